"""Readers of the files a user hands the commands (tables, JSON records, prepared tests): a
file that cannot be read is a one-line error naming it and what was expected (exit 2), not a
parser's traceback."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import pandas as pd


class InputFileError(ValueError):
    """A file given to a command cannot be read as what it should be."""


def read_csv(path, **kwargs) -> pd.DataFrame:
    """``pandas.read_csv`` of a table whose every line has the header's number of fields."""
    path = Path(path)
    try:
        frame = pd.read_csv(path, **kwargs)
    except pd.errors.EmptyDataError:
        raise InputFileError(f"{path}: empty, expected a CSV table with a header line") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise InputFileError(f"{path}: not a readable CSV table: {str(exc).splitlines()[0]}") from None
    _check_fields(path)
    return frame


def _check_fields(path: Path) -> None:
    """Every non-empty line has as many fields as the header (pandas would shift a line with
    one too many into an index, and fill one too short with NaN)."""
    with path.open(newline="") as f:
        rows = csv.reader(f)
        header = next(rows)
        for line, row in enumerate(rows, start=2):
            if row and len(row) != len(header):
                raise InputFileError(f"{path}: line {line}: {len(row)} fields, expected "
                                     f"{len(header)} ({','.join(header)})")


def read_json(path):
    """The JSON document in ``path``."""
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise InputFileError(f"{path}: not valid JSON: line {exc.lineno}, column {exc.colno}: "
                             f"{exc.msg}") from None
    except UnicodeDecodeError:
        raise InputFileError(f"{path}: not a JSON text file") from None


def open_hdf5(path, what: str = "an HDF5 file"):
    """``path`` opened read-only with h5py if it is a complete HDF5 file (h5py's signature
    and superblock checks); use it as a context manager."""
    import h5py
    path = Path(path)
    try:
        return h5py.File(path, "r")
    except OSError as exc:
        reason = "truncated" if "truncated" in str(exc) else "not HDF5"
        raise InputFileError(f"{path}: cannot be read as {what} ({reason})") from None
