"""High-fidelity three-point bending of composite wire bundles (Sec. 4.1).

The virtual test of Fig. 10: the wires are fibre beams at their places in the bundle
section, the tube, tape and fabric are shells, the rollers and the loading pin
(feeder) are rigid 5 mm cylinders; wire-wire, wire-covering and pin-covering
contacts carry Coulomb friction (eq. 6 between wires, mu_rtb / mu_rtp at the pins),
the tape is bonded to the tube and to the wire ends by the damaging cohesive law of
eqs. 7-10, and the whole is integrated by explicit central differences with mass
scaling f_m and the stable step of eq. 11 (:mod:`harnesspipe.fe.solvers.central_difference`).

Time.  The test pushes the feeder 30 mm at 0.5 mm/s: 60 s of physical time
(``t_phys``).  The simulation runs it in ``t_total`` simulated seconds (the paper:
1 s with f_m = 25) at a constant rate too, reached from rest over the first
``rate_ramp`` of the run; eq. 6 needs slip rates in physical time, so contact kernels
get ``time_scale`` = the model's feeder rate over the test's, t_phys / (t_total
(1 - rate_ramp / 2)).  A smooth step over the whole run instead (rates 0 to 1.9x the
test's) let the wires stick at its slow end, where eq. 6 rises to mu_s, and slip: the
fabric CWBs lost 70-78 % of their force in the last 0.03 mm (bench/RESULTS.md).

Energies (families of forces ON the nodes, see :mod:`harnesspipe.fe.solvers.central_difference`):
``internal`` (beams and shells: elastic + plastic; the plastic part is computed in
closed form from the hardening history), ``contact`` (penalty energy of all normal
contacts), ``friction`` (wire-wire, wire-covering and pin dissipation), ``cohesive``
(tape bonds: elastic + damage dissipation), ``damping`` (mass-proportional
damping, zero unless set) and the work ``W_ext`` of the moving feeder.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numba
import numpy as np
import pandas as pd

from harnesspipe.fe.assembly.groups import Cylinders, PinFacets, WirePins
from harnesspipe.fe.assembly.lanes import stack_groups
from harnesspipe.fe.contact.facet_pins import facets_cylinder_gaps
from harnesspipe.fe.solvers.central_difference import DynamicsSettings, integrate, ramp_share
from harnesspipe.models import hifi_mesh as hm
from harnesspipe.models.hifi_bundle import (FAMILIES, KE_IE_FROM, BundleSystem, HifiInputs,
                                            quasi_static_ratio)
from harnesspipe.models.hifi_parts import Pins

PIN_PATCHES = 4          # contacts of one shell part with one pin at most (connected patches: an open tube's lips)
I8, F8 = np.int64, float
PIN_FACET_SPEC = {"quads": ((4,), I8), "t": ((), F8), "slack": ((), F8),
                  "hist_q": ((PIN_PATCHES,), I8), "hist": ((PIN_PATCHES, 3), F8)}   # pins vs shells


class HifiSystem(BundleSystem):
    """The assembled virtual three-point test; the system protocol of :mod:`harnesspipe.fe.solvers.central_difference`."""

    def __init__(self, mesh, inp: HifiInputs):
        super().__init__(mesh, inp)
        tp = inp.config["three_point"]
        ramp = float(inp.explicit["rate_ramp"])
        self.pins = Pins(mesh.rollers["centres"], mesh.rollers["radius"], 2, tp["deflection"], self.T,
                         ramp)
        self.time_scale = float(inp.explicit["t_phys"]) / (self.T * ramp_share(ramp))   # model rate / test's
        centre = int(np.argmin(np.hypot(*mesh.wire_yz.T)))
        mid = mesh.wire_nodes[centre, mesh.wire_nodes.shape[1] // 2]
        self.free[mid, 0] = self.free[mid, 2] = False    # axial and lateral rigid-body modes
        self._setup_pin_contacts()
        self.pin_args, self.cyl_force = self._pin_cylinders()
        self.last_force = 0.0                # mean feeder force of the last history row

    def _setup_pin_contacts(self):
        """The wires against the pins as chains; the shells in one facet set per part (tube,
        fabric, tape: its own friction coefficient, its penalty from the part's lightest
        node), each patch of it touching a pin at its closest point
        (:func:`facets_cylinder_contact`; PIN_PATCHES: an open tube's two lips, tape
        pieces)."""
        mesh, itf = self.mesh, self.inp.interface
        m = self.mass[:, 0]
        self.wire_pins = self._wire_pin_contact(m)
        self.pin_groups = []
        if not self.has_shells:
            return
        for part in (hm.PART_TUBE, hm.PART_FABRIC, hm.PART_TAPE):
            sel = mesh.shell_part == part
            if not sel.any():
                continue
            quads = np.ascontiguousarray(self.sconn[sel])
            t = np.ascontiguousarray(mesh.shell_thickness[sel], dtype=float)
            p = self.pins
            gaps = facets_cylinder_gaps(self.x, quads, t, p.centres, p.axes, p.radii)
            mu = itf["mu_rtp"] if part == hm.PART_TAPE else itf["mu_rtb"]
            self.pin_groups.append(dict(
                quads=quads, t=t, slack=np.maximum(-gaps, 0.0),    # strain-free start
                mu=float(mu), k=self._penalty(m[np.unique(quads)]),
                hist_q=np.full((self.pins.c0.shape[0], PIN_PATCHES), -1, dtype=np.int64),
                hist=np.zeros((self.pins.c0.shape[0], PIN_PATCHES, 3))))

    def _wire_pin_contact(self, m) -> dict:
        """The wires against the pins as chains (:func:`chain_cylinder_contact`): the
        segments of each wire run consecutively along it in ``seg``.  A bare wire on a pin
        is PVC insulation on steel, the pair of the roller-tape coefficient ``mu_rtp``
        (assumption: the paper names none; its wires meet the pins only through a tube,
        tape or fabric -- where a wire does reach a pin, in a TWB between the tape's wraps,
        the roller-tube ``mu_rtb`` of a polypropylene tube has no bearing)."""
        body = self.seg_body
        if np.any(np.diff(body) < 0) or np.any(self.seg[1:, 0][body[1:] == body[:-1]]
                                                != self.seg[:-1, 1][body[1:] == body[:-1]]):
            raise ValueError("hi-fi mesh: wire segments must run consecutively along each wire")
        if np.unique(self.seg).size != self.seg.shape[0] + self.mesh.n_wires:   # s + 1 nodes a wire
            raise ValueError("hi-fi mesh: wires must not share nodes (the pin contact moves "
                             "the wires' nodes in parallel, wire by wire)")
        start = np.searchsorted(body, np.arange(self.mesh.n_wires + 1)).astype(np.int64)
        return dict(start=start, mu=float(self.inp.interface["mu_rtp"]),
                    k=self._penalty(m[:self.nw]), hist=np.zeros((self.mesh.n_wires, 3, 3)))

    def _move_loading(self, t):
        self.pins.move_to(t)

    def _pin_cylinders(self):
        """The pins as the rigid cylinders of :func:`bundle_forces`: against the wires as
        chains and against each shell part's facets (the groups stacked; their histories
        become views of the stacked ones).  The pins' centres and velocities are the very
        arrays :meth:`_move_loading` updates."""
        p, w = self.pins, self.wire_pins
        arrays, off = stack_groups(self.pin_groups, PIN_FACET_SPEC, shared=("hist_q", "hist"))
        prm = np.array([[g["mu"], g["k"]] for g in self.pin_groups], dtype=float).reshape(-1, 2)
        pin_args = (Cylinders(p.centres, p.axes, p.radii, p.velocity),
                    WirePins(w["start"], w["mu"], w["k"], w["hist"]),
                    PinFacets(**arrays, prm=prm, off=np.ascontiguousarray(
                        np.stack([off["quads"], off["slack"]], axis=1))))
        return pin_args, p.force

    def external_work(self, t0, t1) -> float:
        """Work of the pins on the system (:meth:`Pins.work`)."""
        return self.pins.work(t0, t1)

    def observe(self, t) -> dict:
        """History row.  ``force_N`` (feeder), ``roller_force_N`` and ``deflection_mm`` are
        the load cell's MEANS since the previous row (:meth:`Pins.read`); the instantaneous
        ones are ``force_N_instant`` and ``deflection_mm_end``; ``tie_opening_mm`` is the
        largest separation any tape tie has reached so far (:meth:`tie_separation_max`)."""
        p = self.pins
        f, u = p.read()
        self.last_force = float(f[p.feeder, 1])
        return {"deflection_mm": u, "deflection_mm_end": p.feeder_displacement(),
                "force_N": float(f[p.feeder, 1]),
                "roller_force_N": float(-f[:p.feeder, 1].sum()),
                "force_N_instant": float(p.force[p.feeder, 1]),
                "plastic": self.plastic_work(), "contacts": self.active,
                "debonded_ties": self.debonded(), "tie_opening_mm": self.tie_separation_max()}


@dataclass
class HifiRun:
    """Result of one virtual test."""

    curve: pd.DataFrame          # deflection_mm, force_N (feeder)
    history: pd.DataFrame        # time, energies by family, W_ext, balance, observations
    slip_out: pd.DataFrame       # wire, type, left_mm, right_mm (axial slip relative to the covering ends)
    shapes: dict = field(default_factory=dict)   # deflection (mm) -> node positions (n, 3)
    summary: dict = field(default_factory=dict)
    mesh: object = None


def _slip_out(system) -> pd.DataFrame:
    """Axial displacement of each wire end minus that of the covering's end (or of the
    bundle's mean end for a covering-less TWB): positive = the wire pulled in."""
    mesh, x = system.mesh, system.x
    ux = x[:, 0] - mesh.X[:, 0]
    ends = mesh.wire_nodes[:, [0, -1]]
    ref = ux[ends].mean(axis=0)
    cov = np.flatnonzero(mesh.shell_part != hm.PART_TAPE) if system.has_shells else np.array([], int)
    if cov.size:
        nodes = np.unique(system.sconn[cov])
        X = mesh.X[nodes, 0]
        ref = np.array([ux[nodes[X <= X.min() + 1e-6]].mean(), ux[nodes[X >= X.max() - 1e-6]].mean()])
    return pd.DataFrame({"wire": np.arange(mesh.n_wires), "type": mesh.wire_type,
                         "left_mm": ux[ends[:, 0]] - ref[0], "right_mm": -(ux[ends[:, 1]] - ref[1])})


def force_drop(u, F) -> dict:
    """The largest fall of the feeder force below its running peak: ``drop_N`` = max over
    the run of max(F up to u) - F(u), the deflections of that peak and of the trough
    (``from_mm``, ``to_mm``) and ``fraction`` = drop / peak.  A fall over a few mm with a
    burst of kinetic energy is a snap of the specimen (bench/RESULTS.md "Force drops of the
    virtual tests": the compressed wires buckling in the covering's clearance); a fall
    over the whole stroke is softening.  A force that never falls gives drop 0."""
    u, F = np.asarray(u, dtype=float), np.asarray(F, dtype=float)
    if F.size == 0:
        return {"drop_N": 0.0, "fraction": 0.0, "from_mm": 0.0, "to_mm": 0.0}
    fall = np.maximum.accumulate(F) - F
    i = int(np.argmax(fall))
    j = int(np.argmax(F[:i + 1]))
    peak = float(F[j])
    return {"drop_N": float(fall[i]), "fraction": float(fall[i] / peak) if peak > 0.0 else 0.0,
            "from_mm": float(u[j]), "to_mm": float(u[i])}


def tie_opening_at(history: pd.DataFrame, u: float) -> float | None:
    """The tape ties' largest opening once the feeder had reached ``u`` mm (the history's
    ``tie_opening_mm``, :meth:`HifiSystem.observe`); None when the history does not record
    it or ends before ``u``."""
    if "tie_opening_mm" not in history or history["deflection_mm"].max() < u:
        return None
    return float(np.interp(u, history["deflection_mm"], history["tie_opening_mm"]))


FALL_FRACTION = 0.1   # a fall of at least this fraction of the peak force is flagged (:func:`is_fall`) ...
SNAP_SPAN_MM = 5.0    # ... and called a snap within this deflection of the peak (:func:`is_snap`)


def is_fall(drop: dict | None) -> bool:
    """Whether a :func:`force_drop` loses at least ``FALL_FRACTION`` of the peak force (the
    tests' mean curves never do: their largest fall is 4 %)."""
    return bool(drop) and drop["fraction"] >= FALL_FRACTION


def is_snap(drop: dict | None) -> bool:
    """Whether a :func:`force_drop` is a snap: a fall (:func:`is_fall`) within
    ``SNAP_SPAN_MM`` of deflection."""
    return is_fall(drop) and drop["to_mm"] - drop["from_mm"] <= SNAP_SPAN_MM


def end_time(T: float, stop_deflection: float, stroke: float, ramp: float) -> float:
    """Time at which the feeder (:func:`harnesspipe.fe.solvers.central_difference.rate_ramp`
    over the loading time ``T`` to ``stroke``) reaches ``stop_deflection``; ``T`` when that
    is 0 or not below the stroke.  A fit on a deflection window that ends early needs no
    more of the test (friction: < 20 mm)."""
    from harnesspipe.fe.solvers.central_difference import rate_ramp_time
    if stop_deflection <= 0.0 or stop_deflection >= stroke:
        return T
    return T * rate_ramp_time(stop_deflection / stroke, ramp)


def _reject(res, system, ke_ie: float, explicit: dict) -> None:
    """Raise ExplicitError for a finished run that is not a valid quasi-static test: KE/IE
    above ``ke_ie_fail`` or an energy balance error (largest over the run, relative to the
    final external work) above ``energy_fail``."""
    from harnesspipe.fe.solvers.central_difference import ExplicitError
    h = res.history.iloc[-1]
    state = (res.n_steps, system.T, h["KE"], h["internal"], h["W_ext"], res.dt)
    if ke_ie > explicit["ke_ie_fail"]:
        raise ExplicitError(f"max KE/IE {ke_ie:.3g} > {explicit['ke_ie_fail']:g} once the feeder "
                            f"passed {KE_IE_FROM:.0%} of the stroke (not quasi-static: raise t_total)",
                            *state)
    if res.energy_error > explicit["energy_fail"]:
        raise ExplicitError(f"energy balance error {res.energy_error:.3g} of the external work > "
                            f"{explicit['energy_fail']:g} (explicit.energy_fail: unresolved "
                            "dynamics, lower the safety factor)", *state)


def three_point(inp: HifiInputs, n_shapes: int = 4, settings: DynamicsSettings | None = None,
                progress=None) -> HifiRun:
    """Run the virtual three-point test; raises ExplicitError when the run goes unstable, its
    KE/IE exceeds ``config.explicit.ke_ie_fail`` (a quasi-static test that is not) or its
    energy balance error ``config.explicit.energy_fail`` (see :func:`_reject`).  The
    summary reports KE/IE against the paper's target ``config.explicit.ke_ie_max`` (2 %)
    as ``quasi_static``.  ``progress``, if given, is called at every history row with
    ``step, time_fraction, deflection_mm, force_N`` (the row's mean feeder force) and
    ``stroke_mm`` (the deflection the run ends at)."""
    t0 = time.perf_counter()
    mesh = hm.build_mesh(inp.case, inp.config, inp.resolution)
    system = HifiSystem(mesh, inp)
    ex = inp.explicit
    settings = settings or DynamicsSettings(safety=ex["safety"], n_output=200)
    shapes = {}
    marks = np.linspace(0.0, 1.0, n_shapes + 1)
    state = {"next": 0}

    stroke = inp.config["three_point"]["deflection"]
    stop = ex.get("stop_deflection", 0.0)
    t_end = end_time(system.T, stop, stroke, system.pins.ramp)

    def on_output(step, t):
        while state["next"] < marks.size and t >= marks[state["next"]] * t_end - 1e-12:
            shapes[round(float(system.pins.feeder_displacement()), 6)] = system.x.copy()
            state["next"] += 1
        if progress is not None:
            progress(step=step, time_fraction=t / t_end,
                     deflection_mm=float(system.pins.feeder_displacement()),
                     force_N=system.last_force,
                     stroke_mm=stop if 0.0 < stop < stroke else stroke)

    res = integrate(system, t_end, settings, on_output=on_output)
    hist = res.history
    ke_ie = quasi_static_ratio(hist, inp.config["three_point"]["deflection"],
                               float(inp.explicit.get("ke_ie_from", KE_IE_FROM)))
    _reject(res, system, ke_ie, inp.config["explicit"])
    curve = hist[["deflection_mm", "force_N"]].copy()
    summary = {
        "wall_s": time.perf_counter() - t0, "solver_wall_s": res.wall_s, "steps": res.n_steps,
        "dt": res.dt, "f_m": ex["f_m"], "t_total": system.T, "time_scale": system.time_scale,
        "stop_deflection": float(ex.get("stop_deflection", 0.0)),
        "ke_ie_max": ke_ie, "ke_ie_max_after_ramp": res.ke_ie_max,
        "quasi_static": bool(ke_ie <= inp.config["explicit"]["ke_ie_max"]),
        "energy_error": res.energy_error,
        "n_beam_elements": int(mesh.beam_conn.shape[0]), "n_shell_elements": int(mesh.shell_conn.shape[0]),
        "n_nodes": int(mesh.n_nodes), "n_ties": system.n_ties(),
        "contact_pairs_max": int(system.pairs_max), "contact_searches": system.searches,
        "threads": numba.get_num_threads(),     # at the end (a chain's run may change it: hifi_chain)
        "energies": {k: float(hist[k].iloc[-1]) for k in (*FAMILIES, "KE", "W_ext", "plastic")},
        "debonded_ties": system.debonded(),
        "tie_separation_max_mm": system.tie_separation_max(),
        "force_drop": force_drop(curve["deflection_mm"], curve["force_N"]),
        "phase_s": {**system.phase, "integrator and bookkeeping": res.wall_s - sum(system.phase.values())},
        "shell_mass_scale": system.shell_mass_scale,
        "added_mass_fraction": system.added_mass_fraction,
    }
    return HifiRun(curve, hist, _slip_out(system), shapes, summary, mesh)
