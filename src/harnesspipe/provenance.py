"""Hashes of package sources, so Snakemake reruns a rule when the code it uses changes.

Snakemake notices changed inputs, params and rule code, but not changed package
code (DESIGN sec. 7).  Each rule passes :func:`code_hash` of the stage module it runs
as a param: the hash covers that module's import closure inside the package (every
``harnesspipe`` module it imports, directly or through others, at module level or
inside functions), so editing any file the rule's code can reach changes the param
and reruns the rule and its dependants, while untouched code reruns nothing.
:func:`source_hash` hashes named files and folders (the Numba warm-up markers).
"""
from __future__ import annotations

import ast
import hashlib
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parent
PACKAGE = PACKAGE_DIR.name


def _digest(files, root: Path) -> str:
    h = hashlib.sha256()
    for path in files:
        h.update(path.relative_to(root).as_posix().encode() + b"\0")
        h.update(path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def source_hash(*parts: str) -> str:
    """SHA-256 (16 hex digits) of the given package files/folders (relative to the package)."""
    files = []
    for part in sorted(parts):
        root = PACKAGE_DIR / part
        if not root.exists():
            raise FileNotFoundError(f"source_hash: {root} does not exist")
        files += [root] if root.is_file() else sorted(root.rglob("*.py"))
    return _digest(files, PACKAGE_DIR)


def _module_file(name: str, root: Path) -> Path | None:
    """The source file of the package module ``name`` (dotted, from the package), if any."""
    base = root.joinpath(*name.split(".")[1:])
    if base.with_suffix(".py").is_file():
        return base.with_suffix(".py")
    if (base / "__init__.py").is_file():
        return base / "__init__.py"
    return None


def _imported_names(path: Path) -> set[str]:
    """Dotted names of the package that ``path`` imports anywhere (``from a.b import c``
    gives ``a.b`` and ``a.b.c``: c may be a module)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return {n for n in names if n == PACKAGE or n.startswith(PACKAGE + ".")}


def import_closure(module: str, root: Path = PACKAGE_DIR) -> list[Path]:
    """Source files of the package module ``module`` and of every package module it
    imports, transitively (with the ``__init__`` of each package on the way)."""
    seen: set[Path] = set()
    todo = [module]
    while todo:
        parts = todo.pop().split(".")
        for k in range(1, len(parts) + 1):       # importing a.b.c runs a and a.b too
            path = _module_file(".".join(parts[:k]), root)
            if path is not None and path not in seen:
                seen.add(path)
                todo.extend(_imported_names(path))
    if _module_file(module, root) is None:
        raise ModuleNotFoundError(f"code_hash: no module {module} under {root}")
    return sorted(seen)


def code_hash(module: str, *entry_files: str, root: Path = PACKAGE_DIR) -> str:
    """SHA-256 (16 hex digits) of the import closure of ``module`` and of the files
    ``entry_files`` (relative to the package, taken as they are: the command-line layer
    that calls the module, whose other commands' imports must not count)."""
    files = set(import_closure(module, root))
    for name in entry_files:
        path = root / name
        if not path.is_file():
            raise FileNotFoundError(f"code_hash: {path} does not exist")
        files.add(path)
    return _digest(sorted(files), root)
