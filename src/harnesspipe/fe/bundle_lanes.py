"""The bundle's heaviest force families in two concurrent lanes.

Per explicit step the wires' beam forces, the coverings' shell forces and the wire-wire
contact cost about three quarters of the force evaluation (bench/RESULTS.md, "Hi-fi
explicit step cost").  Each kernel could run in parallel on its own (a ``prange`` over
chunks), but then both threads meet at a barrier after every kernel and wait through
every kernel's serial part (scatters, history commits).  On the 2 cores this project
targets, one ``prange`` over two lanes does better: the serial kernels run side by side,

* lane 0: the wire-wire contact
  (:func:`harnesspipe.fe.contact_explicit.beam_beam_contact_serial`) and the beams
  ``0 .. split - 1`` (:func:`harnesspipe.fe.beam_explicit.beam_range_forces`);
* lane 1: the shells (:func:`harnesspipe.fe.shell_bt.shell_element_forces_serial`) and
  the beams ``split .. n - 1``,

with one barrier at the end, after which the beams' forces are scattered to their nodes
(the two ranges share a node).  The contact's cost grows with the number of touching
pairs over a run and with the bundle, so the split that balances the lanes is found
and followed from the calls' wall time (:class:`BeamSplit`).  The lanes write disjoint memory: the beams add into the
wire nodes' rows of the element family, the shells into the shell nodes' rows (the mesh
keeps wire and shell nodes apart; :func:`check_disjoint`), the contact into its own
families.  The results are those of the separate kernels, bit for bit: every kernel does
the same arithmetic in the same order, whatever the split.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from harnesspipe.fe.beam_explicit import beam_range_forces, beam_scatter
from harnesspipe.fe.contact_explicit import beam_beam_contact_serial
from harnesspipe.fe.shell_bt import scatter_add, shell_element_forces_serial


def check_disjoint(beam_conn, shell_conn) -> None:
    """The lanes need the beams' and the shells' nodes apart (their element forces are
    added into the same family concurrently)."""
    shared = np.intersect1d(beam_conn, shell_conn)
    if shared.size:
        raise ValueError(f"bundle mesh: {shared.size} nodes are shared by beams and shells "
                         f"(e.g. node {shared[0]}); the concurrent force lanes need them apart")


@njit(cache=True, parallel=True)
def element_and_wire_contact(
        X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z, sec_area, sec_GJ, sec_id, mats,
        eps_p, alpha, sa_h, b_el, beam_split,                       # beams
        v, sconn, sthick, smat, sstate, dt, s_el, hg,               # shells
        seg, seg_r, seg_body, pairs, k_n, k_t, mu_s, mu_k, d_c, time_scale, hist_partner,
        hist_ft,                                                    # wire-wire contact
        f_el, f_n, f_t):
    """Element forces ON the nodes added into ``f_el`` and the wire-wire contact's normal
    and friction forces into ``f_n``, ``f_t``, in the two lanes of the module docstring;
    histories advance in place as in the separate kernels.  Arguments as
    :func:`~harnesspipe.fe.beam_explicit.beam_forces` (``b_el`` its scratch; the beams'
    material ids are their section ids; ``beam_split`` the first beam of lane 1),
    :func:`~harnesspipe.fe.shell_bt.shell_forces` (``s_el`` its scratch, ``hg`` the
    hourglass coefficient) and :func:`~harnesspipe.fe.contact_explicit.beam_beam_contact`.
    Returns the number of touching wire-wire pairs."""
    n_el = conn.shape[0]
    split = min(max(beam_split, 0), n_el)
    n_act = np.empty(1, dtype=np.int64)
    for lane in prange(2):
        if lane == 0:
            n_act[0] = beam_beam_contact_serial(x, v, seg, seg_r, seg_body, pairs, k_n,
                                                k_t, mu_s, mu_k, d_c, dt, time_scale,
                                                hist_partner, hist_ft, f_n, f_t)
            beam_range_forces(0, split, X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z,
                              sec_area, sec_GJ, sec_id, mats, sec_id, eps_p, alpha, sa_h, b_el)
        else:
            shell_element_forces_serial(x, v, sconn, sthick, smat, sstate, dt, s_el, hg)
            scatter_add(sconn, s_el, f_el, -1.0)
            beam_range_forces(split, n_el, X0, conn, R0, x, quat, xi_g, w_g, sec_y, sec_z,
                              sec_area, sec_GJ, sec_id, mats, sec_id, eps_p, alpha, sa_h, b_el)
    beam_scatter(conn, b_el, f_el, -1.0)
    return n_act[0]



class BeamSplit:
    """The beam split of :func:`element_and_wire_contact` that balances its lanes, found
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
