"""The bundle's forces kernel by kernel: each family's own kernel (the parallel one where
a family has one) called on its own, one after the other, as before the concurrent lanes
(:mod:`harnesspipe.fe.assembly.lanes`).

The lanes must give these forces and histories bit for bit (tests/test_bundle_lanes.py),
and the benchmark times each family with them (bench/bench_hifi.py).  Not used by a run:
it lives with the tests.
"""
from __future__ import annotations

import time

import numpy as np

from harnesspipe.fe.contact.cohesive_ties import (BeamTieSet, QuadTieSet, TieLaw, cohesive_ties_beam,
                                                   cohesive_ties_quad, tie_set)
from harnesspipe.fe.contact.common import Cylinders
from harnesspipe.fe.contact.facet_pins import PinFacetSet, facets_cylinder_contact
from harnesspipe.fe.contact.node_facet import FacetSet, node_facet_contact
from harnesspipe.fe.contact.wire_pins import WireChains, chain_cylinder_contact
from harnesspipe.fe.contact.wire_wire import WireContact, beam_beam_contact
from harnesspipe.fe.elements.shell_bt import HOURGLASS_COEF, shell_forces

FAMILY_KERNELS = ("beams", "shells", "wire-wire contact", "node-facet contact",
                  "cohesive ties", "pins")


def history_arrays(s) -> list:
    """Every array a force call of the pinned bundle ``s`` updates in place."""
    b = s.wires.beams
    arrays = [b.eps_p, b.alpha, b.sa_h, s.sstate, *s.ww_hist]
    arrays += [h for fs in s.facet_sets for h in fs["hist"]]
    arrays += [t[k] for t in s.ties for k in ("tie_kappa", "tie_D", "tie_energy")]
    arrays += [s.wire_pins["hist"], s.pins.force]
    arrays += [g[k] for g in s.pin_groups for k in ("hist_q", "hist")]
    return arrays


def save_histories(s) -> list:
    return [a.copy() for a in history_arrays(s)]


def restore_histories(s, saved: list) -> None:
    for a, b in zip(history_arrays(s), saved):
        a[...] = b


def separate_forces(s, v, dt, seconds: dict | None = None):
    """The forces of :meth:`harnesspipe.models.hifi_bundle.BundleSystem._bundle_forces` of the
    pinned bundle ``s`` (a :class:`~harnesspipe.models.hifi.HifiSystem`) into a new
    (6, n, 6) array, family kernel by family kernel; returns it and the number of active
    contacts.  With ``seconds``, each kernel's wall time is added to it under its
    :data:`FAMILY_KERNELS` name."""
    F = np.zeros((6,) + s.mass.shape)
    itf = s.inp.interface
    clock = _Clock(seconds)
    s.wires.add_forces(s.x, s.quat, F[0])
    clock.lap("beams")
    shell_forces(s.x, v, s.sconn, s.sthick, s.smat, s.sstate, dt, s.s_el, F[0],
                 HOURGLASS_COEF, -1.0)
    clock.lap("shells")
    wc = WireContact(s.seg, s.seg_r, s.seg_body, s.ww_pairs, s.k_ww, s.k_ww, itf["mu_s"],
                     itf["mu_k"], itf["d_c"], s.ww_hist[0], s.ww_hist[1])
    n = beam_beam_contact(s.x, v, wc, dt, s.time_scale, F[1], F[2])
    clock.lap("wire-wire contact")
    for fs in s.facet_sets:
        fset = FacetSet(fs["nodes"], fs["r"], fs["quads"], fs["t"], fs["sign"], fs["pairs"],
                        fs["k"], fs["k"], *fs["mu"], fs["pen_max"], *fs["hist"])
        n += node_facet_contact(s.x, v, fset, dt, s.time_scale, F[1], F[2])
    clock.lap("node-facet contact")
    _ties(s, itf, v, F[5])
    clock.lap("cohesive ties")
    n += _pins(s, v, dt, F)
    clock.lap("pins")
    return F, n


class _Clock:
    def __init__(self, seconds):
        self.seconds, self.t = seconds, time.perf_counter()

    def lap(self, name):
        if self.seconds is not None:
            t = time.perf_counter()
            self.seconds[name] = self.seconds.get(name, 0.0) + t - self.t
            self.t = t


def _ties(s, itf, v, f):
    law = TieLaw(s.K_coh, s.delta0, itf["delta_f"], itf["alpha_d"])
    for t in s.ties:
        if t["kind"] == "quad":
            cohesive_ties_quad(s.x, v, tie_set(QuadTieSet, t), law, f)
        else:
            cohesive_ties_beam(s.x, v, s.quat, tie_set(BeamTieSet, t, seg=s.seg), law, f)


def _pins(s, v, dt, F) -> int:
    p, w = s.pins, s.wire_pins
    p.force[...] = 0.0
    cyl = Cylinders(p.centres, p.axes, p.radii, p.velocity)
    chains = WireChains(s.seg, s.seg_r, w["start"], w["mu"], w["k"], w["k"], w["hist"])
    n = chain_cylinder_contact(s.x, v, chains, cyl, dt, F[3], F[4], p.force)
    for g in s.pin_groups:
        fset = PinFacetSet(g["quads"], g["t"], g["mu"], g["slack"], g["k"], g["k"], g["hist_q"],
                           g["hist"])
        n += facets_cylinder_contact(s.x, v, fset, cyl, dt, F[3], F[4], p.force)
    return n
