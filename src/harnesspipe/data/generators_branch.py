"""Generator of the synthetic branch pull tests (Sec. 2.3, 5; DESIGN sec. 4).

Truth: the Y-harness ROM (:mod:`harnesspipe.models.branch`) at the paper's alpha
(config ``paper.damping.alpha``, 0.2) with the beam properties and protocol of the
config's ``branch`` section; only alpha varies from sample to sample.
Markers: the bent shape of S2 at a few crosshead travels, sampled evenly along its
arc length (rows: displacement, marker index, x, y).  For the out-of-plane case
(Fig. 20) the pull is along z, so the marker ``y`` column holds the out-of-plane
coordinate z (the camera looks along the harness plane).
"""
from __future__ import annotations

import numpy as np

from harnesspipe.data.synthesize import Curve, TestSpec, register

MARKERS = 9
MARKER_DISPLACEMENTS = (10.0, 25.0, 50.0)


def s2_marker_rows(shapes: dict, load_case: str) -> np.ndarray:
    """Marker rows (displacement, index, x, y) spread evenly along S2's deformed arc."""
    vertical = 1 if load_case == "inplane" else 2
    rows = []
    for d in MARKER_DISPLACEMENTS:
        pts = shapes[d]
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        for k, sm in enumerate(np.linspace(0.05, 0.95, MARKERS) * s[-1]):
            rows.append((d, k, np.interp(sm, s, pts[:, 0]), np.interp(sm, s, pts[:, vertical])))
    return np.array(rows)


def model_options(cfg: dict) -> dict:
    """Keyword arguments of :func:`harnesspipe.models.branch.simulate` from the config."""
    b = cfg["branch"]
    return {"properties": b["properties"], "geometry": b["geometry"], "n_steps": b["n_steps"],
            "dt_min": b["dt_min"],
            "stroke": b["stroke"], "rate": b["rate"]}


def _simulator(cfg: dict, load_case: str):
    from harnesspipe.models import branch
    options = model_options(cfg)

    def simulate(p: dict) -> Curve:
        curve, shapes = branch.simulate(load_case, p["alpha"], return_shapes=True,
                                        shape_at=MARKER_DISPLACEMENTS, **options)
        return Curve(curve["displacement_mm"].to_numpy(), curve["force_N"].to_numpy(),
                     s2_marker_rows(shapes, load_case))
    return simulate


@register("branch")
def branch_tests(cfg: dict) -> list[TestSpec]:
    b = cfg["branch"]
    protocol = {"stroke_mm": b["stroke"], "rate_mm_s": b["rate"], "load_cell_N": b["load_cell_N"]}
    return [TestSpec(test_id=f"branch_{case}", kind="branch", item="y_harness", protocol=protocol,
                     truth={"alpha": cfg["paper"]["damping"]["alpha"]}, simulate=_simulator(cfg, case),
                     folder="branch", load_case=case,
                     extra_truth={"model": "Y-harness ROM, config branch.properties"})
            for case in ("inplane", "outofplane")]
