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
  :func:`~harnesspipe.fe.contact_explicit.cohesive_ties_beam`) and the beams
  ``split .. n - 1``,

with one barrier at the end, after which the beams' forces are scattered to their nodes
(the two ranges share a node).  The contact's cost grows with the number of touching
pairs over a run and differs between bundles, so the split that balances the lanes is
found and followed from the calls' wall time (:class:`BeamSplit`).  The lanes write
disjoint memory: the beams add into the wire nodes' rows of the element family, the
shells into the shell nodes' rows (the mesh keeps wire and shell nodes apart;
:func:`check_disjoint`), the contacts (lane 0) and the ties (lane 1) into their own
families.  The results are those of the separate kernels called one after the other, bit
for bit: every kernel does the same arithmetic in the same order, whatever the split.
The loading's contacts (pins, clamps) stay with the system that owns them.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange, typeof
from numba.typed import List

from harnesspipe.fe.beam_explicit import beam_range_forces, beam_scatter
from harnesspipe.fe.contact_explicit import (beam_beam_contact_serial, cohesive_ties_beam,
                                             cohesive_ties_quad_serial, node_facet_contact_serial)
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
        facet_sets,                                                 # node-facet contact
        K, delta0, delta_f, alpha_d, quad_ties, beam_ties, tie_order,   # cohesive ties
        f_el, f_n, f_t, f_c):
    """Element forces ON the nodes added into ``f_el``, the contacts' normal and friction
    forces into ``f_n``, ``f_t`` and the cohesive ties' into ``f_c``, in the two lanes of
    the module docstring; histories advance in place as in the separate kernels.

    Arguments as :func:`~harnesspipe.fe.beam_explicit.beam_forces` (``b_el`` its scratch;
    the beams' material ids are their section ids; ``beam_split`` the first beam of lane
    1), :func:`~harnesspipe.fe.shell_bt.shell_forces` (``s_el`` its scratch, ``hg`` the
    hourglass coefficient) and :func:`~harnesspipe.fe.contact_explicit.beam_beam_contact`;
    ``facet_sets`` a typed list of :func:`facet_set` tuples; ``quad_ties`` and
    ``beam_ties`` typed lists of :func:`quad_tie_group` / :func:`beam_tie_group` tuples,
    applied in the order of ``tie_order`` rows (kind 0: quad, 1: beam; index), with the
    cohesive law's ``K, delta0, delta_f, alpha_d`` (eqs. 7-10).  Returns the number of
    active contacts (wire-wire pairs and node-facet contacts)."""
    n_el = conn.shape[0]
    split = min(max(beam_split, 0), n_el)
    n_act = np.empty(1, dtype=np.int64)
    for lane in prange(2):
        if lane == 0:
            n = beam_beam_contact_serial(x, v, seg, seg_r, seg_body, pairs, k_n, k_t, mu_s,
                                         mu_k, d_c, dt, time_scale, hist_partner, hist_ft,
                                         f_n, f_t)
            for fs in facet_sets:
                prm = fs[8]
                n += node_facet_contact_serial(x, v, fs[0], fs[1], fs[2], fs[3], fs[4], fs[5],
                                               prm[0], prm[0], prm[2], prm[3], prm[4], dt,
                                               time_scale, prm[1], fs[6], fs[7], f_n, f_t)
            n_act[0] = n
            beam_range_forces(0, split, X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z,
                              sec_area, sec_GJ, sec_id, mats, sec_id, eps_p, alpha, sa_h, b_el)
        else:
            shell_element_forces_serial(x, v, sconn, sthick, smat, sstate, dt, s_el, hg)
            scatter_add(sconn, s_el, f_el, -1.0)
            for r in range(tie_order.shape[0]):
                if tie_order[r, 0] == 0:
                    t = quad_ties[tie_order[r, 1]]
                    cohesive_ties_quad_serial(x, t[0], t[1], t[2], t[3], t[4], t[5], t[6], K,
                                              delta0, delta_f, alpha_d, t[7], t[8], t[9], f_c)
                else:
                    t = beam_ties[tie_order[r, 1]]
                    cohesive_ties_beam(x, quat, t[0], t[1], t[2], t[3], t[4], t[5], t[6], seg,
                                       K, delta0, delta_f, alpha_d, t[7], t[8], t[9], f_c)
            beam_range_forces(split, n_el, X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z,
                              sec_area, sec_GJ, sec_id, mats, sec_id, eps_p, alpha, sa_h, b_el)
    beam_scatter(conn, b_el, f_el, -1.0)
    return n_act[0]


def facet_set(nodes, r, quads, t, sign, pairs, hist, k, pen_max, mu_s, mu_k, d_c) -> tuple:
    """One node-facet contact set for :func:`bundle_forces` (arguments as
    :func:`~harnesspipe.fe.contact_explicit.node_facet_contact`; ``hist`` its
    (hist_partner, hist_ft), updated in place)."""
    return (_c(nodes, np.int64), _c(r), _c(quads, np.int64), _c(t), _c(sign),
            _c(pairs, np.int64), _same(hist[0]), _same(hist[1]),
            np.array([k, pen_max, mu_s, mu_k, d_c], dtype=float))


def quad_tie_group(ties: dict) -> tuple:
    """Ties to shell quads (:func:`~harnesspipe.fe.contact_explicit.cohesive_ties_quad`);
    the damage history arrays are the group's own (updated in place)."""
    return (_c(ties["tie_node"], np.int64), _c(ties["tie_quad"], np.int64), _c(ties["tie_xi"]),
            _c(ties["tie_sign"]), _c(ties["tie_off"]), _c(ties["tie_area"]),
            _c(ties["quads"], np.int64), _same(ties["tie_kappa"]), _same(ties["tie_D"]),
            _same(ties["tie_energy"]))


def beam_tie_group(ties: dict) -> tuple:
    """Ties to beams (:func:`~harnesspipe.fe.contact_explicit.cohesive_ties_beam`)."""
    return (_c(ties["tie_node"], np.int64), _c(ties["tie_seg"], np.int64), _c(ties["tie_s"]),
            _c(ties["tie_anchor"], np.int64), _c(ties["tie_arm"]), _c(ties["tie_axis"]),
            _c(ties["tie_area"]), _same(ties["tie_kappa"]), _same(ties["tie_D"]),
            _same(ties["tie_energy"]))


def typed_list(items: list, example: tuple) -> List:
    """A numba typed list of ``items`` (tuples typed like ``example``; may be empty)."""
    out = List.empty_list(typeof(example))
    for item in items:
        out.append(item)
    return out


def _c(a, dtype=float):
    """A C-contiguous array of ``dtype`` (a copy only where needed: read-only inputs)."""
    return np.ascontiguousarray(a, dtype=dtype)


def _same(a):
    """A history array that is updated in place: it must already be C-contiguous (a copy
    would leave the caller's array behind)."""
    if not (isinstance(a, np.ndarray) and a.flags.c_contiguous):
        raise ValueError("bundle_forces: history arrays must be C-contiguous NumPy arrays")
    return a


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


def _empty(*shape, dtype=float):
    return np.zeros(shape, dtype=dtype)


# Examples that type the lists of :func:`bundle_forces` when a bundle has no such group.
EMPTY_FACET_SET = facet_set(_empty(0, dtype=np.int64), _empty(0), _empty(0, 4, dtype=np.int64),
                            _empty(0), _empty(0), _empty(0, 2, dtype=np.int64),
                            (_empty(0, 1, dtype=np.int64), _empty(0, 1, 3)), 0.0, 0.0, 0.0,
                            0.0, 0.0)
EMPTY_QUAD_TIES = quad_tie_group(dict(
    tie_node=_empty(0, dtype=np.int64), tie_quad=_empty(0, dtype=np.int64), tie_xi=_empty(0, 2),
    tie_sign=_empty(0), tie_off=_empty(0, 3), tie_area=_empty(0), quads=_empty(0, 4, dtype=np.int64),
    tie_kappa=_empty(0), tie_D=_empty(0), tie_energy=_empty(0)))
EMPTY_BEAM_TIES = beam_tie_group(dict(
    tie_node=_empty(0, dtype=np.int64), tie_seg=_empty(0, dtype=np.int64), tie_s=_empty(0),
    tie_anchor=_empty(0, dtype=np.int64), tie_arm=_empty(0, 3), tie_axis=_empty(0, 3),
    tie_area=_empty(0), tie_kappa=_empty(0), tie_D=_empty(0), tie_energy=_empty(0)))
