"""Gauss-Newton descent of a sum of squares in ln p.

S(p) = ||r(p)||^2 over the residual r of a model against a curve, minimised over the
parameters ``names`` (the others held) by Gauss-Newton steps in ln p: each step the
least-squares solution of J d = r, J = -dr / d ln p = dF / d ln p by central differences
(:func:`harnesspipe.calibrate.uncertainty.log_sensitivities`; the valleys of these fits are
narrow, a forward-difference direction stalls in them), moving no ln p by more than
MAX_STEP and halved until S decreases (a point where the model fails counts as
S = infinity).  It ends when a step lowers S by less than ``tol``, when no halving of a
step lowers it, or after ``steps`` steps.

Used by the profile likelihood's inner minimisation (:mod:`harnesspipe.calibrate.profile`)
and by the ROM's least-squares refinement after the simplex (:mod:`harnesspipe.calibrate.rom`).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from harnesspipe.calibrate.uncertainty import log_sensitivities

STEPS = 10        # Gauss-Newton steps at most
HALVINGS = 5      # step halvings per step at most
MAX_STEP = 0.5    # a step moves no ln p by more than this


def descend(residual: Callable[[dict], np.ndarray | None], p: dict, names: list[str],
            tol: float, steps: int = STEPS) -> tuple[float, dict]:
    """(S, parameters) at the end of the descent from ``p`` over ``names`` (module
    docstring); ``residual(p)``: r, or None where the model fails or refuses p.  S is
    infinite (and ``p`` returned) where the model fails at the start."""
    p = dict(p)
    r = residual(p)
    if r is None:
        return np.inf, p

    def raising(q: dict) -> np.ndarray:
        found = residual(q)
        if found is None:
            raise ArithmeticError(f"the model fails at {q}")
        return found

    S = float(r @ r)
    for _ in range(steps if names else 0):
        try:
            J = -log_sensitivities(raising, p, list(names))    # dr / d ln p
        except (RuntimeError, ArithmeticError, ValueError):
            break
        step = np.linalg.lstsq(J, r, rcond=None)[0]
        step *= min(1.0, MAX_STEP / max(np.abs(step).max(), 1e-300))   # a trust region in ln p
        for halving in range(HALVINGS):
            trial = {**p, **{k: p[k] * float(np.exp(d * 0.5**halving)) for k, d in zip(names, step)}}
            r_trial = residual(trial)
            if r_trial is not None and float(r_trial @ r_trial) < S:
                break
        else:
            break                                   # no decrease along the step: converged
        S_trial = float(r_trial @ r_trial)
        decrease, p, r, S = S - S_trial, trial, r_trial, S_trial
        if decrease < tol:
            break
    return S, p
