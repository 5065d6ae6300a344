"""The named argument groups of the bundle's force kernel (:func:`harnesspipe.fe.assembly.lanes.bundle_forces`).

Each group is a ``NamedTuple`` of arrays and scalars that Numba passes as one typed
tuple, so that a kernel reads ``beams.conn`` instead of the 40th positional argument:
two arrays of the same type can no longer be swapped by a reordering.  The groups'
arrays are the system's own (updated in place: histories, forces); the system makes the
groups once and again when an array is replaced (after a contact search).  Inside a
``prange`` a kernel writes a group's arrays only from a called kernel or through locals
taken before the loop: a store through a tuple's field in the loop body itself is lost
(Numba issue 7135, still open in 0.68).

The beams' group (:class:`harnesspipe.fe.elements.beam_explicit.Beams`), the wire-wire
contact's (:class:`harnesspipe.fe.contact.wire_wire.WireContact`) and the pins'
(:class:`harnesspipe.fe.contact.common.Cylinders`) live with the kernels that take them
and are imported from there; the stacked groups below are cut into the kernels' own
groups (:class:`~harnesspipe.fe.contact.node_facet.FacetSet`, ...) one member at a time.

Stacked groups (node-facet sets, tie groups, pin-facet groups) hold their members'
arrays one after the other (:func:`harnesspipe.fe.assembly.lanes.stack_groups`),
member ``g`` at rows ``off[g] .. off[g + 1] - 1`` of each array.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from harnesspipe.fe.contact.cohesive_ties import BeamTieSet, QuadTieSet, TieLaw
from harnesspipe.fe.contact.common import Cylinders   # noqa: F401  (re-exported)
from harnesspipe.fe.contact.wire_wire import WireContact   # noqa: F401  (re-exported)
from harnesspipe.fe.elements.beam_explicit import Beams   # noqa: F401  (re-exported)


class Shells(NamedTuple):
    """Belytschko-Lin-Tsay shells (:func:`harnesspipe.fe.elements.shell_bt.shell_forces`)."""
    conn: np.ndarray        # (n_sh, 4) node ids
    thick: np.ndarray       # (n_sh,) stiffness thickness
    mat: np.ndarray         # (n_sh, k) material rows
    state: np.ndarray       # (n_sh, N_STATE) strains, stresses, plastic state, in place
    f_el: np.ndarray        # (n_sh, 4, 6) element forces (scratch)
    hg: float               # hourglass coefficient


class FacetSets(NamedTuple):
    """Node-facet contact sets, stacked
    (:func:`harnesspipe.fe.contact.node_facet.node_facet_contact`)."""
    nodes: np.ndarray       # (n,) contact nodes
    r: np.ndarray           # (n,) their radii
    quads: np.ndarray       # (n_q, 4) facets
    t: np.ndarray           # (n_q,) thicknesses
    sign: np.ndarray        # (n_q,) side of the nodes
    hist_p: np.ndarray      # (n, maxs) slot history, in place
    hist_ft: np.ndarray     # (n, maxs, 3)
    pairs: np.ndarray       # (n_pairs, 2) candidate (node, quad) pairs, each set's own indices
    off: np.ndarray         # (n_sets + 1, 3) offsets of nodes, quads, pairs
    prm: np.ndarray         # (n_sets, 5) k, pen_max, mu_s, mu_k, d_c


def _extended(name: str, base, extra: tuple, doc: str, drop: tuple = ()):
    """The group ``name``: the fields of the group ``base`` (but ``drop``), then ``extra``
    ((field, type) pairs); the base's fields keep their meaning (a stacked group holds its
    members' rows one after the other)."""
    fields = [(f, base.__annotations__[f]) for f in base._fields if f not in drop]
    group = NamedTuple(name, [*fields, *extra])
    group.__doc__ = doc
    return group


QuadTies = _extended(
    "QuadTies", QuadTieSet, (("off", np.ndarray),),
    """Cohesive quad tie sets (:class:`~harnesspipe.fe.contact.cohesive_ties.QuadTieSet`),
    stacked; ``off`` (n_groups + 1, 2): the offsets of their ties and quads.""")

BeamTies = _extended(
    "BeamTies", BeamTieSet, (("off", np.ndarray),),
    """Cohesive beam tie sets (:class:`~harnesspipe.fe.contact.cohesive_ties.BeamTieSet`,
    without the segments: the bundle's own), stacked; ``off`` (n_groups + 1,): the
    offsets of their ties.""", drop=("seg",))

CohesiveLaw = _extended(
    "CohesiveLaw", TieLaw, (("order", np.ndarray),),
    """The cohesive law (:class:`~harnesspipe.fe.contact.cohesive_ties.TieLaw`) and
    ``order`` (n_groups, 2): the kind (0: quad, 1: beam) and group of the tie groups, in
    the order they act.""")


class WirePins(NamedTuple):
    """Wires on the pins as chains (:func:`harnesspipe.fe.contact.wire_pins.chain_cylinder_contact`)."""
    start: np.ndarray       # (n_wires + 1,) first segment of each wire
    mu: float
    k: float
    hist: np.ndarray        # (n_wires, n_cyl, 3) friction history, in place


class PinFacets(NamedTuple):
    """Shell facet groups on the pins, stacked
    (:func:`harnesspipe.fe.contact.facet_pins.facets_cylinder_contact`)."""
    quads: np.ndarray       # (n_q, 4)
    t: np.ndarray           # (n_q,)
    slack: np.ndarray       # (n_groups * n_cyl,) initial gaps closed without force
    hist_q: np.ndarray      # (n_groups * n_cyl, patches) history, in place
    hist: np.ndarray        # (n_groups * n_cyl, patches, 3)
    off: np.ndarray         # (n_groups + 1, 2) offsets of quads, per-cylinder rows
    prm: np.ndarray         # (n_groups, 2) mu, penalty


class Forces(NamedTuple):
    """The force families the kernel ADDS into, all (n_nodes, 6) ON the nodes, and the
    force on the pins."""
    f_el: np.ndarray        # element forces (beams and shells)
    f_n: np.ndarray         # bundle contacts, normal
    f_t: np.ndarray         # bundle contacts, friction
    f_c: np.ndarray         # cohesive ties
    f_pn: np.ndarray        # pins, normal
    f_pt: np.ndarray        # pins, friction
    f_cyl: np.ndarray       # (n_cyl, 3) ON the pins
