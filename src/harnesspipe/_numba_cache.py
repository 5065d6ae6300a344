"""Key Numba's on-disk cache to the whole FE core.

Numba's ``cache=True`` only checks the source file of the kernel being loaded: a
kernel in ``a.py`` that calls a kernel in ``b.py`` keeps its old machine code after
``b.py`` changes.  All kernels of harnesspipe live in :mod:`harnesspipe.fe`, so the
cache directory is named by a hash of every source file there.  Any change in the
core therefore starts from an empty cache, and an unchanged core reuses it.

This module must run before ``numba`` is first imported; ``harnesspipe/__init__``
imports it first.  A user-set ``NUMBA_CACHE_DIR`` is respected as the *parent*
folder, so the keying still applies.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

FE_DIR = Path(__file__).resolve().parent / "fe"


def core_hash(root: Path = FE_DIR) -> str:
    """SHA-256 (first 16 hex digits) of all ``*.py`` files under ``root``, by path and content."""
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(path.relative_to(root).as_posix().encode())
        h.update(b"\0")
        h.update(path.read_bytes())
        h.update(b"\0")
    return h.hexdigest()[:16]


def cache_parent() -> Path:
    """Folder holding the per-core-version caches."""
    base = os.environ.get("HARNESSPIPE_NUMBA_CACHE")
    if base:
        return Path(base)
    xdg = os.environ.get("XDG_CACHE_HOME", str(Path.home() / ".cache"))
    return Path(xdg) / "harnesspipe" / "numba"


def configure() -> Path:
    """Point ``NUMBA_CACHE_DIR`` at ``<parent>/<core hash>`` and return it."""
    target = cache_parent() / core_hash()
    target.mkdir(parents=True, exist_ok=True)
    os.environ["NUMBA_CACHE_DIR"] = str(target)
    return target
