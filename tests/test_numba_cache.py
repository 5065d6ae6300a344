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


SHELLS = textwrap.dedent("""
    import sys
    import numpy as np
    from harnesspipe.fe.elements import shell_bt as bt
    n = 16                                    # 256 shells: the parallel kernel (PARALLEL_MIN)
    xs = np.linspace(0.0, 10.0, n + 1)
    X = np.array([[x, y, 0.0] for y in xs for x in xs])
    conn = np.array([[j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1,
                      (j + 1) * (n + 1) + i] for j in range(n) for i in range(n)], dtype=np.int64)
    h = np.full(n * n, 0.2)
    mat = np.tile([2000.0, 0.3, 20.0, 100.0, 0.5, 0.0], (n * n, 1))
    state = bt.init_shell_state(X, conn, h)
    v = np.zeros((X.shape[0], 6))
    v[:, 0] = 0.01 * X[:, 0]                  # a uniform stretch rate along x
    f_el, f = np.zeros((n * n, 4, 6)), np.zeros((X.shape[0], 6))
    if sys.argv[1] == "hg":
        bt.shell_forces(X, v, conn, h, mat, state, 1e-3, f_el, f, 0.1)
    else:
        bt.shell_forces(X, v, conn, h, mat, state, 1e-3, f_el, f, sign=-1.0)
    print(repr(float(np.abs(f).sum())))
""")


def test_parallel_shell_kernel_survives_a_cache_built_in_steps(tmp_path):
    """One process caches the parallel shell kernel through one call signature, the next
    adds another, the third loads that one: a cached njit caller compiled against the
    parallel kernel loaded from the cache was cached broken and crashed the third process
    (Numba 0.68); shell_bt.shell_forces is therefore a Python function."""
    script = tmp_path / "shells.py"
    script.write_text(SHELLS)
    env = {"PYTHONPATH": str(REPO / "src"), "HARNESSPIPE_NUMBA_CACHE": str(tmp_path / "cache"),
           "PATH": "/usr/bin:/bin", "NUMBA_NUM_THREADS": "1"}
    runs = [subprocess.run([sys.executable, str(script), how], capture_output=True, text=True,
                           env=env) for how in ("hg", "sign", "sign")]
    assert [r.returncode for r in runs] == [0, 0, 0], runs[-1].stderr[-2000:]
    totals = [float(r.stdout) for r in runs]
    assert totals[0] > 0.0 and totals[1] == totals[2]


def test_no_cached_kernel_calls_a_parallel_one():
    """The rule behind the test above, for every kernel: a parallel=True kernel is called from
    Python only, never from another njit function."""
    import ast
    pkg = REPO / "src" / "harnesspipe"
    trees = {p: ast.parse(p.read_text()) for p in (pkg / "fe").rglob("*.py")}

    def decorators(fn):
        return [ast.unparse(d) for d in fn.decorator_list]

    functions = [fn for tree in trees.values() for fn in ast.walk(tree)
                 if isinstance(fn, ast.FunctionDef)]
    parallel = {fn.name for fn in functions if any("parallel=True" in d for d in decorators(fn))}
    callers = [(fn.name, call.func.id) for fn in functions
               if any("njit" in d or "loop_kernel" in d for d in decorators(fn))
               for call in ast.walk(fn)
               if isinstance(call, ast.Call) and isinstance(call.func, ast.Name)
               and call.func.id in parallel]
    assert parallel and callers == []
