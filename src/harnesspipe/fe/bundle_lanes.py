"""The bundle's force families in two concurrent lanes.

Each force kernel could run in parallel on its own (a ``prange`` over chunks), but then
both threads meet at a barrier after every kernel, wait through every kernel's serial
part (scatters, history commits) and pay a thread launch per kernel -- about ten a step.
On the 2 cores this project targets, one ``prange`` over two lanes does better: the
serial kernels run side by side,

* lane 0: the wire-wire contact
  (:func:`harnesspipe.fe.contact_explicit.beam_beam_contact_serial`), the node-facet
  contact sets (:func:`~harnesspipe.fe.contact_explicit.node_facet_contact_serial`) and
  the beams ``0 .. split - 1`` (:func:`harnesspipe.fe.beam_explicit.beam_range_forces`);
* lane 1: the shells (:func:`harnesspipe.fe.shell_bt.shell_element_forces_serial`), the
  cohesive ties (:func:`~harnesspipe.fe.contact_explicit.cohesive_ties_quad_serial`,
  :func:`~harnesspipe.fe.contact_explicit.cohesive_ties_beam`), the rigid cylinders (the
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

from harnesspipe.fe.beam_explicit import beam_range_forces, beam_scatter
from harnesspipe.fe.contact_explicit import (beam_beam_contact_serial,
                                             chain_cylinder_contact_serial, cohesive_ties_beam,
                                             cohesive_ties_quad_serial, facets_cylinder_contact,
                                             node_facet_contact_serial)
from harnesspipe.fe.shell_bt import scatter_add, shell_element_forces_serial


def check_disjoint(beam_conn, shell_conn) -> None:
    """The lanes need the beams' and the shells' nodes apart (their element forces are
    added into the same family concurrently)."""
    shared = np.intersect1d(beam_conn, shell_conn)
    if shared.size:
        raise ValueError(f"bundle mesh: {shared.size} nodes are shared by beams and shells "
                         f"(e.g. node {shared[0]}); the concurrent force lanes need them apart")


@njit(cache=True, parallel=True)
def bundle_forces(
        X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z, sec_area, sec_GJ, sec_id, mats,
        eps_p, alpha, sa_h, b_el, beam_split,                       # beams
        v, sconn, sthick, smat, sstate, dt, s_el, hg,               # shells
        seg, seg_r, seg_body, pairs, k_n, k_t, mu_s, mu_k, d_c, time_scale, hist_partner,
        hist_ft,                                                    # wire-wire contact
        fs_nodes, fs_r, fs_quads, fs_t, fs_sign, fs_pairs, fs_hist_p, fs_hist_ft, fs_off,
        fs_prm,                                                     # node-facet sets
        qt_node, qt_quad, qt_xi, qt_sign, qt_offset, qt_area, qt_c, qt_quads, qt_kappa, qt_D,
        qt_energy, qt_off,                                          # ties to quads
        bt_node, bt_seg, bt_s, bt_anchor, bt_arm, bt_axis, bt_area, bt_c, bt_kappa, bt_D,
        bt_energy, bt_off,                                          # ties to beams
        K, delta0, delta_f, alpha_d, tie_order,                     # cohesive law
        cyl_c, cyl_axis, cyl_R, cyl_v, chain_start, chain_mu, chain_k, chain_hist, pf_quads,
        pf_t, pf_slack, pf_hist_q, pf_hist, pf_off, pf_prm,         # rigid cylinders (pins)
        f_el, f_n, f_t, f_c, f_pn, f_pt, f_cyl):
    """Element forces ON the nodes added into ``f_el``, the contacts' normal and friction
    forces into ``f_n``, ``f_t`` and the cohesive ties' into ``f_c``, in the two lanes of
    the module docstring; histories advance in place as in the separate kernels.

    Arguments as :func:`~harnesspipe.fe.beam_explicit.beam_forces` (``b_el`` its scratch;
    the beams' material ids are their section ids; ``beam_split`` the first beam of lane
    1), :func:`~harnesspipe.fe.shell_bt.shell_forces` (``s_el`` its scratch, ``hg`` the
    hourglass coefficient) and :func:`~harnesspipe.fe.contact_explicit.beam_beam_contact`.
    The node-facet sets (``fs_*``), the tie groups to quads (``qt_*``) and to beams
    (``bt_*``) come as their arrays one after the other (:func:`stack_groups`), group
    ``g`` at rows ``off[g] .. off[g + 1] - 1`` (``fs_off`` (n + 1, 3): nodes, quads,
    pairs; ``qt_off`` (n + 1, 2): ties, quads; ``bt_off`` (n + 1,)); ``fs_prm`` (n, 5)
    the sets' (k, pen_max, mu_s, mu_k, d_c); the groups' pair and tie indices are their
    own.  The ties act in the order of ``tie_order`` rows (kind 0: quad, 1: beam; group),
    with the cohesive law's ``K, delta0, delta_f, alpha_d`` (eqs. 7-10).  Rigid cylinders
    (the test's pins; none: zero rows) meet the wires as chains
    (:func:`~harnesspipe.fe.contact_explicit.chain_cylinder_contact`: ``chain_*``) and the
    stacked shell facet groups
    (:func:`~harnesspipe.fe.contact_explicit.facets_cylinder_contact`: ``pf_*``, ``pf_off``
    (n + 1, 2): quads, rows of the per-cylinder arrays; ``pf_prm`` (n, 2): mu, penalty),
    their forces into ``f_pn``, ``f_pt`` and ``f_cyl`` (ON the cylinders).  Returns the
    number of active contacts (wire-wire pairs, node-facet and cylinder contacts)."""
    n_el = conn.shape[0]
    split = min(max(beam_split, 0), n_el)
    n_act = np.empty(2, dtype=np.int64)
    for lane in prange(2):
        if lane == 0:
            n = beam_beam_contact_serial(x, v, seg, seg_r, seg_body, pairs, k_n, k_t, mu_s,
                                         mu_k, d_c, dt, time_scale, hist_partner, hist_ft,
                                         f_n, f_t)
            n += _facet_sets(x, v, fs_nodes, fs_r, fs_quads, fs_t, fs_sign, fs_pairs,
                             fs_hist_p, fs_hist_ft, fs_off, fs_prm, dt, time_scale, f_n, f_t)
            n_act[0] = n
            beam_range_forces(0, split, X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z,
                              sec_area, sec_GJ, sec_id, mats, sec_id, eps_p, alpha, sa_h, b_el)
        else:
            shell_element_forces_serial(x, v, sconn, sthick, smat, sstate, dt, s_el, hg)
            scatter_add(sconn, s_el, f_el, -1.0)
            _ties(x, v, quat, seg, qt_node, qt_quad, qt_xi, qt_sign, qt_offset, qt_area, qt_c,
                  qt_quads, qt_kappa, qt_D, qt_energy, qt_off, bt_node, bt_seg, bt_s, bt_anchor,
                  bt_arm, bt_axis, bt_area, bt_c, bt_kappa, bt_D, bt_energy, bt_off, K, delta0,
                  delta_f, alpha_d, tie_order, f_c)
            n_act[1] = _cylinders(x, v, seg, seg_r, cyl_c, cyl_axis, cyl_R, cyl_v, chain_start,
                                  chain_mu, chain_k, chain_hist, pf_quads, pf_t, pf_slack,
                                  pf_hist_q, pf_hist, pf_off, pf_prm, dt, f_pn, f_pt, f_cyl)
            beam_range_forces(split, n_el, X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z,
                              sec_area, sec_GJ, sec_id, mats, sec_id, eps_p, alpha, sa_h, b_el)
    beam_scatter(conn, b_el, f_el, -1.0)
    return n_act[0] + n_act[1]


@njit(cache=True)
def _facet_sets(x, v, nodes, r, quads, t, sign, pairs, hist_p, hist_ft, off, prm, dt,
                time_scale, f_n, f_t):
    """The node-facet sets of :func:`bundle_forces` one after the other; returns the
    number of active contacts."""
    n = 0
    for g in range(prm.shape[0]):
        n0, n1 = off[g, 0], off[g + 1, 0]
        q0, q1 = off[g, 1], off[g + 1, 1]
        p0, p1 = off[g, 2], off[g + 1, 2]
        n += node_facet_contact_serial(x, v, nodes[n0:n1], r[n0:n1], quads[q0:q1], t[q0:q1],
                                       sign[q0:q1], pairs[p0:p1], prm[g, 0], prm[g, 0],
                                       prm[g, 2], prm[g, 3], prm[g, 4], dt, time_scale,
                                       prm[g, 1], hist_p[n0:n1], hist_ft[n0:n1], f_n, f_t)
    return n


@njit(cache=True)
def _ties(x, v, quat, seg, qt_node, qt_quad, qt_xi, qt_sign, qt_offset, qt_area, qt_c,
          qt_quads, qt_kappa, qt_D, qt_energy, qt_off, bt_node, bt_seg, bt_s, bt_anchor, bt_arm,
          bt_axis, bt_area, bt_c, bt_kappa, bt_D, bt_energy, bt_off, K, delta0, delta_f,
          alpha_d, tie_order, f_c):
    """The tie groups of :func:`bundle_forces` in the order of ``tie_order``."""
    for r in range(tie_order.shape[0]):
        g = tie_order[r, 1]
        if tie_order[r, 0] == 0:
            a, b = qt_off[g, 0], qt_off[g + 1, 0]
            q0, q1 = qt_off[g, 1], qt_off[g + 1, 1]
            cohesive_ties_quad_serial(x, v, qt_node[a:b], qt_quad[a:b], qt_xi[a:b],
                                      qt_sign[a:b], qt_offset[a:b], qt_area[a:b], qt_c[a:b],
                                      qt_quads[q0:q1], K, delta0, delta_f, alpha_d,
                                      qt_kappa[a:b], qt_D[a:b], qt_energy[a:b], f_c)
        else:
            a, b = bt_off[g], bt_off[g + 1]
            cohesive_ties_beam(x, v, quat, bt_node[a:b], bt_seg[a:b], bt_s[a:b],
                               bt_anchor[a:b], bt_arm[a:b], bt_axis[a:b], bt_area[a:b],
                               bt_c[a:b], seg, K, delta0, delta_f, alpha_d, bt_kappa[a:b],
                               bt_D[a:b], bt_energy[a:b], f_c)


@njit(cache=True)
def _cylinders(x, v, seg, seg_r, cyl_c, cyl_axis, cyl_R, cyl_v, chain_start, chain_mu, chain_k,
               chain_hist, pf_quads, pf_t, pf_slack, pf_hist_q, pf_hist, pf_off, pf_prm, dt,
               f_pn, f_pt, f_cyl):
    """The rigid cylinders of :func:`bundle_forces` against the wires, then against each
    facet group; returns the number of active contacts."""
    n = chain_cylinder_contact_serial(x, v, seg, seg_r, chain_start, chain_mu, cyl_c, cyl_axis,
                                      cyl_R, cyl_v, chain_k, chain_k, dt, chain_hist, f_pn,
                                      f_pt, f_cyl)
    for g in range(pf_prm.shape[0]):
        q0, q1 = pf_off[g, 0], pf_off[g + 1, 0]
        r0, r1 = pf_off[g, 1], pf_off[g + 1, 1]
        n += facets_cylinder_contact(x, v, pf_quads[q0:q1], pf_t[q0:q1], pf_prm[g, 0], cyl_c,
                                     cyl_axis, cyl_R, pf_slack[r0:r1], cyl_v, pf_prm[g, 1],
                                     pf_prm[g, 1], dt, pf_hist_q[r0:r1], pf_hist[r0:r1], f_pn,
                                     f_pt, f_cyl)
    return n


def no_cylinders():
    """The rigid-cylinder arguments of :func:`bundle_forces` for a bundle without any, and
    the (empty) force on them."""
    i8 = np.int64
    patches = 1
    cylinders = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)),
                 np.zeros(1, dtype=i8), 0.0, 0.0, np.zeros((0, 0, 3)),
                 np.zeros((0, 4), dtype=i8), np.zeros(0), np.zeros(0),
                 np.zeros((0, patches), dtype=i8), np.zeros((0, patches, 3)),
                 np.zeros((1, 2), dtype=i8), np.zeros((0, 2)))
    return cylinders, np.zeros((0, 3))


def stack_groups(groups: list, spec: dict, shared: tuple = ()):
    """The groups' arrays one after the other (axis 0), for :func:`bundle_forces`.
    ``spec``: key -> (trailing shape, dtype) of each array to stack; returns the stacked
    arrays (in ``spec`` order, C-contiguous, of that dtype) and each key's offsets
    (n_groups + 1,).  The arrays under ``shared`` -- histories the kernels update in place
    -- are replaced in every group by its view of the stacked array, so that the group
    sees the updates."""
    stacked, offsets = [], []
    for key, (tail, dtype) in spec.items():
        parts = [np.asarray(g[key]).reshape(-1, *tail) for g in groups]
        arr = (np.ascontiguousarray(np.concatenate(parts, axis=0), dtype=dtype) if parts
               else np.zeros((0, *tail), dtype=dtype))
        off = np.zeros(len(parts) + 1, dtype=np.int64)
        off[1:] = np.cumsum([q.shape[0] for q in parts])
        if key in shared:
            for g, lo, hi in zip(groups, off[:-1], off[1:]):
                g[key] = arr[lo:hi]
        stacked.append(arr)
        offsets.append(off)
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
