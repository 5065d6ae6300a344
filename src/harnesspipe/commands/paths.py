"""Argparse types of the file and folder options: a path is checked when the command line is
read, before anything runs, so that a long simulation never ends on an output it cannot
write.  A bad path exits with code 2 and argparse's one line naming the option
(``argument --out: afile/o.csv: afile is a file, not a folder``)."""
from __future__ import annotations

import argparse
import os
from pathlib import Path


def input_file(text: str) -> Path:
    """An existing, readable file."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: is a folder, expected a file")
    if not path.is_file():
        raise argparse.ArgumentTypeError(f"{text}: no such file")
    if not os.access(path, os.R_OK):
        raise argparse.ArgumentTypeError(f"{text}: not readable")
    return path


def output_file(text: str) -> Path:
    """A file the command may write: not a folder, under a folder that exists or can be made."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: is a folder, expected a file name")
    _check_parents(text, path.parent)
    return path


def output_dir(text: str) -> Path:
    """A folder the command may write into: not a file, under a folder that exists or can be
    made."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: is a file, expected a folder")
    _check_parents(text, path if path.is_dir() else path.parent)
    return path


def _check_parents(text: str, folder: Path) -> None:
    """The nearest existing folder above (or at) ``folder`` is a writable folder."""
    for above in (folder, *folder.parents):
        if above.exists():
            if not above.is_dir():
                raise argparse.ArgumentTypeError(f"{text}: {above} is a file, not a folder")
            if not os.access(above, os.W_OK | os.X_OK):
                raise argparse.ArgumentTypeError(f"{text}: cannot write in {above}")
            return
