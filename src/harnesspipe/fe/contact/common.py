"""What the contact and cohesive kernels of the explicit bundle model share: their
conventions, the slot history of friction and the transport of a committed friction
force onto the current tangent plane.

Conventions.  Units mm, N, s.  ``x`` (n_nodes, 3+) current positions, ``v``
(n_nodes, 3+) current half-step velocities (translations in [:, :3]), so that the
increment of the step that led to ``x`` is ``v dt``.  Force arrays are (n_nodes, 6+):
every kernel ADDS the forces acting ON the nodes into them, normal (penalty) forces in
``f_n``, tangential friction forces in ``f_t`` and cohesive forces in their own array
``f_c`` (so that the caller can account the work of each; frictional dissipation is the
work of ``f_t``).  Pair loops write per-pair arrays (in a ``prange`` where a kernel has a
parallel version, serially when short: SERIAL_MAX_CHUNKS), then a serial scatter adds them
to the nodes (no races).  Wire-wire first
flags the touching pairs (with an early bounding-box reject of far candidates), then
computes forces and friction for those only; node-facet rejects pairs whose node is far
from the quad's box before projecting (:mod:`.node_facet`) and updates its history
in place.  A parallel kernel has a serial twin built from the same pieces (``*_serial``):
the hi-fi bundle runs the serial kernels side by side in two lanes
(:mod:`harnesspipe.fe.assembly.lanes`), and the parallel ones -- for a caller that runs one
kernel at a time -- are the lanes' reference in the tests.  The wire-wire contact, the beam
ties and the facet pins have a serial kernel only (it runs in a lane and in the tests'
reference alike).

History.  Each call is one committed explicit step: friction and cohesive history
arrays are updated IN PLACE.  Do not call a kernel twice for the same step.

* Slot arrays (wire-wire, node-facet): ``hist_partner`` (n_owner, MAXS) int64, -1 for a
  free slot, else the partner id (segment / quad); ``hist_ft`` (n_owner, MAXS, ..., 3)
  the committed elastic tangential (friction) force per unit weight of the contact point,
  a global vector.  Allocate with :func:`new_slot_history`.  After each call the slots
  hold exactly the contacts active in that call (an inactive pair forgets its friction).
  A contact whose partner changes to an ADJACENT element (shares a node: sliding onto the
  next element) inherits the old partner's force.  At most MAXS partners per owner are
  remembered (an overflowing contact still acts, but restarts from zero friction): size
  the history with :func:`fit_slot_history` after every search.
* Friction force at the current step: ``f_old`` is rotated onto the current tangent
  plane (projected and rescaled to keep its magnitude), then
  ``rate_dependent_friction`` / ``coulomb_return_map`` of :mod:`harnesspipe.fe.materials.friction`.
* Eq. 6 rate in physical time: ``dt_phys = dt * time_scale`` with ``time_scale`` =
  physical duration / simulated duration; the slip rate is ``|dg_t| / dt_phys``.

Normal law everywhere: ``p = k_n max(-gap, 0)`` (linear penalty, no contact damping).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from harnesspipe.fe.loops import loop_kernel
from harnesspipe.fe.vec3 import dot

DEFAULT_MAXS = 8        # partner slots per owner of a slot history (grown by fit_slot_history)
CHUNK = 64              # items per parallel task (scratch arrays are allocated per task)
SERIAL_MAX_CHUNKS = 1   # up to this many tasks a loop runs serially (no parallel-region cost)
REJECT_TOL = 1e-9       # relative slack of the early distance rejects (round-off of the points)


class Cylinders(NamedTuple):
    """Rigid unbounded cylinders (the test's rollers and loading pin); none: zero rows."""
    centres: np.ndarray     # (n_cyl, 3) a point of each axis
    axes: np.ndarray        # (n_cyl, 3) unit axes
    radii: np.ndarray       # (n_cyl,)
    velocity: np.ndarray    # (n_cyl, 3)


def new_slot_history(n_owner, maxs=DEFAULT_MAXS, points=1):
    """Empty slot history: ``hist_partner`` (n_owner, maxs) = -1 and ``hist_ft``.

    ``points=WW_POINTS`` for wire-wire (``hist_ft`` (n_seg, maxs, WW_POINTS, 3));
    ``points=1`` for node-facet (``hist_ft`` (n_nodes_list, maxs, 3)).
    """
    hp = -np.ones((n_owner, maxs), dtype=np.int64)
    if points == 1:
        return hp, np.zeros((n_owner, maxs, 3))
    return hp, np.zeros((n_owner, maxs, points, 3))


def fit_slot_history(hist, owners):
    """The slot history ``(hist_partner, hist_ft)`` with room for every owner's candidate
    partners (``owners``: the owner of each candidate pair, e.g. ``min(a, b)`` of the
    wire-wire pairs); existing slots are kept.  A touching pair that finds no free slot
    loses its stick force at every step, and which pairs lose it depends on the pair order."""
    hp, hf = hist
    grow = int(np.bincount(owners, minlength=hp.shape[0]).max(initial=0)) - hp.shape[1]
    if grow <= 0:
        return hist
    pad = ((0, 0), (0, grow)) + ((0, 0),) * (hf.ndim - 2)
    return np.pad(hp, pad[:2], constant_values=-1), np.pad(hf, pad)


@loop_kernel
def share_node(conn, a, b):
    """Elements ``a`` and ``b`` of ``conn`` have a node in common (neighbours never contact)."""
    for i in range(conn.shape[1]):
        for j in range(conn.shape[1]):
            if conn[a, i] == conn[b, j]:
                return True
    return False


@loop_kernel
def find_slot(hist_partner, conn, owner, partner):
    """Slot of ``partner`` in the owner's row, else of an element adjacent to it, else -1."""
    maxs = hist_partner.shape[1]
    for s in range(maxs):
        if hist_partner[owner, s] == partner:
            return s
    for s in range(maxs):
        q = hist_partner[owner, s]
        if q >= 0 and share_node(conn, q, partner):
            return s
    return -1


@loop_kernel
def free_slot(hist_partner, owner):
    """The first free history slot of ``owner`` (partner index < 0), -1 when all are taken."""
    for s in range(hist_partner.shape[1]):
        if hist_partner[owner, s] < 0:
            return s
    return -1


@njit(cache=True, inline="always")
def rotate_onto_plane(f, n):
    """Project ``f`` (3,) onto the plane normal to unit ``n`` keeping |f| (in place)."""
    m0 = math.sqrt(dot(f, f))
    if m0 == 0.0:
        return
    fn = dot(f, n)
    for k in range(3):
        f[k] -= fn * n[k]
    m1 = math.sqrt(dot(f, f))
    if m1 < 1e-12 * m0:
        for k in range(3):
            f[k] = 0.0
        return
    for k in range(3):
        f[k] *= m0 / m1


@njit(cache=True, inline="always")
def to_tangent_plane(f_old, dg, n):
    """Friction inputs on the current tangent plane (unit normal ``n``), in place: the
    committed force ``f_old`` rotated onto it (:func:`rotate_onto_plane`), the slip
    increment ``dg`` projected on it."""
    rotate_onto_plane(f_old, n)
    dgn = dot(dg, n)
    for k in range(3):
        dg[k] -= dgn * n[k]
