"""Hashes of package sources, so Snakemake reruns a rule when the code it uses changes.

Snakemake notices changed inputs, params and rule code, but not changed package
code (DESIGN sec. 7).  Each rule passes ``source_hash(...)`` of the package parts
it runs as a param; editing those files changes the param and reruns the rule and
its dependants, while untouched code reruns nothing.
"""
from __future__ import annotations

import hashlib
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent


def source_hash(*parts: str) -> str:
    """SHA-256 (16 hex digits) of the given package files/folders (relative to the package)."""
    h = hashlib.sha256()
    for part in sorted(parts):
        root = PACKAGE_DIR / part
        if not root.exists():
            raise FileNotFoundError(f"source_hash: {root} does not exist")
        files = [root] if root.is_file() else sorted(root.rglob("*.py"))
        for path in files:
            h.update(path.relative_to(PACKAGE_DIR).as_posix().encode() + b"\0")
            h.update(path.read_bytes() + b"\0")
    return h.hexdigest()[:16]
