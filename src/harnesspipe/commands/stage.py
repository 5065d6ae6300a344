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


def register(sub) -> None:
    stage = sub.add_parser("stage", help="pipeline stage steps (called by the Snakemake rules)")
    ssub = stage.add_subparsers(dest="stage_command", required=True, metavar="STEP")

    p = ssub.add_parser("warmup", help="compile or load every Numba kernel once")
    p.set_defaults(func=_warmup)

    p = ssub.add_parser("rom-fit", help="eq. 13 + simplex for one CWB case (Sec. 4.3)")
    p.add_argument("--case", required=True)
    p.add_argument("--reference", type=Path, required=True, help="prepared test (HDF5)")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.set_defaults(func=_rom_fit)

    p = ssub.add_parser("branch-fit", help="calibrate the joint damping alpha (Sec. 5, eq. 15)")
    p.add_argument("--reference", type=Path, required=True, help="prepared in-plane test (HDF5)")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.add_argument("--damping", type=Path, required=True, help="damping.csv to write")
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
    p.set_defaults(func=_branch_predict)

    p = ssub.add_parser("tensile-fit", help="calibrate one covering on its tensile test (Sec. 3.2)")
    p.add_argument("--component", required=True, choices=("closed_tube", "open_tube", "fabric_tube"))
    p.add_argument("--reference", type=Path, required=True, help="prepared test (HDF5)")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.set_defaults(func=_tensile_fit)

    p = ssub.add_parser("table2", help="collect tensile fits into table2.csv")
    p.add_argument("--fits", type=Path, nargs="+", required=True)
    p.add_argument("--out", type=Path, required=True)
    p.set_defaults(func=_table2)

    p = ssub.add_parser("table3", help="collect ROM fits into table3.csv")
    p.add_argument("--fits", type=Path, nargs="+", required=True)
    p.add_argument("--out", type=Path, required=True)
    p.set_defaults(func=_table3)


def _warmup(args) -> int:
    from harnesspipe.stages.warmup import warm_up
    for name, seconds in warm_up().items():
        print(f"{name}: {seconds:.2f} s")
    return 0


def _rom_fit(args) -> int:
    from harnesspipe.stages.rom import fit_case
    fit = fit_case(args.case, args.reference, args.settings, args.outdir)
    print(json.dumps(fit, indent=2))
    return 0


def _branch_fit(args) -> int:
    from harnesspipe.stages.branch import calibrate
    print(json.dumps(calibrate(args.reference, args.settings, args.outdir, args.damping), indent=2))
    return 0


def _branch_predict(args) -> int:
    from harnesspipe.stages.branch import predict, read_alpha
    alpha = args.alpha if args.alpha is not None else read_alpha(args.damping)
    fit = predict(args.reference, args.settings, args.outdir, args.load_case, alpha, args.item, args.role)
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
