"""The hi-fi bundle as an explicit system (Sec. 4.1): wires as fibre beams, tube, fabric
and tape as shells, their contacts and cohesive ties, integrated by
:mod:`harnesspipe.fe.solvers.central_difference`.  The loading -- the three-point test's
pins (:mod:`harnesspipe.models.hifi`), the Y-branch's clamps and strand
(:mod:`harnesspipe.models.hifi_branch`) -- is a subclass's.

Energies (families of forces ON the nodes): ``internal`` (beams and shells: elastic +
plastic; the plastic part in closed form from the hardening history), ``contact``
(penalty energy of the bundle's normal contacts), ``friction`` (wire-wire and
wire-covering dissipation), ``pin_contact`` / ``pin_friction`` (the loading's),
``cohesive`` (tape bonds: elastic + damage dissipation) and ``damping``
(mass-proportional, zero unless set).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from harnesspipe.fe.assembly.groups import CohesiveLaw, FacetSets, Forces, Shells, WireContact
from harnesspipe.fe.assembly.lanes import (BeamSplit, bundle_forces, check_disjoint, no_pins,
                                           stack_groups)
from harnesspipe.fe.contact.common import DEFAULT_MAXS, fit_slot_history, new_slot_history
from harnesspipe.fe.contact.node_facet import FacetSet, near_node_facet_pairs, node_facet_contact
from harnesspipe.fe.contact.search import (box_pairs, max_drift2, near_segment_pairs, node_aabbs,
                                           quad_aabbs, segment_aabbs)
from harnesspipe.fe.contact.wire_wire import WW_POINTS
from harnesspipe.fe.elements.shell_bt import (HOURGLASS_COEF, add_prestrain, init_shell_state,
                                              shell_energies, shell_lumped_mass,
                                              uniaxial_prestrain, wave_speeds2)
from harnesspipe.fe.materials.plane_stress import fabric_shear_modulus
from harnesspipe.fe.rotation import move_nodes
from harnesspipe.fe.solvers.central_difference import smooth_step
from harnesspipe.models import hifi_mesh as hm
from harnesspipe.models.hifi_mesh_parts import end_band_value, tape_material
from harnesspipe.models.hifi_parts import Wires
from harnesspipe.models.hifi_ties import BundleTies
from harnesspipe.fe.elements.shell_bt_element import MAT_TUBE
from harnesspipe.fe.materials import tube_wall
from harnesspipe.models.tube_equivalent import from_config as tube_equivalent
from harnesspipe.models.tube_equivalent import wall_from_config as tube_wall_from_config
from harnesspipe.models.tube_equivalent import wall_row

FAMILIES = ("internal", "contact", "friction", "pin_contact", "pin_friction", "cohesive", "damping")
MAX_LIGHT_SCALE = 16.0   # cap of the selective shell mass scaling (the tape on its bond needs ~13)
LANES_PHASE = "elements, contact and ties"   # one phase: concurrent lanes (fe/assembly/lanes.py)
I8, F8 = np.int64, float
FACET_SPEC = {"nodes": ((), I8), "r": ((), F8), "quads": ((4,), I8), "t": ((), F8),
              "sign": ((), F8), "hist_p": ((DEFAULT_MAXS,), I8),
              "hist_ft": ((DEFAULT_MAXS, 3), F8)}          # stacked node-facet sets


KE_IE_FROM = 1.0 / 3.0   # KE/IE is checked once the feeder has passed this part of the stroke
WRAP_FRACTION = 0.05     # the tape's wrapping tension rises over this start of a run (feeder: 0.1 % of stroke)


def quasi_static_ratio(history, stroke: float, start: float = KE_IE_FROM,
                       travel: str = "deflection_mm_end") -> float:
    """max KE/IE over the history rows past ``start x stroke`` of feeder travel (column
    ``travel``: the feeder's deflection at the row's end, where KE and IE are taken -- not
    the row's mean ``deflection_mm`` -- or the crosshead's displacement of the branch test).

    The paper's quasi-static criterion (KE/IE < 2 %, Sec. 4.1) cannot hold at the very
    start of any loading from rest: IE grows like the deflection squared while the
    kinetic energy of the bundle and its overhangs follows the feeder speed, so the ratio
    diverges as the deflection goes to zero.  It is therefore checked over the part of
    the test that the calibrations use for the hardening and friction response (from a
    third of the stroke); the full history (energies.csv) shows the early ratio too.  A run
    stopped right at that point has its last row there up to rounding: rows within 1e-9 of
    the stroke below it count.
    """
    late = history[history[travel] >= (start - 1e-9) * stroke]
    ie = late["internal"].to_numpy()
    ke = late["KE"].to_numpy()
    ok = ie > 0.0
    return float(np.max(ke[ok] / ie[ok])) if ok.any() else float("inf")


@dataclass
class HifiInputs:
    """Everything one run needs, as plain values (see :func:`harnesspipe.stages.hifi.parameters`)."""

    case: dict                   # config ``cases`` entry
    config: dict                 # the whole config (materials, coverings, three_point)
    interface: dict              # mu_s, mu_k, d_c, K_nn.., mu_rtb, mu_rtp, delta0, delta_f, alpha_d, E2_over_E1
    explicit: dict               # t_total (profile), t_phys, f_m, safety, mass_damping, penalty, search_margin
    resolution: dict             # mesh resolution and fibre section (n_rings, n_sectors)
    coverings: dict              # E, sigma_y, K, n per covering (tensile stage)


def shell_materials(mesh, inp: HifiInputs):
    """Per-element (mat row, stiffness thickness, density) of the shells (fe/shell_bt layout).
    The ridged tube is the isotropic J2 equivalent shell, or with ``wall_law: resultant``
    in its covering entry the resultant law of :mod:`harnesspipe.fe.materials.tube_wall`
    (rows of ``ROW_WIDTH``; the element thickness is then its mass thickness).  A slit tube
    rolled onto the bundle (``mesh.info["tube_layers"]`` m > 1,
    :meth:`harnesspipe.models.hifi_mesh_parts.Covering.close_onto`) is m equivalent walls
    stacked without bond: m times the membrane and the bending stiffness, the yield forces
    and the mass of one (E, sigma_y, K and rho x m at the same t_eq)."""
    cfg, f_m = inp.config, inp.explicit["f_m"]
    n = mesh.shell_conn.shape[0]
    cov = inp.case["covering"]
    resultant = (mesh.shell_part == hm.PART_TUBE).any() and \
        cfg["coverings"][cov].get("wall_law", "isotropic") == "resultant"
    mat = np.zeros((n, tube_wall.ROW_WIDTH if resultant else 6))
    thick = np.zeros(n)
    rho = np.zeros(n)
    tape = tape_material(cfg, inp.case)
    sel = mesh.shell_part == hm.PART_TAPE
    mat[sel, :6] = [tape["E"], tape["nu"], tape["sigma_y"], tape["K"], tape["n"], 0.0]
    thick[sel] = tape["thickness"]
    rho[sel] = tape["rho"]
    ends = sel & np.isin(mesh.shell_group, (hm.GROUP_END_LEFT, hm.GROUP_END_RIGHT))
    fabric = (mesh.shell_part == hm.PART_FABRIC).any()
    thick[ends] *= end_band_value(cfg["hifi"]["build"], fabric, "end_tape_layers")   # wraps of tape
    sel = mesh.shell_part == hm.PART_TUBE
    if sel.any():
        own = {k: inp.case[k] for k in ("d_i", "d_o") if k in inp.case}   # e.g. the 15 mm tube
        cfg_cov = {**cfg, "coverings": {**cfg["coverings"], cov: {**cfg["coverings"][cov], **own}}}
        layers = getattr(mesh, "info", {}).get("tube_layers", 1.0)   # a slit tube rolled onto the bundle
        if resultant:
            if layers != 1.0:
                raise ValueError(f"covering {cov}: wall_law resultant with hifi.build.tube_closure > 0 "
                                 "(a slit tube rolled onto the bundle) is not modelled; use "
                                 "wall_law isotropic or tube_closure 0")
            w = tube_wall_from_config(cfg_cov, cov, inp.coverings[cov])
            mat[sel] = wall_row(w, MAT_TUBE)
            thick[sel] = w["mass_thickness"]
            rho[sel] = w["rho"]
        else:
            eq = tube_equivalent(cfg_cov, cov, inp.coverings[cov])
            m = layers          # m walls that slide on each other: m x the stresses and the mass
            mat[sel, :6] = [m * eq["E"], eq["nu"], m * eq["sigma_y"], m * eq["K"], eq["n"], 0.0]
            thick[sel] = eq["t"]
            rho[sel] = m * eq["rho"]
    sel = mesh.shell_part == hm.PART_FABRIC
    if sel.any():
        fab = cfg["coverings"]["fabric_tube"]
        E1 = inp.coverings["fabric_tube"]["E"]
        E2 = inp.interface["E2_over_E1"] * E1
        nu12 = fab["nu12"]
        mat[sel, :6] = [E1, E2, nu12, fabric_shear_modulus(E1, E2, nu12), fab["compression_factor"],
                        1.0]
        thick[sel] = fab["t"]
        rho[sel] = cfg["materials"][fab["material"]]["rho"]
    return mat, thick, f_m * rho


class BundleSystem(BundleTies):
    """A bundle of wires with its coverings, tape, contacts and cohesive ties, integrated by
    :mod:`harnesspipe.fe.solvers.central_difference`; the loading (pins, clamps, a strand) is the subclass's.

    Subclasses set ``free``, give their rigid cylinders (pins) as :attr:`pin_args` and
    :attr:`cyl_force` (:func:`harnesspipe.fe.assembly.lanes.bundle_forces`) or add other
    loading forces in :meth:`_loading_forces` (both into the families ``pin_contact`` /
    ``pin_friction``), move their rigid bodies in :meth:`_move_loading` and supply
    ``external_work`` and ``observe``.
    """

    families = FAMILIES
    driven = "pin_contact"      # the family the prescribed bodies' external work is credited to
    # cap of the nodal mass factor (see _scale_to_wire_step): the tube's end-edge nodes under
    # the end bands' ties need up to ~30 with the ties' lever (hifi_ties.BundleTies._tie_rows)
    node_scale_cap = 2.0 * MAX_LIGHT_SCALE

    def __init__(self, mesh, inp: HifiInputs):
        self.mesh, self.inp = mesh, inp
        ex = inp.explicit
        self.T = float(ex["t_total"])
        self.time_scale = float(ex["t_phys"]) / self.T
        self.margin = float(ex["search_margin"])
        self.x_search = None        # positions at the last contact search
        self.searches = 0
        n = mesh.n_nodes
        self.x = np.ascontiguousarray(mesh.X, dtype=float).copy()
        self.quat = np.zeros((n, 4))
        self.quat[:, 0] = 1.0
        self.nw = mesh.n_wire_nodes
        numbers = np.unique(mesh.wire_type)            # the bundle's wire types (materials.wire_typeN)
        types = [dict(inp.config["materials"][f"wire_type{t}"]) for t in numbers]
        self.wires = Wires(mesh.X, mesh.beam_conn, np.searchsorted(numbers, mesh.wire_type[mesh.beam_wire]), types,
                           inp.resolution["n_rings"], inp.resolution["n_sectors"], 3, ex["f_m"])
        self.mass = np.zeros((n, 6))
        self.wires.add_mass(self.mass)
        self.has_shells = mesh.shell_conn.shape[0] > 0
        self.sconn = np.ascontiguousarray(mesh.shell_conn, dtype=np.int64).reshape(-1, 4)
        check_disjoint(self.wires.conn, self.sconn)
        self.beam_split = BeamSplit(self.wires.conn.shape[0])
        self.smat, self.sthick, self.srho = self._shell_materials()    # (empty without shells)
        self.sstate = init_shell_state(mesh.X, self.sconn, self.sthick,
                                       np.asarray(mesh.shell_axis, dtype=float).reshape(-1, 3))
        self._wrap_tension()
        self.s_el = np.zeros((self.sconn.shape[0], 4, 6))
        self.free = np.ones((n, 6), dtype=np.bool_)
        self.c_damp = float(ex["mass_damping"])
        self.F = np.zeros((len(FAMILIES), n, 6))
        self.seg = np.ascontiguousarray(mesh.beam_conn, dtype=np.int64)
        self.seg_r = mesh.wire_radius[mesh.beam_wire].astype(float)
        self.seg_body = mesh.beam_wire.astype(np.int64)
        self.ww_skip = None         # (n_beam,) bool: segments kept out of wire-wire contact
        self._setup_ties()
        self.shell_mass_scale = self._scale_to_wire_step()
        self._set_tie_damping()
        self.dt0 = 2.0 / np.sqrt(self.node_omega2().max())
        self._setup_contacts()
        self.phase = {k: 0.0 for k in (LANES_PHASE, "contact search", "strand and damping")}
        self._stack_facet_sets()
        self._stack_ties()
        self.pin_args, self.cyl_force = no_pins(), np.zeros((0, 3))
        self._lane_groups = self._lane_F = None   # bundle_forces' groups, for F (_make_lane_groups)
        self.pairs_max = 0
        self.active = 0

    def _shell_materials(self):
        """Per-element (mat row, stiffness thickness, density) of the shells."""
        return shell_materials(self.mesh, self.inp)

    def _loading_forces(self, v, dt, F) -> int:
        """Add the forces of a loading that is not a rigid cylinder (a strand) to ``F``;
        returns the number of active contacts."""
        return 0

    def _move_loading(self, t) -> None:
        raise NotImplementedError

    def _scale_to_wire_step(self) -> dict:
        """Selective mass scaling (on top of the uniform f_m) to the wires' element step.

        The 0.1 mm PVC tape on its 30 N/mm^3 cohesive bond and the thin tube and fabric
        walls would limit the explicit step well below the wires' bar limit, while all
        coverings together carry a small part of the bundle's mass.  As explicit codes do
        with target-step mass scaling, (1) the density of each shell part is raised by the
        factor that brings its fastest node -- its elements and its cohesive springs
        together (the rows of :meth:`node_omega2`) -- to the wires' step, and (2) every
        node still faster than that -- a heavier part's node under many ties, a wire node
        under the end tape -- gets the nodal mass factor ``s`` that brings its Gershgorin
        row of M^-1 K there (the whole row scales with 1/s: :attr:`node_scale`).  Factors
        are capped at ``MAX_LIGHT_SCALE`` (the nodal ones at :attr:`node_scale_cap`); the
        added mass is reported (``added_mass_fraction``).  Returns the density factor per
        shell part.
        """
        self.added_mass_fraction = 0.0
        self.node_scale = np.ones(self.mesh.n_nodes)
        w_target = (2.0 / self.wires.stable_step(self.x)) ** 2
        base = self.mass[:, 0].sum()
        factor = {}
        if self.has_shells:
            shell_mass = np.zeros_like(self.mass)
            shell_lumped_mass(self.mesh.X, self.sconn, self.sthick, self.srho, shell_mass)
            base += shell_mass[:, 0].sum()
            w_tie = self._tie_omega2(self.mass[:, 0] + shell_mass[:, 0])
            w_tie[:self.nw] = 0.0
            w_el = (2.0 / self._shell_element_steps()) ** 2
            for p in np.unique(self.mesh.shell_part):
                sel = self.mesh.shell_part == p
                w_node = np.zeros(self.mesh.n_nodes)
                np.maximum.at(w_node, self.sconn[sel].ravel(), np.repeat(w_el[sel], 4))
                nodes = np.unique(self.sconn[sel])
                f = float(np.clip(np.max(w_node[nodes] + w_tie[nodes]) / w_target, 1.0,
                                  MAX_LIGHT_SCALE))
                self.srho[sel] *= f
                factor[hm.PART_NAMES[p]] = f
            shell_lumped_mass(self.mesh.X, self.sconn, self.sthick, self.srho, self.mass)
        w_node = self.node_omega2()
        need = np.flatnonzero(w_node > w_target * (1.0 + 1e-9))
        self.node_scale[need] = np.minimum(w_node[need] / w_target, self.node_scale_cap)
        self.mass[need] *= self.node_scale[need, None]
        self.added_mass_fraction = float(self.mass[:, 0].sum() / base - 1.0)
        return factor

    def _penalty(self, masses, key: str = "penalty") -> float:
        """k = penalty m / dt^2: omega dt = sqrt(penalty) per contact, explicit-stable
        (``key``: the config's ``penalty``, or ``penalty_layers`` for the fabric's layers)."""
        return self.inp.explicit[key] * float(np.min(masses)) / self.dt0**2

    def _setup_contacts(self):
        mesh = self.mesh
        m = self.mass[:, 0]
        self.k_ww = self._penalty(m[:self.nw])
        self.ww_hist = new_slot_history(self.seg.shape[0], points=WW_POINTS)
        self.ww_pairs = np.zeros((0, 2), dtype=np.int64)
        wn = np.arange(self.nw, dtype=np.int64)
        wr = np.zeros(self.nw)
        for a in range(2):
            wr[self.seg[:, a]] = self.seg_r
        # wires (and tape) against the covering and tape facets
        self.facet_sets = []
        self.cut = None
        if self.has_shells:
            cov = np.flatnonzero(mesh.shell_part != hm.PART_TAPE)
            if cov.size:
                self._facet_set(wn, wr, cov, -1.0)
            tape = np.flatnonzero(mesh.shell_part == hm.PART_TAPE)
            ends = tape[np.isin(mesh.shell_group[tape], (hm.GROUP_END_LEFT, hm.GROUP_END_RIGHT))]
            if ends.size:
                self._facet_set(wn, wr, ends, -1.0)
            if mesh.fabric_overlap_outer.size:
                inner = np.flatnonzero(np.all(np.isin(self.sconn, mesh.fabric_overlap_inner), axis=1))
                r = np.full(mesh.fabric_overlap_outer.size, 0.2)   # < half the 0.48 layer gap
                self._facet_set(mesh.fabric_overlap_outer.astype(np.int64), r, inner, 1.0,
                                "penalty_layers")
            if mesh.cut_pairs.size:
                self._cut_contact()

    def _cut_contact(self):
        """Self-contact across the open tube's cut (node pairs ``a`` at the cut's angle,
        ``b`` a full turn on, coincident at the start): the cut may open freely but its edges cannot
        pass through each other in the hoop direction.  With ``t`` the unit vector from
        ``a`` to its hoop neighbour (into a's side of the wall, current configuration), the
        overlap is ``p = (x_b - x_a) . t``; a positive overlap is resisted by the penalty
        ``k p`` along ``t`` (energy 1/2 k p^2).  Radial riding of one edge over the other is
        not resisted (one wall thickness, the ridged tube's 1.7 mm, is not resolved there)."""
        mesh = self.mesh
        a, b = mesh.cut_pairs[:, 0].astype(np.int64), mesh.cut_pairs[:, 1].astype(np.int64)
        nbr = mesh.cut_next.astype(np.int64)
        self.cut = (a, b, nbr, self._penalty(self.mass[np.r_[a, b], 0]))

    def _cut_forces(self, fn) -> int:
        a, b, nbr, k = self.cut
        t = self.x[nbr] - self.x[a]
        t /= np.linalg.norm(t, axis=1)[:, None]
        p = np.einsum("ij,ij->i", self.x[b] - self.x[a], t)
        on = p > 0.0
        f = (k * p[on])[:, None] * t[on]
        np.add.at(fn[:, :3], a[on], f)
        np.subtract.at(fn[:, :3], b[on], f)
        return int(on.sum())

    def _facet_set(self, nodes, r, quads, sign, penalty="penalty"):
        itf = self.inp.interface
        q = np.ascontiguousarray(self.sconn[quads])
        qn = np.unique(q)
        k = self._penalty(np.r_[self.mass[nodes, 0], self.mass[qn, 0]], penalty)
        t = np.ascontiguousarray(self.mesh.shell_thickness[quads], dtype=float)
        fs = dict(nodes=np.ascontiguousarray(nodes, dtype=np.int64),
                  r=np.ascontiguousarray(r, float).copy(), quads=q, t=t,
                  sign=np.full(q.shape[0], sign), k=k, pen_max=float(np.max(r) + 0.5 * np.max(t)),
                  hist=new_slot_history(nodes.size), pairs=np.zeros((0, 2), dtype=np.int64),
                  mu=(itf["mu_s"], itf["mu_k"], itf["d_c"]))
        self._adjust_initial_gaps(fs)
        self.facet_sets.append(fs)

    def _adjust_initial_gaps(self, fs):
        """Strain-free start: shrink the contact radius of nodes that begin inside a facet
        (faceted tape wrapped on a round or hexagonal bundle) by their initial penetration,
        found with a unit penalty, so that no contact force exists at t = 0."""
        for _ in range(30):      # edge nodes carry weight 1/2: converges geometrically
            self._search_set(fs)
            f_n = np.zeros((self.mesh.n_nodes, 6))
            hist = new_slot_history(fs["nodes"].size)
            hist[0][:, 0] = 0        # every node counts as in contact: find those behind a facet too
            unit = FacetSet(fs["nodes"], fs["r"], fs["quads"], fs["t"], fs["sign"], fs["pairs"],
                            1.0, 0.0, 0.0, 0.0, 0.0, fs["pen_max"], hist[0], hist[1])
            node_facet_contact(self.x, np.zeros_like(f_n), unit, 1.0, 1.0, f_n, np.zeros_like(f_n))
            pen = np.linalg.norm(f_n[fs["nodes"], :3], axis=1)
            if pen.max() < 1e-9:
                return
            fs["r"] = np.maximum(fs["r"] - pen - 1e-3, 0.0)

    def _wrap_tension(self):
        """The tape as wrapped under the tension T (config ``hifi.build.tape_tension``, N):
        every tape element is prestressed to T / (w t) along the tape (its material axis,
        the end bands' hoop and the strips' length; each wrap of an end band carries it),
        raised smoothly over the first ``WRAP_FRACTION`` of the run (:meth:`_wrap_step`)."""
        self.wrap = None
        T = float(self.inp.config["hifi"]["build"].get("tape_tension", 0.0))
        tape = np.flatnonzero(self.mesh.shell_part == hm.PART_TAPE)
        if T == 0.0 or tape.size == 0:
            return
        props = tape_material(self.inp.config, self.inp.case)
        e11, e22 = uniaxial_prestrain(self.smat, tape, T / (props["width"] * props["thickness"]))
        self.wrap = (tape, e11, e22)
        self.wrap_applied = 0.0

    def _wrap_step(self, t):
        """Raise the tape's prestrain to S(t / t_wrap) of its full value (S the smooth step,
        t_wrap = ``WRAP_FRACTION`` T): a sudden prestress would shake the light tape nodes
        on their ties."""
        tape, e11, e22 = self.wrap
        level = smooth_step(t / (WRAP_FRACTION * self.T))[0]
        add_prestrain(self.sstate, tape, e11, e22, level - self.wrap_applied)
        self.wrap_applied = level
        if level >= 1.0:
            self.wrap = None

    def stable_step(self) -> float:
        """2 / omega_max with a nodal bound of omega_max^2 (Gershgorin, row by row): at each
        node the largest omega^2 of its elements plus the cohesive springs acting on it,
        plus two penalty contacts (omega^2 = penalty / dt0^2 each, see :meth:`_penalty`)."""
        w2 = self.node_omega2().max() + 2.0 * self.inp.explicit["penalty"] / self.dt0**2
        return 2.0 / np.sqrt(w2)

    def node_omega2(self) -> np.ndarray:
        """Gershgorin row of M^-1 K at each node: the largest element bound at the node
        (elements of the material density) divided by the node's mass factor
        :attr:`node_scale`, plus the cohesive springs on the node's actual mass."""
        w2 = np.zeros(self.mesh.n_nodes)
        conn = self.wires.conn
        we = (2.0 / self.wires.element_steps(self.x)) ** 2
        for a in range(2):
            np.maximum.at(w2, conn[:, a], we)
        if self.has_shells:
            ws = (2.0 / self._shell_element_steps()) ** 2
            for a in range(4):
                np.maximum.at(w2, self.sconn[:, a], ws)
        w2 /= self.node_scale
        m = self.mass[:, 0]
        return w2 + self._tie_omega2(m, targets=True)

    def _shell_element_steps(self) -> np.ndarray:
        """L / c per shell (as fe.shell_bt.shell_stable_step, element by element)."""
        p = self.x[self.sconn]
        area = 0.5 * np.linalg.norm(np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1]), axis=1)
        diag = np.maximum(np.linalg.norm(p[:, 2] - p[:, 0], axis=1),
                          np.linalg.norm(p[:, 3] - p[:, 1], axis=1))
        c2 = wave_speeds2(self.smat, self.srho, self.sthick)
        return area / diag / np.sqrt(c2)

    def advance(self, du, t):
        move_nodes(self.x, self.quat, du, self.nw)
        self._move_loading(t)

    def _search(self):
        """Candidate pairs of every contact set, boxes padded by ``margin``."""
        x, m = self.x, self.margin
        self.x_search = x.copy()
        self.searches += 1
        lo, hi = segment_aabbs(x, self.seg, self.seg_r, m)
        cell = float(np.median(np.max(hi - lo, axis=1)))
        p = box_pairs(lo, hi, lo, hi, cell, True)
        if self.ww_skip is not None:
            p = p[~np.any(self.ww_skip[p], axis=1)]
        self.ww_pairs = p = p[near_segment_pairs(x, self.seg, self.seg_r, p, m)]
        other = self.seg_body[p[:, 0]] != self.seg_body[p[:, 1]]
        self.ww_hist = fit_slot_history(self.ww_hist, np.min(p[other], axis=1))
        for fs in self.facet_sets:
            self._search_set(fs)
        self._stack_facet_pairs()
        self._lane_groups = None    # the pairs and the wire-wire history are new arrays

    def _search_set(self, fs):
        lo_n, hi_n = node_aabbs(self.x, fs["nodes"], fs["r"], self.margin)
        lo_q, hi_q = quad_aabbs(self.x, fs["quads"], 0.5 * fs["t"], self.margin)
        cell = float(np.median(np.max(hi_q - lo_q, axis=1)))
        p = box_pairs(lo_n, hi_n, lo_q, hi_q, cell, False)
        fs["pairs"] = p[near_node_facet_pairs(self.x, fs["nodes"], fs["r"], fs["quads"],
                                                 fs["t"], p, fs["pen_max"], self.margin)]

    def forces(self, t, v, dt):
        """All force families at the current configuration; phase wall times in ``phase``."""
        clock = time.perf_counter
        F = self.F
        F[...] = 0.0
        if self.wrap is not None:
            self._wrap_step(t)
        t0 = clock()
        if self.x_search is None or max_drift2(self.x, self.x_search) > (0.5 * self.margin) ** 2:
            self._search()          # some pair may have closed in by a margin: search anew
        t1 = clock()
        self.cyl_force[...] = 0.0
        active = self._cut_forces(F[1]) if self.cut is not None else 0
        active += self._bundle_forces(v, dt, F)
        t2 = clock()
        self.beam_split.record(t2 - t1)
        active += self._loading_forces(v, dt, F)
        if self.c_damp > 0.0:
            np.multiply(self.mass, v, out=F[6])
            F[6] *= -self.c_damp
        t3 = clock()
        for name, a, b in (("contact search", t0, t1), (LANES_PHASE, t1, t2),
                           ("strand and damping", t2, t3)):
            self.phase[name] += b - a
        self.active = active
        self.pairs_max = max(self.pairs_max, active)
        return F

    def _bundle_forces(self, v, dt, F) -> int:
        """Beam and shell forces ON the nodes into ``F[0]``, the wire-wire and node-facet
        contacts into ``F[1]``, ``F[2]``, the cohesive ties into ``F[5]``, the pins'
        contacts into ``F[3]``, ``F[4]`` (:attr:`pin_args`), in two concurrent lanes
        (:mod:`harnesspipe.fe.assembly.lanes`); returns the number of active contacts.
        (The open tube's cut is added to ``F[1]`` before: on the covering's nodes it comes
        before the node-facet contact: the order of the additions fixes the rounding.)

        The groups hold the system's own arrays, updated in place, so they are made once
        and again after each contact search (which replaces the pairs and the wire-wire
        history); only the split, the velocities and the step change per call."""
        if self._lane_groups is None or self._lane_F is not F:
            self._lane_groups, self._lane_F = self._make_lane_groups(F), F
        return bundle_forces(self.x, self.quat, v, dt, self.time_scale,
                             self.beam_split.current(), **self._lane_groups)

    def _make_lane_groups(self, F) -> dict:
        """The named groups of :func:`bundle_forces` (:mod:`harnesspipe.fe.assembly.groups`)."""
        w, itf = self.wires, self.inp.interface
        pins, wire_pins, pin_facets = self.pin_args
        return dict(
            beams=w.beams,
            shells=Shells(self.sconn, self.sthick, self.smat, self.sstate, self.s_el,
                          HOURGLASS_COEF),
            wires=WireContact(self.seg, self.seg_r, self.seg_body, self.ww_pairs, self.k_ww,
                              self.k_ww, itf["mu_s"], itf["mu_k"], itf["d_c"],
                              self.ww_hist[0], self.ww_hist[1]),
            facets=self.facets._replace(pairs=self.facet_pairs, off=self.facet_off),
            quad_ties=self.quad_ties, beam_ties=self.beam_ties,
            law=CohesiveLaw(self.K_coh, self.delta0, itf["delta_f"], itf["alpha_d"],
                            self.tie_order),
            pins=pins, wire_pins=wire_pins, pin_facets=pin_facets,
            forces=Forces(F[0], F[1], F[2], F[5], F[3], F[4], self.cyl_force))

    def _stack_facet_sets(self):
        """The node-facet sets stacked for :func:`bundle_forces` (their histories become
        views of the stacked ones); the pairs are stacked at each search
        (:meth:`_stack_facet_pairs`)."""
        sets = self.facet_sets
        for fs in sets:
            fs["hist_p"], fs["hist_ft"] = fs["hist"]
        arrays, off = stack_groups(sets, FACET_SPEC, shared=("hist_p", "hist_ft"))
        for fs in sets:
            fs["hist"] = (fs["hist_p"], fs["hist_ft"])
        self.facet_node_off, self.facet_quad_off = off["nodes"], off["quads"]
        prm = np.array([[fs["k"], fs["pen_max"], *fs["mu"]] for fs in sets],
                       dtype=float).reshape(-1, 5)
        self._stack_facet_pairs()
        self.facets = FacetSets(**arrays, pairs=self.facet_pairs, off=self.facet_off, prm=prm)

    def _stack_facet_pairs(self):
        arrays, off = stack_groups(self.facet_sets, {"pairs": ((2,), I8)})
        self.facet_pairs = arrays["pairs"]
        self.facet_off = np.ascontiguousarray(
            np.stack([self.facet_node_off, self.facet_quad_off, off["pairs"]], axis=1))

    def displacement_max(self) -> float:
        return float(np.max(np.abs(self.x - self.mesh.X)))

    def plastic_work(self) -> float:
        w = self.wires.plastic_work()
        if self.has_shells:
            w += float(shell_energies(self.sstate)[2])
        return w
