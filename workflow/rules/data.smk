# Stage 1: data check and per-test resampling (DESIGN sec. 2.1).

from harnesspipe.stages.chain_settings import CALIBRATED as CALIBRATED_CASES


rule check_data:
    """Validate every file of the data folder against the manifest schema."""
    input:
        manifest=f"{DATA}/manifest.yaml",
        samples=[f for t in TESTS for f in sample_files(t)],
    output:
        f"{RES}/data/check.txt",
    log:
        f"{RES}/logs/check_data.log",
    params:
        code=code_hash("harnesspipe.stages.data", "commands/data.py"),
    shell:
        "{HP} check-data {DATA} > {output} 2> {log} || (cat {log} >&2; rm -f {output}; exit 1)"


def first_data_priority(entry):
    """10 for the tests the hi-fi chain's start waits on (the tensile tests, through Table 2,
    and the chain's calibration cases), the longest path of the run; 0 for the others."""
    return 10 if entry.get("kind") == "tensile" or entry.get("item") in CALIBRATED_CASES else 0


rule prepare_test:
    """Resample the replicates of one test to a common grid: mean and min/max band."""
    input:
        lambda wc: sample_files(wc.test),
    output:
        f"{RES}/data/{{test}}.h5",
    log:
        f"{RES}/logs/prepare_{{test}}.log",
    params:
        entry=lambda wc: json.dumps(TESTS[wc.test], sort_keys=True),
        code=code_hash("harnesspipe.stages.data", "commands/data.py"),
    wildcard_constraints:
        test="[a-z0-9_]+",
    priority: lambda wc: first_data_priority(TESTS[wc.test])
    shell:
        "{HP} prepare --data-dir {DATA} --test {wildcards.test} --out {output} > {log} 2>&1"
