"""The Numba cache is keyed to the whole FE core (DESIGN sec. 7).

Numba's own ``cache=True`` checks only the kernel's file: a caller in one file
keeps the old result after its callee in another file changes.  Keying the cache
folder to a hash of every fe/ source makes the caller recompile.
"""
import re
import shutil
import subprocess
import sys
import textwrap

from conftest import REPO

CALLER = textwrap.dedent("""
    from numba import njit
    from harnesspipe.fe._probe_callee import callee

    @njit(cache=True)
    def caller(x):
        return 2.0 * callee(x)
""")
CALLEE = "from numba import njit\n\n@njit(cache=True)\ndef callee(x):\n    return x + {}\n"
RUN = ("import harnesspipe, sys; from harnesspipe.fe._probe_caller import caller; "
       "print(caller(1.0), harnesspipe.NUMBA_CACHE_DIR)")


def run_probe(src, cache):
    out = subprocess.run([sys.executable, "-c", RUN], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(src), "HARNESSPIPE_NUMBA_CACHE": str(cache),
                              "PATH": "/usr/bin:/bin"})
    value, folder = out.stdout.split()
    return float(value), folder


def test_changed_callee_recompiles_caller(tmp_path):
    src = tmp_path / "src"
    shutil.copytree(REPO / "src" / "harnesspipe", src / "harnesspipe",
                    ignore=shutil.ignore_patterns("__pycache__"))
    fe = src / "harnesspipe" / "fe"
    (fe / "_probe_caller.py").write_text(CALLER)
    (fe / "_probe_callee.py").write_text(CALLEE.format("1.0"))
    cache = tmp_path / "cache"
    v1, dir1 = run_probe(src, cache)
    v1_again, dir1_again = run_probe(src, cache)        # unchanged core: same cache, same value
    (fe / "_probe_callee.py").write_text(CALLEE.format("5.0"))
    v2, dir2 = run_probe(src, cache)
    assert (v1, v1_again, v2) == (4.0, 4.0, 12.0)
    assert dir1 == dir1_again != dir2
    assert any((cache / dir1.rsplit("/", 1)[-1]).rglob("*.nbi"))  # the first run did cache


def test_all_kernels_live_in_fe():
    """The cache key covers fe/ only, so no other module may define a kernel."""
    pkg = REPO / "src" / "harnesspipe"
    offenders = [p.relative_to(pkg).as_posix() for p in pkg.rglob("*.py")
                 if "fe" not in p.relative_to(pkg).parts[:1]
                 and re.search(r"^\s*@(numba\.)?(njit|jit|vectorize|guvectorize)", p.read_text(), re.M)]
    assert offenders == []


def test_openmp_threads_sleep_when_idle_unless_the_user_says_otherwise():
    """Importing harnesspipe makes OpenMP's waiting threads sleep (OMP_WAIT_POLICY=passive:
    spinning threads stalled a two-thread hi-fi run 3.4x beside another busy process,
    bench/RESULTS.md) when the user has set neither OMP_WAIT_POLICY nor GOMP_SPINCOUNT;
    a user's own setting is kept."""
    import os
    probe = "import os, harnesspipe; print(os.environ.get('OMP_WAIT_POLICY'))"
    base = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    cases = [({}, "passive"), ({"OMP_WAIT_POLICY": "active"}, "active"),
             ({"GOMP_SPINCOUNT": "300000"}, "None")]
    for extra, expected in cases:
        out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                             check=True, env={**base, **extra})
        assert out.stdout.strip() == expected, extra
