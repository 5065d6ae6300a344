"""``harnesspipe rom branch``: the Y-harness pull test (Sec. 5); the lead's ``rom`` group adds it."""
from __future__ import annotations

from harnesspipe.commands.paths import output_file


def add_branch_parser(rom_subparsers) -> None:
    """Add ``branch`` to the sub-parsers of ``harnesspipe rom``."""
    p = rom_subparsers.add_parser("branch", help="Y-shaped branching harness pull test (Fig. 16/20)")
    p.add_argument("--load-case", required=True, help="inplane (Fig. 16) or outofplane (Fig. 20)")
    p.add_argument("--alpha", default="0.2", help="eq. 15 damping coefficient of the joint [s]")
    p.add_argument("--out", type=output_file, required=True, help="CSV: displacement_mm,force_N")
    p.set_defaults(func=_branch)


def _alpha(text: str) -> float:
    from harnesspipe.cli import InputError
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"rom branch: --alpha {text!r} is not a number") from None
    if not value >= 0.0:
        raise InputError(f"rom branch: --alpha {text!r} must be >= 0")
    return value


def _branch(args) -> int:
    from harnesspipe.cli import InputError
    from harnesspipe.models import branch
    if args.load_case not in branch.LOAD_CASES:
        raise InputError(f"rom branch: --load-case {args.load_case!r}: choose one of "
                         f"{', '.join(sorted(branch.LOAD_CASES))}")
    curve = branch.simulate(args.load_case, _alpha(args.alpha))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".tmp")
    curve.to_csv(tmp, index=False, float_format="%.8g")
    tmp.replace(args.out)
    print(f"wrote {args.out} ({len(curve)} rows)")
    return 0
