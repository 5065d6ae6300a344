"""Cohesive ties of the hi-fi bundle (Sec. 4.1, eqs. 7-10): the tape's nodes bonded to the
tube, to the tape underneath and to the wires, with a dashpot beside each tie; their
stiffness enters the stable step and the selective mass scaling.
"""
from __future__ import annotations

import numpy as np

from harnesspipe.fe.assembly.groups import BeamTies, QuadTies
from harnesspipe.fe.assembly.lanes import stack_groups
from harnesspipe.fe.contact.tie_targets import make_ties
from harnesspipe.fe.elements.shell_element import XI_NODE
from harnesspipe.models import hifi_mesh as hm
from harnesspipe.models.hifi_mesh_parts import end_band_value, tape_material

TIE_TOL = {hm.TIE_COVERING: 0.3, hm.TIE_WIRES: 0.5, hm.TIE_TAPE: 0.3}   # mm: facet chord sag / hexagonal bundle under a round band
I8, F8 = np.int64, float
QUAD_TIE_SPEC = {"tie_node": ((), I8), "tie_quad": ((), I8), "tie_xi": ((2,), F8),
                 "tie_sign": ((), F8), "tie_off": ((3,), F8), "tie_area": ((), F8),
                 "tie_c": ((), F8), "quads": ((4,), I8), "tie_kappa": ((), F8), "tie_D": ((), F8),
                 "tie_energy": ((), F8)}                       # stacked ties to quads
BEAM_TIE_SPEC = {"tie_node": ((), I8), "tie_seg": ((), I8), "tie_s": ((), F8),
                 "tie_anchor": ((), I8), "tie_arm": ((3,), F8), "tie_axis": ((3,), F8),
                 "tie_area": ((), F8), "tie_c": ((), F8), "tie_kappa": ((), F8),
                 "tie_D": ((), F8), "tie_energy": ((), F8)}    # stacked ties to beams
TIE_HISTORY = ("tie_kappa", "tie_D", "tie_energy")


def bilinear(xi_eta):
    """Bilinear shape functions N (n, 4) and their natural derivatives dN/dxi, dN/deta
    (n, 4 each) at the points ``xi_eta`` (n, 2): :func:`harnesspipe.fe.elements.shell_element.shape`
    for many points at once."""
    s, t = XI_NODE[:, 0], XI_NODE[:, 1]
    xi, eta = xi_eta[:, 0:1], xi_eta[:, 1:2]
    return (0.25 * (1.0 + s * xi) * (1.0 + t * eta), 0.25 * s * (1.0 + t * eta),
            0.25 * t * (1.0 + s * xi))


class BundleTies:
    """The cohesive ties of a :class:`~harnesspipe.models.hifi_bundle.BundleSystem`: made from
    the mesh's tie nodes and targets, their dashpots, their share of the stable step, and
    their groups stacked for :func:`harnesspipe.fe.assembly.lanes.bundle_forces`."""

    def _setup_ties(self):
        mesh, itf = self.mesh, self.inp.interface
        self.ties = []
        self.K_coh = np.array([itf["K_nn"], itf["K_ss"], itf["K_tt"]], dtype=float)
        self.delta0 = np.full(3, float(itf["delta0"]))
        if not self.has_shells or mesh.tie_nodes.size == 0:
            return
        tape = self.sconn[mesh.shell_part == hm.PART_TAPE]
        tape_t = 0.5 * tape_material(self.inp.config, self.inp.case)["thickness"]
        for target in (hm.TIE_COVERING, hm.TIE_WIRES, hm.TIE_TAPE):
            sel = mesh.tie_target == target
            if not sel.any():
                continue
            nodes, area = mesh.tie_nodes[sel], mesh.tie_area[sel]
            if target == hm.TIE_WIRES:
                _, ties = make_ties(self.x, nodes, area, seg=self.seg, seg_r=self.seg_r,
                                       tape_half_t=tape_t, tol=TIE_TOL[target])
                self._lever(ties)
                kind = "beam"
            else:
                quads = (self.sconn[mesh.shell_part != hm.PART_TAPE] if target == hm.TIE_COVERING
                         else tape)
                t = np.full(quads.shape[0], 2 * tape_t)
                if target == hm.TIE_COVERING:
                    t = mesh.shell_thickness[mesh.shell_part != hm.PART_TAPE]
                ties, _ = make_ties(self.x, nodes, area, quads=quads, quad_t=t,
                                       tape_half_t=tape_t, tol=TIE_TOL[target])
                ties["quads"] = np.ascontiguousarray(quads)
                kind = "quad"
            if ties["tie_node"].size:
                ties["kind"] = kind
                self.ties.append(ties)
        fabric = bool((mesh.shell_part == hm.PART_FABRIC).any())
        if end_band_value(self.inp.config["hifi"]["build"], fabric, "end_tape_binds") >= 1.0:
            self._bind_every_wire(tape_t)
        if not itf["delta_f"] > itf["delta0"]:
            raise ValueError(f"cohesive: delta_f = {itf['delta_f']} must exceed delta0 = {itf['delta0']}")

    def _lever(self, ties):
        """A beam tie group's anchor (the nearer end node of its segment), lever arm (tied
        node minus the segment point) and axis, for :func:`cohesive_ties_beam`."""
        ends = self.seg[ties["tie_seg"]]
        s_ = ties["tie_s"]
        P = (1.0 - s_)[:, None] * self.x[ends[:, 0]] + s_[:, None] * self.x[ends[:, 1]]
        ties["tie_anchor"] = np.where(s_ < 0.5, ends[:, 0], ends[:, 1]).astype(np.int64)
        ties["tie_arm"] = np.ascontiguousarray(self.x[ties["tie_node"]] - P)
        ties["tie_axis"] = np.ascontiguousarray(ties["tie_t0"])

    def _bind_every_wire(self, tape_t: float):
        """Build ``end_tape_binds`` 1: the end bands bind every wire under them, not only
        the ones they touch.  Each end-band node over the bare wires is also tied to the
        closest point of every wire no node of that band touches (of the 19-wire bundle:
        the 7 inner wires and 4 of the outer ring), on a lever arm across the wires between
        (the squeezed end moving as one); the node's bond area is shared among those wires,
        so their ties together are as stiff as one tie of the node, not as their number."""
        mesh = self.mesh
        centre = mesh.wire_yz.mean(axis=0)
        for group in (hm.GROUP_END_LEFT, hm.GROUP_END_RIGHT):
            band = np.unique(self.sconn[mesh.shell_group == group])
            sel = (mesh.tie_target == hm.TIE_WIRES) & np.isin(mesh.tie_nodes, band)
            nodes, area = mesh.tie_nodes[sel], mesh.tie_area[sel]
            held = {int(w) for t in self.ties if t["kind"] == "beam"
                    for w in mesh.beam_wire[t["tie_seg"][np.isin(t["tie_node"], band)]]}
            loose = [w for w in range(mesh.n_wires) if w not in held]
            if not nodes.size or not loose:
                continue
            reach = 2.0 * float(np.max(np.linalg.norm(self.x[nodes, 1:3] - centre, axis=1)))
            for w in loose:
                segs = np.flatnonzero(mesh.beam_wire == w)
                _, ties = make_ties(self.x, nodes, area / len(loose), seg=self.seg[segs],
                                    seg_r=self.seg_r[segs], tape_half_t=tape_t, tol=reach)
                ties["tie_seg"] = segs[ties["tie_seg"]]
                self._lever(ties)
                ties["kind"] = "beam"
                self.ties.append(ties)

    def _tie_targets(self, ties):
        """The target nodes (n, k) of a tie group and their weights (n, k): the quad's
        bilinear shape functions at the tie point, or the segment's linear ones."""
        if ties["kind"] == "quad":
            N, _, _ = bilinear(ties["tie_xi"])
            return ties["quads"][ties["tie_quad"]], N
        s_ = ties["tie_s"]
        return self.seg[ties["tie_seg"]], np.stack([1.0 - s_, s_], axis=1)

    def _set_tie_damping(self):
        """Dashpot coefficient of every tie, ``c = 2 zeta sqrt(k m_red)`` (``zeta`` the
        config's ``tie_damping``): ``k = max(K) A`` the tie's stiffness, ``m_red`` the
        reduced mass of the tied node and its target point (the target nodes' masses
        weighted by their shape functions), at the scaled masses of the run."""
        zeta = float(self.inp.explicit["tie_damping"])
        m = self.mass[:, 0]
        for ties in self.ties:
            targets, N = self._tie_targets(ties)
            m1, m2 = m[ties["tie_node"]], np.sum(m[targets] * N, axis=1)
            k = np.max(self.K_coh) * ties["tie_area"]
            ties["tie_c"] = 2.0 * zeta * np.sqrt(k * m1 * m2 / (m1 + m2))

    def n_ties(self) -> int:
        return int(sum(t["tie_node"].size for t in self.ties))

    def _tie_rows(self, ties):
        """Gershgorin weights of a tie group's linearised separation: the target nodes (n, k),
        each node's weight ``B`` (n, k) and the row sum ``S`` (n,) with the tied node's 1.

        delta = R^T (x_node - X(xi)) - off: the tied node enters with weight 1, a target
        node with its shape function N_j and, for a quad, through the turning of the
        quad's frame R (the normal's tilt, grad w), which moves the tie's offset (the
        tape's and the covering's half thicknesses, ``tie_off``): |off| |grad N_j| at the
        tie point, on a facet of mean sides a, b.  So B_j = N_j + |off| |grad N_j| and
        S = 1 + sum_j B_j (2 without an offset)."""
        targets, N = self._tie_targets(ties)
        if ties["kind"] != "quad":
            return targets, N, 1.0 + N.sum(axis=1)
        p = self.x[targets]

        def side(i, j):
            return np.linalg.norm(p[:, j] - p[:, i], axis=1)

        a, b = 0.5 * (side(0, 1) + side(3, 2)), 0.5 * (side(0, 3) + side(1, 2))
        _, dN_dxi, dN_deta = bilinear(ties["tie_xi"])
        dN_dx, dN_dy = 2.0 * dN_dxi / a[:, None], 2.0 * dN_deta / b[:, None]
        B = N + np.linalg.norm(ties["tie_off"], axis=1)[:, None] * np.hypot(dN_dx, dN_dy)
        return targets, B, 1.0 + B.sum(axis=1)

    def _tie_omega2(self, m, targets: bool = False) -> np.ndarray:
        """Gershgorin row of the cohesive springs at each tied node (masses ``m``): a tie of
        stiffness ``k = K A`` adds ``k S / m`` at its tied node and, with ``targets``,
        ``k B_j S / m_j`` at its target's nodes (:meth:`_tie_rows`; a spring between two
        masses: ``2 k / m`` at each)."""
        w2 = np.zeros(self.mesh.n_nodes)
        for ties in self.ties:
            k = np.max(self.K_coh) * ties["tie_area"]
            tg, B, S = self._tie_rows(ties)
            np.add.at(w2, ties["tie_node"], k * S / m[ties["tie_node"]])
            if targets:
                np.add.at(w2, tg.ravel(), ((k * S)[:, None] * B).ravel() / m[tg.ravel()])
        return w2

    def _stack_ties(self):
        """The cohesive tie groups stacked by kind for :func:`bundle_forces` (their damage
        histories become views of the stacked ones) and the order in which they act
        (kind 0: quad, 1: beam; group)."""
        quad, beam, order = [], [], []
        for t in self.ties:
            group = quad if t["kind"] == "quad" else beam
            order.append((0 if group is quad else 1, len(group)))
            group.append(t)
        qa, qo = stack_groups(quad, QUAD_TIE_SPEC, shared=TIE_HISTORY)
        ba, bo = stack_groups(beam, BEAM_TIE_SPEC, shared=TIE_HISTORY)
        self.quad_ties = QuadTies(**qa, off=np.ascontiguousarray(
            np.stack([qo["tie_node"], qo["quads"]], axis=1)))
        self.beam_ties = BeamTies(**ba, off=bo["tie_node"])
        self.tie_order = np.array(order, dtype=np.int64).reshape(-1, 2)

    def tie_separation_max(self) -> float:
        """Largest effective separation any cohesive tie reached (its history kappa, mm);
        damage starts at delta0 (eq. 10)."""
        return float(max((t["tie_kappa"].max(initial=0.0) for t in self.ties), default=0.0))

    def debonded(self) -> int:
        return int(sum(np.sum(t["tie_D"] >= 1.0) for t in self.ties))
