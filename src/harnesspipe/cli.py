"""Calibrate and run FE models of automotive wire harnesses: test data, reduced-order and
high-fidelity bending models, the pipeline's stages.

The console command ``harnesspipe`` (DESIGN sec. 5).  Exit codes: 0 success, 2 bad input
(config, data, option), 3 a simulation or calibration that failed (convergence,
instability), 130 interrupted (Ctrl-C).  Errors are one line on stderr naming what and
where.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from harnesspipe import __version__

# Sub-command modules: each defines ``register(subparsers)``; the handler set
# with ``set_defaults(func=...)`` receives the parsed namespace.
COMMAND_MODULES = (
    "harnesspipe.commands.data",
    "harnesspipe.commands.rom",
    "harnesspipe.commands.hifi",
    "harnesspipe.commands.report",
    "harnesspipe.commands.stage",
    "harnesspipe.commands.campaign",
    "harnesspipe.commands.cards",
)


class InputError(ValueError):
    """Bad command-line input."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="harnesspipe", description=__doc__.split("\n\n")[0].replace("\n", " "),
        epilog="Exit codes: 0 success, 2 bad input (naming the file, key or option), 3 a failed "
               "simulation or calibration, 130 interrupted.  Help of a command: harnesspipe "
               "COMMAND --help.")
    parser.add_argument("--version", action="version", version=f"harnesspipe {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def _input_errors() -> tuple[type[BaseException], ...]:
    from harnesspipe.cards.properties import TableError
    from harnesspipe.config import ConfigError
    from harnesspipe.data.experimental import DataError
    from harnesspipe.input_files import InputFileError
    return (ConfigError, DataError, InputError, InputFileError, TableError, FileNotFoundError)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except _input_errors() as exc:
        for line in str(exc).splitlines() or [type(exc).__name__]:
            print(f"harnesspipe: error: {line}", file=sys.stderr)
        return 2
    except (RuntimeError, FloatingPointError) as exc:
        print(f"harnesspipe: failed: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:       # every result file is written atomically: none half-written
        print("\nharnesspipe: interrupted", file=sys.stderr)
        return 130
