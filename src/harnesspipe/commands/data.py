"""``harnesspipe check-data``, ``harnesspipe synthesize``, ``harnesspipe prepare``."""
from __future__ import annotations

from pathlib import Path

from harnesspipe import config as cfgmod
from harnesspipe.commands.paths import input_file, output_dir, output_file


def register(sub) -> None:
    p = sub.add_parser("check-data", help="validate a test-data folder (manifest + CSVs)")
    p.add_argument("data_dir", nargs="?", default="data/experimental", type=Path)
    p.add_argument("--config", type=input_file, default=None,
                   help="a config whose cases and coverings the tests' items should name: the "
                        "summary then lists the tests it has no use for")
    p.set_defaults(func=_check_data)

    p = sub.add_parser("synthesize", help="write the synthetic twin data set")
    p.add_argument("--config", type=input_file, default=cfgmod.DEFAULT_CONFIG)
    p.add_argument("--out", type=output_dir, default=Path("data/experimental"))
    p.add_argument("--only", nargs="+", metavar="GENERATOR",
                   help="generators to run (default: all registered)")
    p.set_defaults(func=_synthesize)

    p = sub.add_parser("prepare", help="resample one test's replicates (mean, band) to HDF5")
    p.add_argument("--data-dir", type=Path, default=Path("data/experimental"))
    p.add_argument("--test", required=True)
    p.add_argument("--out", type=output_file, required=True)
    p.set_defaults(func=_prepare)


def _check_data(args) -> int:
    from harnesspipe.stages.data import check_data
    print(check_data(args.data_dir, cfgmod.load(args.config) if args.config else None))
    return 0


def _synthesize(args) -> int:
    from harnesspipe.data import generators, generators_branch  # noqa: F401  (register generators)
    from harnesspipe.data.synthesize import synthesize
    cfg = cfgmod.load(args.config)
    out = synthesize(cfg, args.out, args.only)
    print(f"wrote synthetic data set to {out}")
    return 0


def _prepare(args) -> int:
    from harnesspipe.stages.data import prepare_test
    print(prepare_test(args.data_dir, args.test, args.out))
    return 0
