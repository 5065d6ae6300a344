"""``harnesspipe report``: the offline HTML report."""
from __future__ import annotations

from pathlib import Path

from harnesspipe import config as cfgmod


def register(sub) -> None:
    p = sub.add_parser("report", help="write the self-contained HTML report")
    p.add_argument("--config", type=Path, default=cfgmod.DEFAULT_CONFIG,
                   help="the effective config of the run (Snakemake writes results/config.yaml)")
    p.add_argument("--results", type=Path, default=Path("results"))
    p.add_argument("--check", type=Path, required=True, help="output of check-data")
    p.add_argument("--prepared", type=Path, nargs="*", default=[])
    p.add_argument("--fits", nargs="*", default=[], metavar="STAGE=FIT_JSON",
                   help="fit.json files, each prefixed by its stage, e.g. rom=results/rom/x/fit.json")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--screen", type=Path, default=None,
                   help="the hi-fi sensitivity screen's record (bench/sensitivity.json), shown if given")
    p.set_defaults(func=_report)


def _report(args) -> int:
    from harnesspipe.cli import InputError
    from harnesspipe.report.html import STAGES, build
    from harnesspipe.report.screen import read_record
    cfg = cfgmod.load(args.config)
    fits: dict[str, list[Path]] = {}
    for item in args.fits:
        stage, sep, path = item.partition("=")
        if not sep or stage not in STAGES:
            raise InputError(f"report --fits {item!r}: expected STAGE=PATH with STAGE in {sorted(STAGES)}")
        fits.setdefault(stage, []).append(Path(path))
    if args.screen is not None and not args.screen.exists():
        raise InputError(f"report --screen {args.screen}: no such file")
    try:
        record = read_record(args.screen)
    except ValueError as exc:
        raise InputError(f"report --screen: {exc}") from None
    print(build(args.out, cfg=cfg, results=args.results, check_summary=args.check,
                prepared=args.prepared, fits=fits, screen_record=record))
    return 0
