"""``harnesspipe campaign ...``: check a construction catalogue, and the campaign's steps
(called by workflow/rules/campaign.smk; each takes its settings as one JSON object)."""
from __future__ import annotations

import json
from pathlib import Path

from harnesspipe import config as cfgmod
from harnesspipe.commands.paths import input_file, output_dir, output_file


def register(sub) -> None:
    camp = sub.add_parser("campaign", help="virtual test campaigns over a construction catalogue")
    csub = camp.add_subparsers(dest="campaign_command", required=True, metavar="STEP")

    p = csub.add_parser("check", help="validate a catalogue (exit 2 naming the construction and key)")
    p.add_argument("catalogue", type=input_file)
    p.add_argument("--config", type=input_file, default=cfgmod.DEFAULT_CONFIG)
    p.set_defaults(func=_check)

    p = csub.add_parser("hifi", help="the hi-fi virtual test of one construction")
    p.add_argument("--construction", required=True)
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=output_dir, required=True)
    p.set_defaults(func=_hifi)

    p = csub.add_parser("rom", help="eq. 13 + simplex on a construction's virtual test: its library row")
    p.add_argument("--construction", required=True)
    p.add_argument("--hifi", type=Path, required=True, help="folder of the virtual test (result.json)")
    p.add_argument("--settings", type=_settings, required=True)
    p.add_argument("--outdir", type=output_dir, required=True)
    p.set_defaults(func=_rom)

    p = csub.add_parser("library", help="collect property.json files into properties.csv")
    p.add_argument("--rows", type=input_file, nargs="+", required=True)
    p.add_argument("--out", type=output_file, required=True)
    p.set_defaults(func=_library)

    p = csub.add_parser("page", help="the campaign's HTML page (offline, images embedded)")
    p.add_argument("--library", type=input_file, required=True, help="properties.csv")
    p.add_argument("--title", default="")
    p.add_argument("--out", type=output_file, required=True)
    p.set_defaults(func=_page)


def _settings(text: str) -> dict:
    from harnesspipe.commands.stage import _settings as parse
    return parse(text)


def _check(args) -> int:
    from harnesspipe.campaign.catalogue import load
    cat = load(args.catalogue, cfgmod.load(args.config))
    print(f"{args.catalogue}: OK: {len(cat.constructions)} constructions "
          f"({', '.join(cat.constructions)}); results/campaign/{cat.name}/")
    return 0


def _hifi(args) -> int:
    from harnesspipe.campaign.virtual import virtual_test
    result = virtual_test(args.construction, args.settings, args.outdir)
    print(json.dumps(result, indent=2, default=str))
    return 0


def _rom(args) -> int:
    from harnesspipe.campaign.library import properties
    print(json.dumps(properties(args.construction, args.hifi, args.settings, args.outdir), indent=2))
    return 0


def _library(args) -> int:
    from harnesspipe.campaign.library import library
    print(library(args.rows, args.out).to_string(index=False))
    return 0


def _page(args) -> int:
    from harnesspipe.campaign.page import build
    print(build(args.library, args.out, title=args.title))
    return 0
