"""``harnesspipe rom three-point`` and ``harnesspipe rom cantilever`` (DESIGN sec. 5)."""
from __future__ import annotations

from pathlib import Path

from harnesspipe.commands.branch import add_branch_parser
from harnesspipe.commands.paths import output_file


def _number(text: str, *, strict: bool) -> float:
    import argparse
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (v > 0.0 if strict else v >= 0.0):
        raise argparse.ArgumentTypeError(f"{text!r} must be {'>' if strict else '>='} 0")
    return v


def _positive(text: str) -> float:
    return _number(text, strict=True)


def _nonneg(text: str) -> float:
    return _number(text, strict=False)


def _physical(key: str):
    """An argparse type: a number the physical-input validator accepts for ``key``."""
    def parse(text: str) -> float:
        import argparse

        from harnesspipe.validate import problem
        bad = problem(key, text)
        if bad:
            raise argparse.ArgumentTypeError(f"{text!r}: {bad}")
        return float(text)
    parse.__name__ = key          # argparse names the type in its messages
    return parse


def _material(p, *, what: str) -> None:
    """--E, --sigma-y, --K, --n: the effective beam's eq. 2 law."""
    p.add_argument("--E", type=_physical("E"), required=True, help=f"{what} [MPa]")
    p.add_argument("--sigma-y", type=_physical("sigma_y"),
                   help="yield stress [MPa] (required unless --elastic)")
    p.add_argument("--K", type=_physical("K"),
                   help="hardening coefficient of eq. 2, >= 0 [MPa] (required unless --elastic)")
    p.add_argument("--n", type=_physical("n"),
                   help="hardening exponent of eq. 2, in (0, 1] (required unless --elastic)")


def register(sub) -> None:
    rom = sub.add_parser("rom", help="reduced-order beam models")
    rsub = rom.add_subparsers(dest="rom_command", required=True, metavar="MODEL")

    p = rsub.add_parser("three-point", help="three-point bending of an effective beam")
    _material(p, what="effective modulus E_eff")
    p.add_argument("--radius", type=_positive, required=True, help="outer radius r_o [mm]")
    p.add_argument("--span", type=_positive, default=127.0,
                   help="distance between the supports [mm] (default: %(default)g)")
    p.add_argument("--overhang", type=_nonneg, default=36.5,
                   help="sample length beyond each support, rollers only [mm] (default: %(default)g)")
    p.add_argument("--deflection", type=_positive, default=30.0,
                   help="stroke of the loading pin, below span / 2 [mm] (default: %(default)g)")
    p.add_argument("--supports", choices=("rollers", "pinned"), default="rollers",
                   help="rollers: 5 mm cylinders in contact; pinned: ideal supports at the span "
                        "ends, no overhang (default: %(default)s)")
    p.add_argument("--elements", type=int, default=None,
                   help="beam elements, even (default: the model's, 40)")
    p.add_argument("--elastic", action="store_true", help="ignore plasticity")
    p.add_argument("--out", type=output_file, required=True, help="CSV: deflection_mm,force_N")
    p.set_defaults(func=_three_point)

    p = rsub.add_parser("cantilever", help="cantilever under a tip dead load")
    _material(p, what="modulus E")
    p.add_argument("--radius", type=_positive, required=True, help="radius of the section [mm]")
    p.add_argument("--length", type=_positive, required=True, help="free length [mm]")
    p.add_argument("--tip-load", type=_positive, required=True,
                   help="final tip dead load P, across the undeformed axis [N]")
    p.add_argument("--elements", type=int, default=None,
                   help="beam elements (default: the model's, 20)")
    p.add_argument("--elastic", action="store_true", help="ignore plasticity")
    p.add_argument("--out", type=output_file, required=True,
                   help="CSV: load_N,tip_ux_mm,tip_uy_mm,tip_rotation_rad")
    p.set_defaults(func=_cantilever)

    add_branch_parser(rsub)


def _plastic_args(args) -> dict:
    from harnesspipe.cli import InputError
    if args.elastic:
        return {}
    missing = [f"--{n.replace('_', '-')}" for n in ("sigma_y", "K", "n") if getattr(args, n) is None]
    if missing:
        raise InputError(f"rom {args.rom_command}: {', '.join(missing)} required unless --elastic")
    return {"sigma_y": args.sigma_y, "K": args.K, "n": args.n}


def _mesh(args) -> dict:
    from harnesspipe.cli import InputError
    if args.elements is None:
        return {}
    if args.elements < 2:
        raise InputError(f"rom {args.rom_command}: --elements {args.elements}: need at least 2")
    if args.rom_command == "three-point" and args.elements % 2:
        raise InputError(f"rom three-point: --elements {args.elements}: must be even "
                         "(a node at mid-span under the loading pin)")
    return {"n_elements": args.elements}


def _write(frame, out: Path) -> int:
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    frame.to_csv(tmp, index=False, float_format="%.8g")
    tmp.replace(out)
    print(f"wrote {out} ({len(frame)} rows)")
    return 0


def _three_point(args) -> int:
    from harnesspipe import rom
    from harnesspipe.cli import InputError
    from harnesspipe.validate import deflection_problem
    plastic, mesh = _plastic_args(args), _mesh(args)
    bad = deflection_problem(args.deflection, args.span)
    if bad:
        raise InputError(f"rom three-point: --deflection {args.deflection:g}: {bad}")
    try:
        frame = rom.three_point(E=args.E, radius=args.radius, supports=args.supports, span=args.span,
                                overhang=args.overhang, deflection=args.deflection,
                                elastic=args.elastic, **plastic, **mesh)
    except ValueError as exc:  # the model's own input checks
        raise InputError(f"rom three-point: {exc}") from None
    return _write(frame, args.out)


def _cantilever(args) -> int:
    from harnesspipe import rom
    from harnesspipe.cli import InputError
    plastic, mesh = _plastic_args(args), _mesh(args)
    try:
        frame = rom.cantilever(E=args.E, radius=args.radius, length=args.length,
                               tip_load=args.tip_load, elastic=args.elastic, **plastic, **mesh)
    except ValueError as exc:
        raise InputError(f"rom cantilever: {exc}") from None
    return _write(frame, args.out)
