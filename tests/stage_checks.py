"""Checks shared by the stage tests (tests/test_tensile.py, tests/test_rom_stage.py)."""
from __future__ import annotations

import numpy as np
import pytest


def assert_intervals_and_replicate_band(fit: dict, curve_csv, u, F) -> None:
    """fit.json's 95 % intervals (issue 29): each holds its estimate, Fisher ones are
    estimate * exp(+-1.96 SE) (SE up to 5 %), the others profile-likelihood ones; curve.csv's
    replicate band: finite over the rows and, on the second half of the stroke, of the order
    of the t interval of the specimens' mean force there (t(2) sd / sqrt(3); within a factor
    two: it is the part of the specimens' spread the model's parameters can follow)."""
    import pandas as pd
    from scipy import stats
    for name, value in fit["parameters"].items():
        iv = fit["interval95"][name]
        assert (iv["lower"] is None or iv["lower"] < value) and (iv["upper"] is None or value < iv["upper"])
        se = fit["fisher"]["standard_error"][name]
        if iv["method"] == "fisher":
            assert se <= 0.05 and iv["upper"] == pytest.approx(value * np.exp(1.959964 * se), rel=1e-6)
        else:
            assert iv["method"] == "profile" and (se is None or se > 0.05)
    curve = pd.read_csv(curve_csv)
    x = curve["displacement_mm"].to_numpy()
    late = (x >= 0.5 * u[-1]) & (x <= u[-1])
    band = curve["band_replicate_N"].to_numpy()[late]
    mean_ci = stats.t.ppf(0.975, len(F) - 1) * np.interp(x[late], u, F.std(axis=0, ddof=1)) / np.sqrt(len(F))
    assert np.all(np.isfinite(band)) and 0.5 < np.median(band / mean_ci) < 2.0
