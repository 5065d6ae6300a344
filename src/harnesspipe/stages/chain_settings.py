"""The hi-fi calibration chain of Sec. 4.2 and the settings its rules pass to the stages.

The chain in order: each step fixes what the earlier steps fitted (``prior``).  It starts
with the specimen's build state that the sensitivity screen shows the curves depend on
(bench/RESULTS.md "Hi-fi sensitivity screen"): on the whole test of both tube CWBs, which
wires the end bands bind (``binding``, a pick between its two values), the end bands' wraps
(``build``) and the tape's wrapping tension (``tension``), two bounded searches in turn; then,
at those end bands, whether the half-lap CWB's slit tube is rolled onto its wires or stays
as moulded (``closure``, a pick, on the one calibration case with a slit tube).  Then the
paper's steps; before the paper's fabric step, the fabric CWB's own end bands, which wires
they bind (``fabric_binding``, a pick like ``binding``) and their wraps (``fabric_build``):
its tape is only at the ends, and the tube CWBs' fitted bands hold its curled sleeve too
stiffly (bench/RESULTS.md "The fabric sleeve curled onto its bundle", "Which wires the end
bands bind").  ``cores``: the step's Snakemake threads.  Nothing else of the chain can run
beside the friction and cohesive fits (every virtual test needs their interface), so they
take both cores (one process per case, or one process with two Numba threads); the fabric
fit takes one, and the virtual tests of the other cases run beside it (one Numba thread per
run is the efficient use of a core).  ``window`` and ``bounds`` name keys of the config's
``hifi.pipeline``.

The settings are JSON texts: a rule passes them as a param, so a rule reruns exactly when the
settings of its run change (workflow/rules/hifi.smk).
"""
from __future__ import annotations

import json

def _chained(steps: dict) -> dict:
    """``steps`` with each one's ``prior``: every step before it (the chain runs in order)."""
    return {name: {**s, "prior": list(steps)[:i]} for i, (name, s) in enumerate(steps.items())}


TUBE_CWBS = ["cwb19_t2_closed", "cwb19_t2_open_halflap"]
STEPS = _chained({
    "binding": {"names": ["end_tape_binds"], "cases": TUBE_CWBS, "window": "build_window",
                "method": "choice", "choices": "binds_choices", "cores": 2},
    "build": {"names": ["end_tape_layers"], "cases": TUBE_CWBS, "window": "build_window",
              "method": "bounded", "bounds": "layers_bounds", "cores": 2},
    "tension": {"names": ["tape_tension"], "cases": TUBE_CWBS, "window": "build_window",
                "method": "bounded", "bounds": "tension_bounds", "cores": 2},
    "closure": {"names": ["tube_closure"], "cases": ["cwb19_t2_open_halflap"],
                "window": "build_window", "method": "choice", "choices": "closure_choices",
                "cores": 2},
    "mu_rtb": {"names": ["mu_rtb"], "cases": ["cwb19_t2_closed"], "window": "friction_window",
               "method": "bounded", "bounds": "mu_bounds", "cores": 2},
    "mu_rtp": {"names": ["mu_rtp"], "cases": ["cwb19_t2_open_halflap"],
               "window": "friction_window", "method": "bounded", "bounds": "mu_bounds", "cores": 2},
    "cohesive": {"names": ["delta0", "delta_f", "alpha_d"], "cases": TUBE_CWBS,
                 "window": "cohesive_window", "method": "simplex", "cores": 2},
    "fabric_binding": {"names": ["fabric_end_tape_binds"], "cases": ["cwb19_t2_fabric"],
                       "window": "fabric_window", "method": "choice", "choices": "binds_choices",
                       "cores": 1},
    "fabric_build": {"names": ["fabric_end_tape_layers"], "cases": ["cwb19_t2_fabric"],
                     "window": "fabric_window", "method": "bounded", "bounds": "layers_bounds",
                     "cores": 1},
    "fabric": {"names": ["E2_over_E1"], "cases": ["cwb19_t2_fabric"], "window": "fabric_window",
               "method": "bounded", "bounds": "E2_bounds", "cores": 1},
})
VALIDATION = ("cwb19_t1_open_coarse", "cwb10t1_9t2_fabric")   # Sec. 4.2: predicted, no refit
CALIBRATED = sorted({c for s in STEPS.values() for c in s["cases"]})
BUILD = ("end_tape_binds", "end_tape_layers", "tape_tension", "tube_closure", "fabric_end_tape_binds",
         "fabric_end_tape_layers")   # build-state inputs the chain fits (config hifi.build)
WINDOWS = ("build_window", "friction_window", "cohesive_window", "fabric_window",
           "layers_bounds", "tension_bounds", "mu_bounds", "E2_bounds", "binds_choices",
           "closure_choices")


def check_windows(config: dict) -> None:
    """Every window and bound of ``hifi.pipeline`` increases, and its ``chain_profile`` names a
    profile (ValueError naming the key)."""
    pipe = config["hifi"]["pipeline"]
    for name in WINDOWS:
        if not pipe[name][0] < pipe[name][1]:
            raise ValueError(f"config hifi.pipeline.{name}: {pipe[name]} must increase")
    chain_profile(config)


def chain_profile(config: dict) -> str:
    """The resolution profile the chain's fits run at: ``hifi.pipeline.chain_profile``, or the
    run's own profile when it is null.  The virtual tests always run at the run's profile."""
    name = config["hifi"]["pipeline"]["chain_profile"] or config["profile"]
    if name not in config["profiles"]:
        raise ValueError(f"config hifi.pipeline.chain_profile: {name!r} is not a profile; "
                         f"expected one of {sorted(config['profiles'])} or null")
    return name


def reuses_fit_runs(config: dict) -> bool:
    """Whether a virtual test may take its chain step's best-point run: only when the chain
    ran at the run's own mesh (else the two runs are different models)."""
    return chain_profile(config) == config["profile"]


def cases(config: dict) -> dict:
    """Every case a hi-fi rule runs: the config's cases and ``hifi.extra_cases``."""
    return {**config["cases"], **config["hifi"]["extra_cases"]}


def is_fabric(config: dict, case: str) -> bool:
    return cases(config)[case]["covering"] == "fabric_tube"


def role(case: str) -> str:
    """A case's role in the chain: calibration (fitted on), validation (predicted, Sec. 4.2)
    or prediction."""
    if case in VALIDATION:
        return "validation"
    return "calibration" if case in CALIBRATED else "prediction"


def virtual_priority(config: dict, case: str, reused: bool) -> float:
    """Scheduling priority of a virtual test: longest first (so the last one to finish is a
    short one), 1 plus the run's cost in wire-steps (wires x t_total_scale) / 1000, below
    the chain's 10; a reused run is 1."""
    if reused:
        return 1.0
    c = cases(config)[case]
    return 1.0 + sum(c["wires"].values()) * c.get("t_total_scale", 1.0) / 1000.0


def budget(config: dict) -> dict:
    """Hi-fi evaluations per fit at the profile whose mesh the fits run on (:func:`chain_profile`;
    missing profile: default): an evaluation's cost is that mesh's, and past its first three a
    search at the data's floor bought nothing (bench/RESULTS.md 'Pipeline (default)')."""
    budgets = config["hifi"]["pipeline"]["budgets"]
    return budgets.get(chain_profile(config), budgets["default"])


def model(config: dict, case: str, resolution: dict, paper_coverings: bool = False,
          profile: str | None = None) -> dict:
    """The part of the config a hi-fi run of ``case`` reads: its case entry, the covering it
    has (and its material), wires and tape, test geometry, explicit settings and
    ``resolution`` (of ``profile``, default the run's: :func:`harnesspipe.config.resolution`).
    A change elsewhere (another covering, the ROM, the branch) reruns none of its runs."""
    profile = profile or config["profile"]
    c = cases(config)[case]
    cov = c["covering"]
    covs = {} if cov == "none" else {cov: config["coverings"][cov]}
    mats = {k: config["materials"][k] for k in ("wire_type1", "wire_type2", "pvc_tape")}
    if covs:
        mats[covs[cov]["material"]] = config["materials"][covs[cov]["material"]]
    out = {
        "profile": profile,
        "profiles": {profile: {"hifi": resolution["hifi"]}},
        "cases": {case: c},
        "hifi": {"coverings": "paper", "explicit": config["hifi"]["explicit"],
                 "build": config["hifi"]["build"], "extra_cases": {}},
        "interfaces": config["interfaces"],
        "explicit": config["explicit"],
        "materials": mats,
        "coverings": covs,
        "three_point": config["three_point"],
    }
    if paper_coverings:
        out["paper"] = {"table2": {k: v for k, v in config["paper"]["table2"].items() if k in covs}}
    return out


def interface_of(config: dict, case: str, values: dict) -> dict:
    """Interface values a run of ``case`` uses (E2/E1 only with a fabric covering)."""
    return {k: v for k, v in values.items() if k != "E2_over_E1" or is_fabric(config, case)}


def run_settings(config: dict, case: str, resolution: dict, crosscheck: bool) -> str:
    """Settings of a virtual test (``stage hifi-run``): at the paper's Table 2 and interface
    for the cross-check, else at the chain's interface (given to the stage as a file)."""
    return json.dumps({
        "model": model(config, case, resolution, paper_coverings=crosscheck),
        "interface": interface_of(config, case, config["paper"]["interface"]) if crosscheck else {},
        "set": config["hifi"]["pipeline"]["set"],
    }, sort_keys=True)


def fit_stop(config: dict, window) -> dict:
    """``--set`` that ends a fit's runs just past its window (friction: < 20 mm of 30), if any."""
    after = config["hifi"]["pipeline"]["stop_after_window"]
    end = window[1] + (after or 0.0)
    if after is None or end >= config["three_point"]["deflection"]:
        return {}
    return {"stop_deflection": end}


def build_start(config: dict, name: str) -> float:
    """Start value of a fitted build input: config ``hifi.build``; the fabric CWB's end bands
    (``fabric_<name>``) start as a fabric CWB's run reads them
    (:func:`harnesspipe.models.hifi_mesh_parts.end_band_value`: ``<name>``'s config value when
    null), not at the tube CWBs' fitted value."""
    from harnesspipe.models.hifi_mesh_parts import end_band_value
    build = config["hifi"]["build"]
    if name.startswith("fabric_"):
        return end_band_value(build, True, name.removeprefix("fabric_"))
    return float(build[name])


def fit_settings(config: dict, step: str) -> str:
    """Settings of one chain step (``stage hifi-fit``, :func:`harnesspipe.stages.hifi_chain.fit_step`):
    its models at the mesh of :func:`chain_profile` and that profile's :func:`budget`."""
    pipe = config["hifi"]["pipeline"]
    profile = chain_profile(config)
    resolution = config["profiles"][profile]
    s = STEPS[step]
    bounded = s["method"] == "bounded"
    choice = s["method"] == "choice"
    fabric = any(is_fabric(config, c) for c in s["cases"])
    start = {k: v for k, v in config["hifi"]["parameters"].items() if k != "E2_over_E1" or fabric}
    # every build input a run of these cases reads, at its start value: a run's identity then
    # does not depend on which step made it (the next step takes its start's run, hifi_chain.StoredRun)
    start.update({k: build_start(config, k) for k in BUILD if not k.startswith("fabric_") or fabric})
    window = pipe[s["window"]]
    return json.dumps({
        "names": s["names"], "cases": s["cases"], "window": window, "method": s["method"],
        "bounds": pipe[s["bounds"]] if bounded else None,
        "choices": pipe[s["choices"]] if choice else None,
        "xatol": pipe["bounded_xatol"] if bounded else pipe["simplex"]["xatol"],
        "fatol": None if bounded or choice else pipe["simplex"]["fatol"],
        "maxfev": budget(config)["bounded_maxfev" if bounded else "simplex_maxfev"],
        "flat_factor": pipe["flat_factor"],
        "bits_spread": pipe["fidelity_spread"],
        "start": start,
        "models": {c: model(config, c, resolution, profile=profile) for c in s["cases"]},
        "set": {**fit_stop(config, window), **pipe["set"]},
    }, sort_keys=True)
