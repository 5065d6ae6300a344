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
# The hi-fi sensitivity screen's record (bench/bench_sensitivity.py, ~30 hi-fi runs, not a rule
# of the pipeline): shown by the report when the project has one; a new record reruns the report.
SCREEN = [p for p in ["bench/sensitivity.json"] if Path(p).exists()]


rule report:
    """One self-contained HTML file (figures embedded, no network)."""
    input:
        config=f"{RES}/config.yaml",
        check=f"{RES}/data/check.txt",
        prepared=[f"{RES}/data/{t}.h5" for t in sorted(TESTS)],
        fits=[p for paths in REPORT_FITS.values() for p in paths],
        extra=CATALOGUE.report_extra(config, TESTS, RES),
        screen=SCREEN,
    output:
        report(f"{RES}/report/index.html", caption="../report/index.rst", category="Report"),
    log:
        f"{RES}/logs/report.log",
    params:
        fits=CATALOGUE.report_fit_args(REPORT_FITS),
        code=code_hash("harnesspipe.report.html", "commands/report.py"),
        screen=" ".join(f"--screen {p}" for p in SCREEN),
    shell:
        "{HP} report --config {input.config} --results {RES} --check {input.check} "
        "--prepared {input.prepared} --fits {params.fits} --out {output} "
        "{params.screen} > {log} 2>&1"
