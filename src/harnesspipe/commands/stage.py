"""``harnesspipe stage ...``: the entry points Snakemake rules call, one per stage step.

Each takes its settings as one JSON object (the rule builds it from the config),
so the rule's params -- and thus its reruns -- follow exactly the settings used.
"""
from __future__ import annotations

import json
from pathlib import Path


def _settings(text: str) -> dict:
    import argparse
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise argparse.ArgumentTypeError(f"--settings is not valid JSON: {exc}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError("--settings must be a JSON object")
    return value


def _has_key(value, key: str) -> bool:
    """``key`` is a key of the JSON object ``value`` or of an object inside it."""
    if isinstance(value, dict):
        return key in value or any(_has_key(v, key) for v in value.values())
    if isinstance(value, list):
        return any(_has_key(v, key) for v in value)
    return False


def _named_keys(func):
    """The step ``func``, with a key missing from its ``--settings`` reported as bad input
    (exit 2, naming the key) instead of a traceback."""
    def step(args):
        try:
            return func(args)
        except KeyError as exc:
            key = exc.args[0] if exc.args else None
            settings = getattr(args, "settings", None)
            if settings is None or not isinstance(key, str) or _has_key(settings, key):
                raise
            from harnesspipe.cli import InputError
            raise InputError(f"stage {args.stage_command}: --settings has no key {key!r} (the "
                             "rule builds it from config/config.yaml)") from None
    return step


def _collector(ssub, name: str, text: str, func) -> None:
    """A subcommand that collects fit.json files (``--fits``) into one table (``--out``)."""
    p = ssub.add_parser(name, help=text)
    p.add_argument("--fits", type=Path, nargs="+", required=True)
    p.add_argument("--out", type=Path, required=True)
    p.set_defaults(func=func)

def register(sub) -> None:
    stage = sub.add_parser("stage", help="pipeline stage steps (called by the Snakemake rules)")
    ssub = stage.add_subparsers(dest="stage_command", required=True, metavar="STEP")

    p = ssub.add_parser("warmup", help="compile or load every Numba kernel once")
    p.add_argument("--hifi", action="store_true", help="the hi-fi model's kernels instead")
    p.set_defaults(func=_warmup)

    p = ssub.add_parser("rom-fit", help="eq. 13 + simplex for one CWB case (Sec. 4.3)")
    p.add_argument("--case", required=True)
    p.add_argument("--reference", type=Path, required=True,
                   help="prepared test (HDF5), or a hi-fi curve.csv with rom.reference hifi")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.set_defaults(func=_rom_fit)

    p = ssub.add_parser("branch-fit", help="calibrate the joint damping alpha (Sec. 5, eq. 15)")
    p.add_argument("--reference", type=Path, required=True, help="prepared in-plane test (HDF5)")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.add_argument("--damping", type=Path, required=True, help="damping.csv to write")
    p.add_argument("--properties-from", nargs="*", default=[], metavar="CASE=FIT",
                   help="fit.json of eq. 13 + simplex on a case's hi-fi virtual test")
    p.set_defaults(func=_branch_fit)

    p = ssub.add_parser("branch-predict", help="Y-harness ROM against a test, no refit")
    p.add_argument("--reference", type=Path, required=True)
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.add_argument("--load-case", choices=("inplane", "outofplane"), required=True)
    group = p.add_mutually_exclusive_group(required=True)
    group.add_argument("--alpha", type=float, help="damping coefficient [s]")
    group.add_argument("--damping", type=Path, help="damping.csv with the calibrated alpha")
    p.add_argument("--item", required=True, help="title of the prediction in the report")
    p.add_argument("--role", default="validation")
    p.add_argument("--properties-from", nargs="*", default=[], metavar="CASE=FIT",
                   help="fit.json of eq. 13 + simplex on a case's hi-fi virtual test")
    p.set_defaults(func=_branch_predict)

    p = ssub.add_parser("tensile-fit", help="calibrate one covering on its tensile test (Sec. 3.2)")
    p.add_argument("--component", required=True, choices=("closed_tube", "open_tube", "fabric_tube"))
    p.add_argument("--reference", type=Path, required=True, help="prepared test (HDF5)")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.set_defaults(func=_tensile_fit)

    _collector(ssub, "table2", "collect tensile fits into table2.csv", _table2)

    _collector(ssub, "table3", "collect ROM fits into table3.csv", _table3)

    p = ssub.add_parser("hifi-run", help="one hi-fi virtual three-point test of a case (Sec. 4.1)")
    p.add_argument("--case", required=True)
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.add_argument("--coverings", type=Path, default=None, help="table2.csv (default: the paper's Table 2)")
    p.add_argument("--interface", type=Path, default=None,
                   help="fit.json of a chain step whose interface replaces the settings' values")
    p.add_argument("--reference", type=Path, default=None, help="prepared test (HDF5) to compare with")
    p.add_argument("--role", default="virtual", help="crosscheck | validation | virtual (report)")
    p.add_argument("--reuse", type=Path, default=None,
                   help="folder of an earlier run (a fit's best point) taken when it is the same run")
    p.set_defaults(func=_hifi_run)

    p = ssub.add_parser("branch-hifi", help="the hi-fi Y harness on a pull test (Sec. 5, Fig. 18a)")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--coverings", type=Path, default=None, help="table2.csv (default: the paper's Table 2)")
    p.add_argument("--outdir", type=Path, required=True)
    p.set_defaults(func=_branch_hifi)

    p = ssub.add_parser("hifi-fit", help="one step of the hi-fi interface calibration (Sec. 4.2)")
    p.add_argument("--step", required=True)
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--reference", nargs="+", required=True, metavar="CASE=H5",
                   help="prepared test of every case of the step")
    p.add_argument("--coverings", type=Path, default=None, help="table2.csv of the tensile stage")
    p.add_argument("--prior", type=Path, nargs="*", default=[], help="fit.json of the earlier steps")
    p.add_argument("--cores", type=int, default=1,
                   help="cores of the step: the cases of one evaluation run side by side in "
                        "min(cores, cases) processes sharing the cores (a run left alone takes "
                        "them all); a single case runs on the NUMBA_NUM_THREADS threads")
    p.add_argument("--outdir", type=Path, required=True)
    p.set_defaults(func=_hifi_fit)

    _collector(ssub, "hifi-interface", "collect the chain fits into interface.csv", _hifi_interface)

    p = ssub.add_parser("hifi-rom", help="eq. 13 + simplex on a hi-fi curve (Table 3 cross-check)")
    p.add_argument("--case", required=True)
    p.add_argument("--curve", type=Path, required=True, help="hi-fi curve.csv (deflection_mm,force_N)")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.add_argument("--label", default="hi-fi (paper's parameters)", help="legend of the hi-fi curve")
    p.set_defaults(func=_hifi_rom)

    for p in ssub.choices.values():
        p.set_defaults(func=_named_keys(p.get_default("func")))


def _warmup(args) -> int:
    from harnesspipe.stages.warmup import warm_up, warm_up_hifi
    for name, seconds in (warm_up_hifi() if args.hifi else warm_up()).items():
        print(f"{name}: {seconds:.2f} s")
    return 0


def _rom_fit(args) -> int:
    from harnesspipe.stages.rom import fit_case
    fit = fit_case(args.case, args.reference, args.settings, args.outdir)
    print(json.dumps(fit, indent=2))
    return 0


def _case_paths(items, option: str) -> dict:
    """``CASE=PATH`` arguments of ``option`` as {case: Path}."""
    from harnesspipe.cli import InputError
    paths = {}
    for item in items:
        case, sep, path = item.partition("=")
        if not sep:
            raise InputError(f"{option} {item!r}: expected CASE=PATH")
        paths[case] = Path(path)
    return paths


def _branch_settings(args) -> dict:
    from harnesspipe.stages.branch import with_fitted_properties
    return with_fitted_properties(args.settings, _case_paths(args.properties_from, "--properties-from"))


def _branch_fit(args) -> int:
    from harnesspipe.stages.branch import calibrate
    settings = _branch_settings(args)
    print(json.dumps(calibrate(args.reference, settings, args.outdir, args.damping), indent=2))
    return 0


def _branch_predict(args) -> int:
    from harnesspipe.stages.branch import predict, read_alpha
    alpha = args.alpha if args.alpha is not None else read_alpha(args.damping)
    fit = predict(args.reference, _branch_settings(args), args.outdir, args.load_case, alpha, args.item,
                  args.role)
    print(json.dumps(fit, indent=2))
    return 0


def _tensile_fit(args) -> int:
    from harnesspipe.stages.tensile import fit_component
    print(json.dumps(fit_component(args.component, args.reference, args.settings, args.outdir), indent=2))
    return 0


def _table2(args) -> int:
    from harnesspipe.stages.tensile import table2
    print(table2(args.fits, args.out).to_string(index=False))
    return 0


def _table3(args) -> int:
    from harnesspipe.stages.rom import table3
    print(table3(args.fits, args.out).to_string(index=False))
    return 0


def _hifi_run(args) -> int:
    from harnesspipe.stages.hifi_chain import run_case
    summary = run_case(args.case, args.settings, args.outdir, table2=args.coverings,
                       interface_fit=args.interface, reference=args.reference, role=args.role,
                       reuse=args.reuse)
    print(json.dumps({k: summary.get(k) for k in ("case", "role", "wall_s", "steps", "dt", "ke_ie_max",
                                                   "energy_error", "measured", "reused_from")}, indent=2))
    return 0


def _branch_hifi(args) -> int:
    from harnesspipe.stages.branch_hifi import run
    summary = run(args.settings, args.outdir, table2=args.coverings)
    print(json.dumps({k: summary.get(k) for k in ("load_case", "wall_s", "steps", "dt", "ke_ie_max",
                                                   "energy_error")}, indent=2))
    return 0


def _hifi_fit(args) -> int:
    from harnesspipe.cli import InputError
    from harnesspipe.stages.hifi_chain import fit_step
    refs = _case_paths(args.reference, "--reference")
    missing = [c for c in args.settings.get("cases", []) if c not in refs]
    if missing:
        raise InputError(f"--reference: no prepared test for {missing}")
    if args.cores < 1:
        raise InputError(f"--cores {args.cores}: expected a positive number of cores")
    workers = min(args.cores, max(len(args.settings.get("cases", [])), 1))
    fit = fit_step(args.step, args.settings, refs, args.outdir, table2=args.coverings, priors=args.prior,
                   workers=workers)
    print(json.dumps(fit, indent=2))
    return 0


def _hifi_interface(args) -> int:
    from harnesspipe.stages.hifi_chain import interface_table
    print(interface_table(args.fits, args.out).to_string(index=False))
    return 0


def _hifi_rom(args) -> int:
    from harnesspipe.stages.hifi_chain import rom_crosscheck
    print(json.dumps(rom_crosscheck(args.case, args.curve, args.settings, args.outdir, label=args.label),
                     indent=2))
    return 0
