"""``harnesspipe hifi three-point`` and ``hifi branch``: the high-fidelity virtual bending test
(Sec. 4.1) and the pull test of the Y-shaped branching harness (Sec. 5, Fig. 18a)."""
from __future__ import annotations

from pathlib import Path


def _assignment(text: str) -> tuple[str, str]:
    import argparse
    key, sep, value = text.partition("=")
    if not sep or not key.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"--set {text!r}: expected key=value, e.g. mu_rtb=0.25")
    return key.strip(), value.strip()


def register(sub) -> None:
    hifi = sub.add_parser("hifi", help="high-fidelity (mesoscale) bundle models")
    hsub = hifi.add_subparsers(dest="hifi_command", required=True, metavar="MODEL")
    p = hsub.add_parser("three-point", help="explicit three-point bending of a wire bundle")
    p.add_argument("--case", required=True, help="case name (config `cases` / `hifi.extra_cases`)")
    p.add_argument("--profile", default=None, help="resolution profile (config `profiles`)")
    p.add_argument("--config", type=Path, default=None, help="config file (default: the package's)")
    p.add_argument("--coverings", type=Path, default=None,
                   help="table2.csv of the tensile stage (default: config hifi.coverings)")
    p.add_argument("--set", dest="overrides", type=_assignment, action="append", default=[],
                   metavar="KEY=VALUE", help="override a parameter, e.g. mu_rtb=0.25 (repeatable)")
    p.add_argument("--out", type=Path, required=True, help="CSV: deflection_mm,force_N")
    p.add_argument("--summary", type=Path, required=True, help="summary JSON")
    p.add_argument("--threads", type=int, default=None,
                   help="Numba threads (default: all cores; Snakemake passes its `threads`)")
    p.add_argument("--outdir", type=Path, default=None,
                   help="folder for energies, slip-out, shapes (default: beside --out)")
    p.set_defaults(func=_three_point)

    p = hsub.add_parser("branch", help="explicit pull test of the Y-shaped branching harness (Fig. 18a)")
    p.add_argument("--load-case", choices=("inplane", "outofplane"), default=None,
                   help="default: config branch.hifi.load_case")
    p.add_argument("--t-total", type=float, default=None,
                   help="simulated seconds of the 50 mm pull (default: config branch.hifi.t_total)")
    p.add_argument("--profile", default=None, help="resolution profile (config `profiles`)")
    p.add_argument("--config", type=Path, default=None, help="config file (default: the package's)")
    p.add_argument("--coverings", type=Path, default=None,
                   help="table2.csv of the tensile stage (default: config hifi.coverings)")
    p.add_argument("--threads", type=int, default=None, help="Numba threads (default: all cores)")
    p.add_argument("--out", type=Path, required=True, help="CSV: displacement_mm,force_N")
    p.add_argument("--summary", type=Path, required=True, help="summary JSON")
    p.add_argument("--outdir", type=Path, default=None,
                   help="folder for energies and S2's bent shapes (default: beside --out)")
    p.set_defaults(func=_branch)


def _config(args) -> dict:
    """The config of a run with --threads and --profile applied (bad values: InputError)."""
    from harnesspipe.cli import InputError
    from harnesspipe.config import load
    if args.threads is not None:
        import numba
        if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
            raise InputError(f"--threads {args.threads}: expected 1..{numba.config.NUMBA_NUM_THREADS}")
        numba.set_num_threads(args.threads)
    cfg = load(args.config) if args.config else load()
    if args.profile is not None:
        if args.profile not in cfg["profiles"]:
            raise InputError(f"--profile {args.profile!r}: not one of {sorted(cfg['profiles'])}")
        cfg["profile"] = args.profile
    return cfg


def _three_point(args) -> int:
    from harnesspipe.stages.hifi import run_case

    cfg = _config(args)
    outdir = args.outdir or args.out.parent / f"{args.out.stem}_files"
    summary = run_case(cfg, args.case, dict(args.overrides), coverings=args.coverings,
                       out_csv=args.out, summary_json=args.summary, outdir=outdir)
    print(f"{args.case}: {summary['steps']} steps, dt {summary['dt']:.3g} s, "
          f"wall {summary['wall_s']:.1f} s, KE/IE max {summary['ke_ie_max']:.3g}, "
          f"energy error {summary['energy_error']:.3g}")
    return 0


def _branch(args) -> int:
    from harnesspipe.stages.branch_hifi import run, settings_from_config

    cfg = _config(args)
    if args.t_total is not None and not args.t_total > 0:
        from harnesspipe.cli import InputError
        raise InputError(f"--t-total {args.t_total}: expected a positive time")
    outdir = args.outdir or args.out.parent / f"{args.out.stem}_files"
    summary = run(settings_from_config(cfg, args.load_case, args.t_total), outdir,
                  table2=args.coverings, curve_csv=args.out, summary_json=args.summary)
    print(f"branch {summary['load_case']}: {summary['steps']} steps, dt {summary['dt']:.3g} s, "
          f"wall {summary['wall_s']:.1f} s, KE/IE max {summary['ke_ie_max']:.3g}, "
          f"energy error {summary['energy_error']:.3g}")
    return 0
