# Stage 9: the offline HTML report of every fit.


rule effective_config:
    """The config of this run, with --config overrides applied, for the report."""
    output:
        f"{RES}/config.yaml",
    log:
        f"{RES}/logs/effective_config.log",
    params:
        cfg=json.dumps(config, sort_keys=True),
    run:
        Path(output[0]).write_text(yaml.safe_dump(json.loads(params.cfg), sort_keys=False))
        Path(log[0]).write_text(f"wrote {output[0]} (profile {config['profile']})\n")


REPORT_FITS = CATALOGUE.stage_fits(config, TESTS, RES)
# The benches' records of many hi-fi runs, not rules of the pipeline: the sensitivity screen
# (bench/bench_sensitivity.py, ~30 runs) and Table 3's band over the build state
# (bench/bench_build_band.py, 20 runs).  The report shows each the project has; a new record
# reruns the report.
RECORDS = {k: p for k, p in [("screen", "bench/sensitivity.json"), ("band", "bench/build_band.json")]
           if Path(p).exists()}


rule report:
    """One self-contained HTML file (figures embedded, no network)."""
    input:
        config=f"{RES}/config.yaml",
        check=f"{RES}/data/check.txt",
        prepared=[f"{RES}/data/{t}.h5" for t in sorted(TESTS)],
        fits=[p for paths in REPORT_FITS.values() for p in paths],
        extra=CATALOGUE.report_extra(config, TESTS, RES),
        records=list(RECORDS.values()),
    output:
        report(f"{RES}/report/index.html", caption="../report/index.rst", category="Report"),
    log:
        f"{RES}/logs/report.log",
    params:
        fits=CATALOGUE.report_fit_args(REPORT_FITS),
        code=code_hash("harnesspipe.report.html", "commands/report.py"),
        records=" ".join(f"--{k} {p}" for k, p in RECORDS.items()),
    shell:
        "{HP} report --config {input.config} --results {RES} --check {input.check} "
        "--prepared {input.prepared} --fits {params.fits} --out {output} "
        "{params.records} > {log} 2>&1"
