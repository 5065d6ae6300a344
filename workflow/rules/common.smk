# Shared helpers of the rule files: the data manifest as seen at parse time and
# the code-version params.
import yaml
from pathlib import Path


def manifest_tests():
    """Tests of the manifest ({} if it is missing or unreadable: check_data reports why)."""
    path = Path(DATA) / "manifest.yaml"
    try:
        with open(path) as f:
            return (yaml.safe_load(f) or {}).get("tests", {}) or {}
    except (OSError, yaml.YAMLError):
        return {}


TESTS = manifest_tests()


def sample_files(test_id):
    """CSV files (curves and markers) of one test."""
    files = []
    for s in TESTS[test_id].get("samples", []):
        files.append(f"{DATA}/{s['file']}")
        if "markers" in s:
            files.append(f"{DATA}/{s['markers']}")
    return files


def test_id_for(kind, item, load_case=None):
    for t, e in TESTS.items():
        if e.get("kind") == kind and e.get("item") == item and e.get("load_case") == load_case:
            return t
    raise ValueError(f"{DATA}/manifest.yaml: no {kind} test for {item!r}")


rule numba_warmup:
    """Compile (or load from cache) the Numba kernels of the ROM, tensile and branch
    models once, before their parallel jobs start.

    Jobs starting together would each compile everything (Numba has no lock).
    The output name carries the FE-core hash, so a changed core warms up again.
    """
    output:
        f"{RES}/logs/numba_warmup_{source_hash('fe')}.done",
    log:
        f"{RES}/logs/numba_warmup.log",
    shell:
        "{HP} stage warmup > {log} 2>&1 && cp {log} {output}"


rule hifi_warmup:
    """The same for the hi-fi model's kernels (only the hi-fi rules need them).  Beside
    numba_warmup, not after it: the two share only small kernels (hardening, rotations),
    which both may compile (the cache is written atomically); a cold start is ~2 min
    shorter on 2 cores."""
    priority: 10      # the head of the hi-fi chain, the longest path of the run
    output:
        f"{RES}/logs/hifi_warmup_{source_hash('fe')}.done",
    log:
        f"{RES}/logs/hifi_warmup.log",
    shell:
        "{HP} stage warmup --hifi > {log} 2>&1 && cp {log} {output}"
