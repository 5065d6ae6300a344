# Stage 1: data check and per-test resampling (DESIGN sec. 2.1).


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
    shell:
        "{HP} prepare --data-dir {DATA} --test {wildcards.test} --out {output} > {log} 2>&1"
