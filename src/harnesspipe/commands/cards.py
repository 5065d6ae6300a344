"""``harnesspipe cards``: solver cards of a property table (issue 28, harnesspipe.cards)."""
from __future__ import annotations

from harnesspipe.commands.paths import input_file, output_dir

FORMAT_CHOICES = "calculix|abaqus|lsdyna"   # harnesspipe.cards.FORMATS, named here so that
                                             # building the parser imports no model code


def register(sub) -> None:
    p = sub.add_parser("cards", help="CalculiX/Abaqus/LS-DYNA cards of effective beams",
                       description="Write, per case of a property table (results/rom/table3.csv "
                                   "or a campaign's properties.csv), the solver cards of its "
                                   "effective beam and a README giving every number's source.")
    p.add_argument("--table", type=input_file, required=True,
                   help="CSV with columns case,E,sigma_y,K,n (optional r_o, nu, rho, span, "
                        "deflection, status)")
    p.add_argument("--format", dest="fmt", required=True, metavar=FORMAT_CHOICES,
                   help="solver: calculix and abaqus write material.inp and three_point.inp, "
                        "lsdyna material.k")
    p.add_argument("--out", type=output_dir, required=True, help="folder; one sub-folder per case")
    p.add_argument("--config", type=input_file, default=None,
                   help="config file for r_o, rho and the test geometry where the table has "
                        "none (default: the repository's config/config.yaml)")
    p.set_defaults(func=_cards)


def _cards(args) -> int:
    from harnesspipe.cards import FORMATS, write_cards
    from harnesspipe.cli import InputError
    if args.fmt not in FORMATS:
        raise InputError(f"cards: --format {args.fmt!r}: expected one of {', '.join(FORMATS)}")
    folders = write_cards(args.table, args.fmt, args.out, config=args.config)
    print(f"wrote {args.fmt} cards of {len(folders)} case(s) to {args.out}")
    return 0
