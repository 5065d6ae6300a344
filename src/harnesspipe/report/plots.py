"""Figures of the report: measured band, mean, simulated curve; optimiser traces."""
from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def _finish(fig, ax, xlabel: str, ylabel: str, title: str, legend_size: int, legend_at="best"):
    """Labels, title, grid and legend of a one-axes figure, laid out; returns the figure."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=legend_size, loc=legend_at)
    fig.tight_layout()
    return fig


def fit_figure(prepared, curve=None, title="", xlabel="displacement [mm]", label="simulated", reference=None):
    """Band (min/max of the replicates), their mean and a simulated curve (with its 95 % band
    when ``curve`` has a ``band_N`` column, the half-width, and the replicates' band when it
    has ``band_replicate_N``); ``reference``
    (displacement_mm, force_N): the hi-fi curve a ROM was fitted to, when not the mean;
    ``prepared`` None: no measured test to show."""
    fig, ax = plt.subplots(figsize=(5.2, 3.6), dpi=110)
    if prepared is not None:
        ax.fill_between(prepared.grid, prepared.lo, prepared.hi, color="0.82", label="measured (min/max)")
        for name, s in sorted(prepared.samples.items()):
            ax.plot(s["displacement_mm"], s["force_N"], color="0.6", lw=0.6)
        ax.plot(prepared.grid, prepared.mean, color="k", lw=1.6 if reference is None else 0.8,
                label="measured mean")
    if reference is not None:
        ax.plot(reference["displacement_mm"], reference["force_N"], color="tab:blue", lw=1.6,
                label="hi-fi virtual test (reference)")
    if curve is not None:
        ax.plot(curve["displacement_mm"], curve["force_N"], color="tab:red", lw=1.6, ls="--", label=label)
        if "band_N" in curve and np.any(np.isfinite(curve["band_N"])):
            x, F, b = (np.asarray(curve[k], dtype=float) for k in ("displacement_mm", "force_N", "band_N"))
            ax.fill_between(x, F - b, F + b, color="tab:red", alpha=0.3, lw=0,
                            label=f"model 95 % band (parameters, \u00b1{np.nanmax(b):.2g} N at most)")
        if "band_replicate_N" in curve and np.any(np.isfinite(curve["band_replicate_N"])):
            x, F, b = (np.asarray(curve[k], dtype=float) for k in ("displacement_mm", "force_N", "band_replicate_N"))
            ax.fill_between(x, F - b, F + b, color="tab:purple", alpha=0.18, lw=0,
                            label=f"model 95 % band (replicates, \u00b1{np.nanmax(b):.2g} N at most)")
    return _finish(fig, ax, xlabel, "force [N]", title, legend_size=8)


def flow_stress_figure(flow: dict, title=""):
    """Eq. 2 flow stress sigma_Y + K eps_p^n of a fit against the plastic strain (log scale)
    and, when there is one, its 95 % band (fit.json ``flow_stress``)."""
    fig, ax = plt.subplots(figsize=(4.2, 3.0), dpi=110)
    eps, sigma = np.asarray(flow["eps_p"], dtype=float), np.asarray(flow["sigma"], dtype=float)
    ax.semilogx(eps, sigma, color="tab:red", lw=1.6, label="fitted")
    if flow.get("band") is not None:
        b = np.asarray(flow["band"], dtype=float)
        ax.fill_between(eps, sigma - b, sigma + b, color="tab:red", alpha=0.3, lw=0, label="95 % band")
    return _finish(fig, ax, "plastic strain", "flow stress [MPa]", title, legend_size=8)


def trace_figure(trace, title=""):
    """Error of every evaluation and the running best (log scale)."""
    fig, ax = plt.subplots(figsize=(5.2, 3.0), dpi=110)
    err = np.asarray(trace["error"], dtype=float)
    k = np.arange(1, err.size + 1)
    ax.semilogy(k, np.where(np.isfinite(err), err, np.nan), ".", color="tab:blue", ms=3, label="evaluation")
    ax.semilogy(k, np.minimum.accumulate(np.where(np.isfinite(err), err, np.inf)), color="k", lw=1.2,
                label="best so far")
    ax.set_xlabel("evaluation")
    ax.set_ylabel(r"$\|e\|_{l_2}$ [N]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def save(fig, path) -> None:
    fig.savefig(path)
    plt.close(fig)


def png_bytes(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


def shape_figure(prepared, shapes, title="", vertical="y"):
    """Bent shapes: measured marker positions (dots) against the model's centre line.

    ``shapes`` holds the model's x, y, z; ``vertical`` (``"y"`` or ``"z"``) is the model axis
    the markers' second coordinate records (``"z"`` for the out-of-plane pull, whose camera
    looks along the harness plane)."""
    fig, ax = plt.subplots(figsize=(5.2, 3.0), dpi=110)
    frames = sorted(set(shapes["displacement_mm"]))
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, max(len(frames), 1)))
    for d, c in zip(frames, colours):
        s = shapes[shapes["displacement_mm"] == d]
        ax.plot(s["x_mm"], s[f"{vertical}_mm"], color=c, lw=1.4, label=f"model, u = {d:g} mm")
        for sample in prepared.samples.values():
            m = sample.get("markers")
            if m is None:
                continue
            m = m[np.isclose(m[:, 1], d)]
            ax.plot(m[:, 3], m[:, 4], "o", ms=3.5, mfc="none", color=c)
    ax.plot([], [], "o", mfc="none", color="0.3", label="markers (3 samples)")
    ax.set_aspect("equal")
    return _finish(fig, ax, "x [mm]", f"{vertical} [mm]", title, legend_size=8, legend_at="lower right")


# --------------------------------------------------------------------------- hi-fi section

def _band(ax, prepared):
    ax.fill_between(prepared.grid, prepared.lo, prepared.hi, color="0.85", label="measured (min/max)")
    ax.plot(prepared.grid, prepared.mean, color="k", lw=1.4, label="measured mean")


def hifi_curve_figure(curves: dict, prepared=None, title="", window=None, xlabel="deflection [mm]"):
    """Hi-fi force-deflection curves (label -> DataFrame deflection_mm/displacement_mm, force_N)
    over the measured band when there is a test."""
    fig, ax = plt.subplots(figsize=(5.2, 3.6), dpi=110)
    if prepared is not None:
        _band(ax, prepared)
    styles = ["--", "-.", ":", "-"]
    for k, (label, c) in enumerate(curves.items()):
        x = c["deflection_mm"] if "deflection_mm" in c else c["displacement_mm"]
        ax.plot(x, c["force_N"], lw=1.6, ls=styles[k % len(styles)], label=label)
    if window is not None:
        ax.axvspan(window[0], window[1], color="tab:orange", alpha=0.08, label="fitted window")
    return _finish(fig, ax, xlabel, "force [N]", title, legend_size=8)


def overlay_figure(curves: dict, prepared=None, title="", xlabel="crosshead displacement [mm]", zoom=None):
    """Model curves (label -> DataFrame displacement_mm, force_N) over the measured band, in two
    stacked panels: the whole test and its first ``zoom`` mm, where curves that differ only in
    the transient (the joint's damping, eq. 15) come apart."""
    fig, axes = plt.subplots(2, 1, figsize=(5.6, 6.4), dpi=110)
    styles = ["--", "-.", ":", "-"]
    for ax, limit in zip(axes, (None, zoom)):
        if prepared is not None:
            _band(ax, prepared)
        for k, (label, c) in enumerate(curves.items()):
            ax.plot(c["displacement_mm"], c["force_N"], lw=1.6, ls=styles[k % len(styles)], label=label)
        if limit is not None:
            x = np.asarray(prepared.grid if prepared is not None else c["displacement_mm"], dtype=float)
            ys = [np.asarray(c["force_N"])[np.asarray(c["displacement_mm"]) <= limit] for c in curves.values()]
            if prepared is not None:
                ys.append(np.asarray(prepared.hi)[x <= limit])
            ax.set_xlim(0.0, limit)
            ax.set_ylim(min(0.0, *(float(np.min(y)) for y in ys if y.size)),
                        1.05 * max(float(np.max(y)) for y in ys if y.size))
        ax.set_xlabel(xlabel)
        ax.set_ylabel("force [N]")
        ax.set_title(title if limit is None else f"first {limit:g} mm", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig


def hifi_cases_figure(prepared: dict, curves: dict, title="", window=None, names=None):
    """One panel per case of a calibration step, stacked (each as wide as a one-panel figure):
    band, mean and the hi-fi curve at the best point; ``names``: case -> title."""
    n = max(len(prepared), 1)
    fig, axes = plt.subplots(n, 1, figsize=(5.6, 3.4 * n), dpi=110, squeeze=False)
    for ax, (case, pr) in zip(axes[:, 0], prepared.items()):
        _band(ax, pr)
        c = curves.get(case)
        if c is not None:
            x = c["deflection_mm"] if "deflection_mm" in c else c["displacement_mm"]
            ax.plot(x, c["force_N"], color="tab:red", lw=1.6, ls="--", label="hi-fi (best point)")
        if window is not None:
            ax.axvspan(window[0], window[1], color="tab:orange", alpha=0.08, label="fitted window")
        ax.set_xlabel("deflection [mm]")
        ax.set_ylabel("force [N]")
        ax.set_title(f"{title}: {(names or {}).get(case, case)}", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    return fig


def hifi_rom_figure(hifi, rom, title="", label="hi-fi (paper's parameters)"):
    """A hi-fi curve and the ROM fitted to it (eq. 13 + simplex)."""
    fig, ax = plt.subplots(figsize=(5.2, 3.6), dpi=110)
    ax.plot(hifi["deflection_mm"], hifi["force_N"], color="k", lw=1.4, label=label)
    ax.plot(rom["displacement_mm"], rom["force_N"], color="tab:red", lw=1.6, ls="--", label="ROM (fitted)")
    ax.set_xlabel("deflection [mm]")
    ax.set_ylabel("force [N]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


ENERGY_COLUMNS = (("KE", "kinetic"), ("internal", "internal"), ("friction", "friction (wires)"),
                  ("pin_friction", "friction (rollers)"), ("cohesive", "cohesive"),
                  ("contact", "contact"), ("damping", "damping"), ("W_ext", "external work"))


def energies_figure(history, title=""):
    """Energy families of a hi-fi run against the feeder deflection (or time)."""
    fig, ax = plt.subplots(figsize=(5.2, 3.6), dpi=110)
    xcol = next((c for c in ("deflection_mm", "displacement_mm") if c in history), "time_s")
    x = history[xcol]
    for col, label in ENERGY_COLUMNS:
        if col in history and (col in ("KE", "internal", "W_ext") or np.any(np.abs(history[col]) > 0)):
            ax.plot(x, history[col], lw=1.8 if col == "W_ext" else 1.2,
                    ls="--" if col == "W_ext" else "-", label=label)
    xlabel = {"deflection_mm": "deflection [mm]", "displacement_mm": "crosshead displacement [mm]",
              "time_s": "time [s]"}[xcol]
    return _finish(fig, ax, xlabel, "energy [N mm]", title, legend_size=8, legend_at="upper left")
