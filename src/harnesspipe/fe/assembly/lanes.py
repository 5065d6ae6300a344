"""The bundle's force families in two concurrent lanes.

Each force kernel could run in parallel on its own (a ``prange`` over chunks), but then
both threads meet at a barrier after every kernel, wait through every kernel's serial
part (scatters, history commits) and pay a thread launch per kernel -- about ten a step.
On the 2 cores this project targets, one ``prange`` over two lanes does better: the
serial kernels run side by side,

* lane 0: the wire-wire contact
  (:func:`harnesspipe.fe.contact.wire_wire.beam_beam_contact`), the node-facet
  contact sets (:func:`~harnesspipe.fe.contact.node_facet.node_facet_contact_serial`) and
  the beams ``0 .. split - 1`` (:func:`harnesspipe.fe.elements.beam_explicit.beam_range_forces`);
* lane 1: the shells (:func:`harnesspipe.fe.elements.shell_bt.shell_element_forces_serial`), the
  cohesive ties (:func:`~harnesspipe.fe.contact.cohesive_ties.cohesive_ties_quad_serial`,
  :func:`~harnesspipe.fe.contact.cohesive_ties.cohesive_ties_beam`), the rigid cylinders (the
  pins) against wires and shells and the beams ``split .. n - 1``,

with one barrier at the end, after which the beams' forces are scattered to their nodes
(the two ranges share a node).  The contact's cost grows with the number of touching
pairs over a run and differs between bundles, so the split that balances the lanes is
found and followed from the calls' wall time (:class:`BeamSplit`).  The lanes write
disjoint memory: the beams add into the wire nodes' rows of the element family, the
shells into the shell nodes' rows (the mesh keeps wire and shell nodes apart;
:func:`check_disjoint`), the bundle's contacts (lane 0), the ties and the cylinders'
contacts (lane 1) into their own families.  The results are those of the separate kernels called one after the other, bit
for bit: every kernel does the same arithmetic in the same order, whatever the split.
Other loadings (the branch test's strand) stay with the system that owns them.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from harnesspipe.fe.assembly.groups import Cylinders, PinFacets, WirePins
from harnesspipe.fe.contact.cohesive_ties import (BeamTieSet, QuadTieSet, TieLaw,
                                                   cohesive_ties_beam, cohesive_ties_quad_serial)
from harnesspipe.fe.contact.facet_pins import PinFacetSet, facets_cylinder_contact
from harnesspipe.fe.contact.node_facet import FacetSet, node_facet_contact_serial
from harnesspipe.fe.contact.wire_pins import WireChains, chain_cylinder_contact_serial
from harnesspipe.fe.contact.wire_wire import beam_beam_contact
from harnesspipe.fe.elements.beam_explicit import beam_range_forces, beam_scatter
from harnesspipe.fe.elements.shell_bt import scatter_add, shell_element_forces_serial


def check_disjoint(beam_conn, shell_conn) -> None:
    """The lanes need the beams' and the shells' nodes apart (their element forces are
    added into the same family concurrently)."""
    shared = np.intersect1d(beam_conn, shell_conn)
    if shared.size:
        raise ValueError(f"bundle mesh: {shared.size} nodes are shared by beams and shells "
                         f"(e.g. node {shared[0]}); the concurrent force lanes need them apart")


@njit(cache=True, parallel=True)
def bundle_forces(x, quat, v, dt, time_scale, beam_split, beams, shells, wires, facets,
                  quad_ties, beam_ties, law, pins, wire_pins, pin_facets, forces):
    """Element forces ON the nodes added into ``forces.f_el``, the bundle contacts' normal
    and friction forces into ``f_n``, ``f_t``, the cohesive ties' into ``f_c`` and the
    pins' contacts into ``f_pn``, ``f_pt`` (and ON the pins into ``f_cyl``), in the two
    lanes of the module docstring; histories advance in place as in the separate kernels.

    Args:
        x: (n_nodes, 3) positions; quat: (n_nodes, 4) nodal rotations;
        v: (n_nodes, 6) half-step velocities; dt: the step;
        time_scale: physical / simulated duration (eq. 6 rates in physical time);
        beam_split: the first beam of lane 1 (any split gives the same result);
        beams, shells, wires, facets, quad_ties, beam_ties, law, pins, wire_pins,
        pin_facets, forces: the groups of :mod:`harnesspipe.fe.assembly.groups`.

    Returns the number of active contacts (wire-wire pairs, node-facet and pin contacts)."""
    n_el = beams.conn.shape[0]
    split = min(max(beam_split, 0), n_el)
    n_act = np.empty(2, dtype=np.int64)
    for lane in prange(2):
        if lane == 0:
            n_act[0] = _lane_contact(x, v, dt, time_scale, wires, facets, forces)
            _beam_range(0, split, x, quat, beams)
        else:
            _lane_shells_ties(x, v, quat, dt, shells, wires.seg, quad_ties, beam_ties, law,
                              forces)
            n_act[1] = _cylinders(x, v, dt, wires, pins, wire_pins, pin_facets, forces)
            _beam_range(split, n_el, x, quat, beams)
    beam_scatter(beams.conn, beams.f_el, forces.f_el, -1.0)
    return n_act[0] + n_act[1]


@njit(cache=True)
def _beam_range(lo, hi, x, quat, b):
    """Element forces of the beams ``lo .. hi - 1`` into ``b.f_el``."""
    beam_range_forces(lo, hi, b, x, quat)


@njit(cache=True)
def _lane_contact(x, v, dt, time_scale, w, fs, forces):
    """Lane 0's contacts: wire-wire, then the node-facet sets; returns the active count."""
    n = beam_beam_contact(x, v, w, dt, time_scale, forces.f_n, forces.f_t)
    return n + _facet_sets(x, v, dt, time_scale, fs, forces)


@njit(cache=True)
def _lane_shells_ties(x, v, quat, dt, sh, seg, quad_ties, beam_ties, law, forces):
    """Lane 1's shells and cohesive ties."""
    shell_element_forces_serial(x, v, sh.conn, sh.thick, sh.mat, sh.state, dt, sh.f_el, sh.hg)
    scatter_add(sh.conn, sh.f_el, forces.f_el, -1.0)
    _ties(x, v, quat, seg, quad_ties, beam_ties, law, forces.f_c)


@njit(cache=True)
def _facet_sets(x, v, dt, time_scale, fs, forces):
    """The node-facet sets one after the other; returns the number of active contacts."""
    n = 0
    off, prm = fs.off, fs.prm
    for g in range(prm.shape[0]):
        n0, n1 = off[g, 0], off[g + 1, 0]
        q0, q1 = off[g, 1], off[g + 1, 1]
        p0, p1 = off[g, 2], off[g + 1, 2]
        fset = FacetSet(fs.nodes[n0:n1], fs.r[n0:n1], fs.quads[q0:q1], fs.t[q0:q1],
                        fs.sign[q0:q1], fs.pairs[p0:p1], prm[g, 0], prm[g, 0], prm[g, 2],
                        prm[g, 3], prm[g, 4], prm[g, 1], fs.hist_p[n0:n1], fs.hist_ft[n0:n1])
        n += node_facet_contact_serial(x, v, fset, dt, time_scale, forces.f_n, forces.f_t)
    return n


@njit(cache=True)
def _ties(x, v, quat, seg, qt, bt, law, f_c):
    """The tie groups in the order of ``law.order``."""
    tie_law = TieLaw(law.K, law.delta0, law.delta_f, law.alpha_d)
    for r in range(law.order.shape[0]):
        g = law.order[r, 1]
        if law.order[r, 0] == 0:
            a, b = qt.off[g, 0], qt.off[g + 1, 0]
            q0, q1 = qt.off[g, 1], qt.off[g + 1, 1]
            ties = QuadTieSet(qt.tie_node[a:b], qt.tie_quad[a:b], qt.tie_xi[a:b],
                              qt.tie_sign[a:b], qt.tie_off[a:b], qt.tie_area[a:b],
                              qt.tie_c[a:b], qt.quads[q0:q1], qt.tie_kappa[a:b], qt.tie_D[a:b],
                              qt.tie_energy[a:b])
            cohesive_ties_quad_serial(x, v, ties, tie_law, f_c)
        else:
            a, b = bt.off[g], bt.off[g + 1]
            ties = BeamTieSet(bt.tie_node[a:b], bt.tie_seg[a:b], bt.tie_s[a:b],
                              bt.tie_anchor[a:b], bt.tie_arm[a:b], bt.tie_axis[a:b],
                              bt.tie_area[a:b], bt.tie_c[a:b], seg, bt.tie_kappa[a:b],
                              bt.tie_D[a:b], bt.tie_energy[a:b])
            cohesive_ties_beam(x, v, quat, ties, tie_law, f_c)


@njit(cache=True)
def _cylinders(x, v, dt, w, p, wp, pf, forces):
    """The pins against the wires, then against each facet group; returns the number of
    active contacts."""
    chains = WireChains(w.seg, w.seg_r, wp.start, wp.mu, wp.k, wp.k, wp.hist)
    n = chain_cylinder_contact_serial(x, v, chains, p, dt, forces.f_pn, forces.f_pt,
                                      forces.f_cyl)
    for g in range(pf.prm.shape[0]):
        q0, q1 = pf.off[g, 0], pf.off[g + 1, 0]
        r0, r1 = pf.off[g, 1], pf.off[g + 1, 1]
        fset = PinFacetSet(pf.quads[q0:q1], pf.t[q0:q1], pf.prm[g, 0], pf.slack[r0:r1],
                           pf.prm[g, 1], pf.prm[g, 1], pf.hist_q[r0:r1], pf.hist[r0:r1])
        n += facets_cylinder_contact(x, v, fset, p, dt, forces.f_pn, forces.f_pt, forces.f_cyl)
    return n


def no_pins():
    """The pin groups of :func:`bundle_forces` for a bundle without pins: zero rows."""
    i8 = np.int64
    pins = Cylinders(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)))
    wire_pins = WirePins(np.zeros(1, dtype=i8), 0.0, 0.0, np.zeros((0, 0, 3)))
    pin_facets = PinFacets(np.zeros((0, 4), dtype=i8), np.zeros(0), np.zeros(0),
                           np.zeros((0, 1), dtype=i8), np.zeros((0, 1, 3)),
                           np.zeros((1, 2), dtype=i8), np.zeros((0, 2)))
    return pins, wire_pins, pin_facets


def stack_groups(groups: list, spec: dict, shared: tuple = ()):
    """The groups' arrays one after the other (axis 0), for :func:`bundle_forces`.
    ``spec``: key -> (trailing shape, dtype) of each array to stack; returns two dicts by
    key: the stacked arrays (C-contiguous, of that dtype) and their offsets
    (n_groups + 1,).  The arrays under ``shared`` -- histories the kernels update in place
    -- are replaced in every group by its view of the stacked array, so that the group
    sees the updates."""
    stacked, offsets = {}, {}
    for key, (tail, dtype) in spec.items():
        parts = [np.asarray(g[key]).reshape(-1, *tail) for g in groups]
        arr = (np.ascontiguousarray(np.concatenate(parts, axis=0), dtype=dtype) if parts
               else np.zeros((0, *tail), dtype=dtype))
        off = np.zeros(len(parts) + 1, dtype=np.int64)
        off[1:] = np.cumsum([q.shape[0] for q in parts])
        if key in shared:
            for g, lo, hi in zip(groups, off[:-1], off[1:]):
                g[key] = arr[lo:hi]
        stacked[key], offsets[key] = arr, off
    return stacked, offsets


class BeamSplit:
    """The beam split of :func:`bundle_forces` that balances its lanes, found
    by hill climbing on the calls' wall time: ``window`` calls at ``centre - delta``, as
    many at ``centre + delta``, then the centre moves by ``delta`` towards the side whose
    fastest call was faster (the fastest: the work of a call is the same from call to
    call, while the machine only ever adds delays).  The balance moves over a run (the
    contact grows, fibres yield) and differs between bundles; the climb follows it.
    Only the speed depends on the split, never the results."""

    def __init__(self, n_beams: int, window: int = 16):
        self.n_beams, self.window = int(n_beams), int(window)
        self.delta = max(1, self.n_beams // 32)
        self.centre = self.n_beams // 2
        self.fastest = [np.inf, np.inf]
        self.calls = 0

    def _side(self) -> int:
        return (self.calls // self.window) % 2

    def current(self) -> int:
        """The split for the next call."""
        return min(max(self.centre + (2 * self._side() - 1) * self.delta, 0), self.n_beams)

    def record(self, seconds: float) -> None:
        """The wall time of the call made at :meth:`current`."""
        side = self._side()
        self.fastest[side] = min(self.fastest[side], seconds)
        self.calls += 1
        if self.calls % (2 * self.window) == 0:
            step = self.delta if self.fastest[1] < self.fastest[0] else -self.delta
            self.centre = min(max(self.centre + step, 0), self.n_beams)
            self.fastest = [np.inf, np.inf]
