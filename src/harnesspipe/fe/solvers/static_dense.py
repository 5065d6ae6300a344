"""Implicit static Newton-Raphson driver for the shell models (quasi-static tests).

Load and displacement control share one load factor lambda in [0, 1]: driven
DOFs move by ``lambda * drive`` and external loads are ``lambda * loads``.  Each
step starts with a consistent predictor (the prescribed increment is carried into
the free DOFs through the tangent), Newton iterates on the free DOFs with the
consistent tangent, and a step that does not converge is cut in half (the step
grows back to the nominal one after easy steps).

A model takes part through four methods (see :class:`System`): the tangent and
internal force at the trial configuration, an increment of that configuration
(which lets shells update rotations multiplicatively), and accept/reject of the
trial history.  Solver failures raise :class:`ConvergenceError` with diagnostics.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


class ConvergenceError(RuntimeError):
    """Newton did not converge even after the allowed step cuts."""


class System(Protocol):
    n_dof: int

    def tangent_and_force(self):
        """(K, f_int) at the trial configuration; K dense ndarray or scipy sparse."""

    def advance(self, du: np.ndarray) -> None:
        """Move the trial configuration by the increment ``du``."""

    def accept(self) -> None:
        """The trial configuration and history become the converged ones."""

    def reject(self) -> None:
        """Go back to the last converged configuration and history."""


@dataclass
class Controls:
    """Load stepping and Newton tolerances."""

    n_steps: int = 20
    rtol: float = 1e-8        # free residual / reference force
    atol: float = 1e-10       # absolute floor on the free residual (N)
    max_iter: int = 25
    max_cuts: int = 10        # consecutive halvings of one step


@dataclass
class History:
    """Converged load factors and the reactions summed over the driven DOFs."""

    lam: list = field(default_factory=lambda: [0.0])
    reaction: list = field(default_factory=lambda: [0.0])
    iterations: list = field(default_factory=lambda: [0])


def _solve(K, rhs, free):
    if sp.issparse(K):
        Kff = K[free][:, free].tocsc()
        return spla.spsolve(Kff, rhs)
    return np.linalg.solve(K[np.ix_(free, free)], rhs)


def _coupling(K, free, driven, du_driven):
    """K_fd @ du_d: force on free DOFs due to moving the driven ones."""
    if sp.issparse(K):
        return K[free][:, driven] @ du_driven
    return K[np.ix_(free, driven)] @ du_driven


def solve(system: System, fixed, driven=None, drive=None, loads=None,
          controls: Controls | None = None, on_step=None) -> History:
    """Trace the equilibrium path from lambda = 0 to 1.

    ``fixed``: DOFs held at zero; ``driven``/``drive``: DOFs moved to ``drive`` at
    lambda = 1; ``loads``: external load vector at lambda = 1.  ``on_step(lam)``
    is called after each converged step (e.g. to record a tip position).
    """
    controls = controls or Controls()
    n = system.n_dof
    driven = np.asarray([] if driven is None else driven, dtype=np.int64)
    drive = np.asarray([] if drive is None else drive, dtype=float)
    loads = np.zeros(n) if loads is None else np.asarray(loads, dtype=float)
    constrained = np.union1d(np.asarray(fixed, dtype=np.int64), driven)
    free = np.setdiff1d(np.arange(n), constrained)
    hist = History()
    nominal = 1.0 / controls.n_steps
    lam, dlam, cuts = 0.0, nominal, 0
    while lam < 1.0 - 1e-12:
        dlam = min(dlam, 1.0 - lam)
        iters, f_int = _newton_step(system, free, driven, drive * dlam, loads, lam + dlam, controls)
        if iters < 0:
            system.reject()
            cuts += 1
            if cuts > controls.max_cuts:
                raise ConvergenceError(
                    f"Newton failed at load factor {lam:.6g} with step {dlam:.3g} "
                    f"after {controls.max_cuts} cuts ({-iters} iterations, last residual too high)")
            dlam *= 0.5
            continue
        lam += dlam
        hist.lam.append(lam)
        hist.reaction.append(float(f_int[driven].sum()) if driven.size else 0.0)
        hist.iterations.append(iters)
        system.accept()
        cuts = 0
        if iters <= controls.max_iter // 4:
            dlam = min(2.0 * dlam, nominal)  # recover the nominal step after a cut
        if on_step is not None:
            on_step(lam)
    return hist


def _newton_step(system, free, driven, du_driven, loads, lam, controls):
    """Newton iterations for one step: (iteration count or -count on failure, f_int)."""
    K, f_int = system.tangent_and_force()
    du = np.zeros(system.n_dof)
    du[driven] = du_driven
    rhs = lam * loads[free] - f_int[free] - _coupling(K, free, driven, du_driven)
    du[free] = _solve(K, rhs, free)
    system.advance(du)
    ref = max(np.abs(lam * loads).max(), 1.0)
    for it in range(1, controls.max_iter + 1):
        K, f_int = system.tangent_and_force()
        r = lam * loads[free] - f_int[free]
        if not np.all(np.isfinite(r)):
            return -it, f_int
        ref = max(ref, np.abs(f_int).max())
        if np.abs(r).max() <= controls.rtol * ref + controls.atol:
            return it, f_int
        du = np.zeros(system.n_dof)
        du[free] = _solve(K, r, free)
        if not np.all(np.isfinite(du)):
            return -it, f_int
        system.advance(du)
    return -controls.max_iter, f_int
