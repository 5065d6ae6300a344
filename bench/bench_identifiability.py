"""How well the shipped kind of test data can determine each fitted parameter at all.

Run with the project's venv: ``.venv/bin/python bench/bench_identifiability.py``.
Replaces the section "## Identifiability (Cramer-Rao bound)" of bench/RESULTS.md.

For every synthetic test of the twin (tensile: Table 2, three-point: Table 3), at
the truth parameters and with the twin's own data design (``synthesize.rows``
decimated rows, load-cell noise ``synthesize.noise_fraction`` of the peak force),
the Cramer-Rao bound of ln p (:mod:`harnesspipe.calibrate.uncertainty`): the
smallest standard deviation any unbiased estimator from one specimen's curve can
have; from the mean of the ``synthesize.samples`` specimens it is that over
sqrt(samples).  This is load-cell noise alone: the specimen-to-specimen scatter
(``synthesize.variability`` per parameter) comes on top.  Two cases: all four
parameters free, and E known (the three-point stage fixes E by eq. 13 first).
"""
from __future__ import annotations

import numpy as np

from benchlib import write_section

from harnesspipe import config as cfgmod
from harnesspipe.calibrate import uncertainty
from harnesspipe.data.generators import three_point, tensile_tests

HEADING = "## Identifiability (Cramer-Rao bound)"
NAMES = ["E", "sigma_y", "K", "n"]


def bounds(spec, syn: dict) -> tuple[dict, dict, float]:
    """Standard deviations of ln p for one specimen: (all four free, E known) and the noise."""
    first = spec.simulate(spec.truth)
    u = np.linspace(0.0, float(first.displacement[-1]), syn["rows"])

    def curve(p):
        c = spec.simulate(p)
        return np.interp(u, c.displacement, c.force)
    sigma = syn["noise_fraction"] * float(np.max(np.abs(first.force)))
    J = uncertainty.log_sensitivities(curve, spec.truth, NAMES)
    free = np.sqrt(np.diag(uncertainty.log_covariance(J, sigma**2)))
    known_E = np.sqrt(np.diag(uncertainty.log_covariance(J[:, 1:], sigma**2)))
    return dict(zip(NAMES, free)), dict(zip(NAMES[1:], known_E)), sigma


def percent(x: float) -> str:
    return f"{100.0 * x:.3g} %" if np.isfinite(x) else "inf"


def main() -> None:
    cfg = cfgmod.load()
    syn = cfg["synthesize"]
    root_n = np.sqrt(syn["samples"])
    rows = []
    for spec in tensile_tests(cfg) + three_point(cfg):
        free, known_E, sigma = bounds(spec, syn)
        cells = [percent(free[k] / root_n) for k in NAMES] + [percent(known_E[k] / root_n) for k in NAMES[1:]]
        rows.append(f"| {spec.test_id} | {sigma:.3g} | " + " | ".join(cells) + " |")
        print(rows[-1], flush=True)
    text = f"""{HEADING}

`bench/bench_identifiability.py`, at the truth of every synthetic test, with the twin's data
design: {syn['rows']} rows per curve, load-cell noise {100 * syn['noise_fraction']:.3g} % of the
peak force (1 sigma), mean of {syn['samples']} specimens.  Smallest standard deviation of
ln p any unbiased estimator can reach from that mean (Cramer-Rao bound, load-cell noise only;
the {100 * syn['variability']:.3g} % specimen scatter of each parameter comes on top: its mean over
{syn['samples']} specimens alone is {100 * syn['variability'] / root_n:.2g} %):

| test | noise sigma [N] | E | sigma_Y | K | n | sigma_Y (E known) | K (E known) | n (E known) |
|---|---|---|---|---|---|---|---|---|
""" + "\n".join(rows) + """

A parameter whose bound is above 5 % cannot be tested for "within 5 % of truth" on this data,
whatever the estimator: the curve fixes a combination of it with the others (for the
three-point sets the flow stress at the strains the fibres reach, sec. "ROM identifiability").
Each fit's own standard errors (from the replicates' scatter) are in its fit.json and the report.
"""
    write_section(HEADING, text)


if __name__ == "__main__":
    main()
