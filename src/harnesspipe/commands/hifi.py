"""``harnesspipe hifi three-point``: the high-fidelity virtual bending test (Sec. 4.1)."""
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


def _three_point(args) -> int:
    from harnesspipe.config import load
    from harnesspipe.stages.hifi import run_case

    if args.threads is not None:
        import numba
        from harnesspipe.cli import InputError
        if not 1 <= args.threads <= numba.config.NUMBA_NUM_THREADS:
            raise InputError(f"--threads {args.threads}: expected 1..{numba.config.NUMBA_NUM_THREADS}")
        numba.set_num_threads(args.threads)
    cfg = load(args.config) if args.config else load()
    if args.profile is not None:
        if args.profile not in cfg["profiles"]:
            from harnesspipe.cli import InputError
            raise InputError(f"--profile {args.profile!r}: not one of {sorted(cfg['profiles'])}")
        cfg["profile"] = args.profile
    outdir = args.outdir or args.out.parent / f"{args.out.stem}_files"
    summary = run_case(cfg, args.case, dict(args.overrides), coverings=args.coverings,
                       out_csv=args.out, summary_json=args.summary, outdir=outdir)
    print(f"{args.case}: {summary['steps']} steps, dt {summary['dt']:.3g} s, "
          f"wall {summary['wall_s']:.1f} s, KE/IE max {summary['ke_ie_max']:.3g}, "
          f"energy error {summary['energy_error']:.3g}")
    return 0
