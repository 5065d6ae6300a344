"""``harnesspipe report``: the offline HTML report."""
from __future__ import annotations

from pathlib import Path

from harnesspipe import config as cfgmod
from harnesspipe.commands.paths import input_file, output_file


def register(sub) -> None:
    p = sub.add_parser("report", help="write the self-contained HTML report")
    p.add_argument("--config", type=input_file, default=cfgmod.DEFAULT_CONFIG,
                   help="the effective config of the run (Snakemake writes results/config.yaml)")
    p.add_argument("--results", type=Path, default=Path("results"))
    p.add_argument("--check", type=input_file, required=True, help="output of check-data")
    p.add_argument("--prepared", type=input_file, nargs="*", default=[])
    p.add_argument("--fits", nargs="*", default=[], metavar="STAGE=FIT_JSON",
                   help="fit.json files, each prefixed by its stage, e.g. rom=results/rom/x/fit.json")
    p.add_argument("--out", type=output_file, required=True)
    p.add_argument("--screen", type=input_file, default=None,
                   help="the hi-fi sensitivity screen's record (bench/sensitivity.json), shown if given")
    p.add_argument("--band", type=input_file, default=None,
                   help="the record of Table 3's E_eff band over the build state "
                        "(bench/build_band.json), shown if given")
    p.set_defaults(func=_report)


def _report(args) -> int:
    from harnesspipe.cli import InputError
    from harnesspipe.report import band, screen
    from harnesspipe.report.html import STAGES, build
    cfg = cfgmod.load(args.config)
    fits: dict[str, list[Path]] = {}
    for item in args.fits:
        stage, sep, path = item.partition("=")
        if not sep or stage not in STAGES:
            raise InputError(f"report --fits {item!r}: expected STAGE=PATH with STAGE in {sorted(STAGES)}")
        if not Path(path).is_file():
            raise InputError(f"report --fits {item}: {path}: no such file")
        fits.setdefault(stage, []).append(Path(path))
    records = {option: _record(args, option, read) for option, read in
               (("screen", screen.read_record), ("band", band.read_record))}
    print(build(args.out, cfg=cfg, results=args.results, check_summary=args.check,
                prepared=args.prepared, fits=fits, screen_record=records["screen"],
                band_record=records["band"]))
    return 0


def _record(args, option: str, read):
    """The bench record given as ``--<option>``, read by ``read``; None when not given."""
    from harnesspipe.cli import InputError
    path = getattr(args, option)              # an existing file or None (argparse checked)
    try:
        return read(path)
    except ValueError as exc:
        raise InputError(f"report --{option}: {exc}") from None
