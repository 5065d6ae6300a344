"""Reduced-order beam models (Sec. 4.3), the Python face of ``harnesspipe rom``.

Units mm, N, MPa.  The bundle is a solid circular effective beam of the outer
radius r_o (I = pi r_o^4 / 4) with the eq. 2 elastoplastic law.  See
:mod:`harnesspipe.models.rom_beam` for the models and their richer results.
"""
from __future__ import annotations

import pandas as pd

from harnesspipe.models.rom_beam import Material, Mesh, cantilever_run, three_point_run


def three_point(E, sigma_y=None, K=None, n=None, radius=None, supports="rollers", span=127.0,
                overhang=36.5, deflection=30.0, elastic=False, nu=0.39, mu=0.0,
                return_shapes=False, shape_at=(0.0, 10.0, 20.0, 30.0), **mesh):
    """Force on the loading pin vs its travel in three-point bending.

    ``supports="rollers"``: 200 mm sample (span + 2 overhang) on two rigid 5 mm roller
    pins in penalty contact (Coulomb coefficient ``mu``, default frictionless), loaded
    by a 5 mm pin at midspan.  ``"pinned"``: span only, pinned/roller ends, midspan
    deflection prescribed.  ``mesh``: ``n_elements`` (even, default 40),
    ``n_increments`` (output steps, default 20), ``n_rings``, ``n_sectors`` (fibre
    section, default 4 x 12), ``n_gauss`` (Lobatto points, default 3).

    Returns a DataFrame ``deflection_mm, force_N``; with ``return_shapes=True`` a tuple
    ``(curve, shapes)`` where ``shapes`` maps each deflection of ``shape_at`` (within
    [0, deflection]) to the (n_nodes, 3) array of deformed centreline coordinates.
    """
    if radius is None:
        raise ValueError("radius (outer radius r_o of the bundle, mm) is required")
    material = Material.of(E, sigma_y, K, n, elastic, nu)
    shapes = [d for d in shape_at if 0.0 <= d <= deflection] if return_shapes else ()
    run = three_point_run(material, radius, supports, span, overhang, deflection, mu,
                          Mesh(**mesh), shape_at=shapes)
    return (run.curve, run.shapes) if return_shapes else run.curve


def cantilever(E, radius, length, tip_load=None, elastic=False, sigma_y=None, K=None, n=None,
               tip_displacement=None, nu=0.39, **mesh) -> pd.DataFrame:
    """Large-deflection cantilever, clamped at x = 0, tip dead load ``tip_load`` along +y.

    With ``tip_displacement`` (mm, +y) the tip deflection is prescribed instead and
    ``load_N`` is the reaction.  Columns ``load_N, tip_ux_mm, tip_uy_mm,
    tip_rotation_rad`` (ux along the undeformed axis, uy across).  ``mesh`` as in
    :func:`three_point` (default 20 elements, 20 increments).
    """
    material = Material.of(E, sigma_y, K, n, elastic, nu)
    if tip_displacement is not None:
        tip_load = None
    mesh = {"n_elements": 20, **mesh}
    return cantilever_run(material, radius, length, tip_load, tip_displacement, Mesh(**mesh)).curve
