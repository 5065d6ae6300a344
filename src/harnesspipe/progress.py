"""Progress of a hi-fi run on stderr: the callback the command layer hands to the model.

A line every ``every`` (5 %) of the stroke: percent, deflection, force, step, elapsed time
and an ETA from the simulated-time fraction (the explicit steps are near-uniform in time,
the loading ramp is not).  On a terminal one line is rewritten in place (``\\r``) with a
bar; in a log file every update is a line of its own.
"""
from __future__ import annotations

import sys
import time


class Progress:
    """``Progress(label)(step=, time_fraction=, deflection_mm=, force_N=, stroke_mm=)``;
    :meth:`close` ends the terminal line."""

    def __init__(self, label: str, stream=None, every: float = 0.05, clock=time.perf_counter,
                 travel: str = "deflection"):
        self.label, self.stream, self.every, self.clock = label, stream or sys.stderr, every, clock
        self.travel = travel         # what the stroke is called: deflection, displacement
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.t0 = clock()
        self.t_start = None          # wall time of the first step (after mesh and compile)
        self.next = 0.0              # the next stroke fraction to report
        self.open = False

    def __call__(self, *, step: int, time_fraction: float, deflection_mm: float, force_N: float,
                 stroke_mm: float) -> None:
        now = self.clock()
        if self.t_start is None:
            self.t_start = now
        fraction = min(max(deflection_mm / stroke_mm, 0.0), 1.0) if stroke_mm > 0 else 1.0
        done = time_fraction >= 1.0 - 1e-9
        if fraction + 1e-9 < self.next and not done:
            return
        while self.next <= fraction + 1e-9:
            self.next += self.every
        if done:
            self.next = float("inf")
        eta = ((now - self.t_start) * (1.0 - time_fraction) / time_fraction
               if time_fraction > 0.0 else None)
        text = (f"{self.label}: {100.0 * fraction:3.0f} %  {self.travel} {deflection_mm:6.2f} of "
                f"{stroke_mm:g} mm  force {force_N:8.3f} N  step {step}  elapsed "
                f"{now - self.t0:.0f} s  ETA {'?' if eta is None else f'{eta:.0f} s'}")
        if self.tty:
            bar = "#" * round(20 * fraction)
            self.stream.write(f"\r[{bar:<20}] {text}\x1b[K")
            self.open = True
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def close(self) -> None:
        """End the updating line on a terminal (before any other output)."""
        if self.open:
            self.stream.write("\n")
            self.stream.flush()
            self.open = False
