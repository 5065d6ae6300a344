# Stage 8: branching harness, break-out joint damping (Sec. 5, eqs. 14-15).

BRANCH_TESTS = CATALOGUE.branch_tests(TESTS)


# branch.properties_source: hifi -- the beams' E, sigma_y, K, n from eq. 13 + simplex on each
# case's hi-fi virtual test (rule hifi_virtual_rom), in place of the config's estimates
BRANCH_HIFI_FITS = CATALOGUE.branch_property_fits(config, RES)
BRANCH_PROPS = " ".join(f"{c}={p}" for c, p in BRANCH_HIFI_FITS.items())

BRANCH_CODE = code_hash("harnesspipe.stages.branch", "commands/stage.py")


rule branch_fit:
    """Calibrate alpha on the in-plane pull test: results/branch/damping.csv."""
    input:
        ref=lambda wc: f"{RES}/data/{BRANCH_TESTS['inplane']}.h5",
        warm=rules.numba_warmup.output,
        hifi_props=list(BRANCH_HIFI_FITS.values()),
    output:
        fit=f"{RES}/branch/inplane/fit.json",
        curve=f"{RES}/branch/inplane/curve.csv",
        trace=f"{RES}/branch/inplane/trace.h5",
        shapes=f"{RES}/branch/inplane/shapes.csv",
        plot=report(f"{RES}/branch/inplane/fit.png", caption="../report/branch.rst",
                    category="Branch (Sec. 5)"),
        damping=f"{RES}/branch/damping.csv",
    log:
        f"{RES}/logs/branch_fit.log",
    params:
        settings=SETTINGS.branch(config),
        code=BRANCH_CODE,
    threads: 1
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage branch-fit --reference {input.ref} "
        "--settings '{params.settings}' --outdir {RES}/branch/inplane --damping {output.damping} "
        "--properties-from {BRANCH_PROPS} > {log} 2>&1"


rule branch_elastic:
    """The elastic joint (alpha = 0) on the in-plane test: the paper's discrepancy (Fig. 18a)."""
    input:
        ref=lambda wc: f"{RES}/data/{BRANCH_TESTS['inplane']}.h5",
        warm=rules.numba_warmup.output,
        hifi_props=list(BRANCH_HIFI_FITS.values()),
    output:
        fit=f"{RES}/branch/elastic/fit.json",
        curve=f"{RES}/branch/elastic/curve.csv",
        shapes=f"{RES}/branch/elastic/shapes.csv",
        plot=report(f"{RES}/branch/elastic/fit.png", caption="../report/branch.rst",
                    category="Branch (Sec. 5)"),
    log:
        f"{RES}/logs/branch_elastic.log",
    params:
        settings=SETTINGS.branch(config),
        code=BRANCH_CODE,
    shell:
        "{HP} stage branch-predict --reference {input.ref} --settings '{params.settings}' "
        "--outdir {RES}/branch/elastic --load-case inplane --alpha 0 "
        "--item 'in-plane pull: elastic joint (alpha = 0)' --role prediction "
        "--properties-from {BRANCH_PROPS} > {log} 2>&1"


rule branch_validate:
    """The out-of-plane pull test (Fig. 20) at the calibrated alpha, no refit."""
    input:
        ref=lambda wc: f"{RES}/data/{BRANCH_TESTS['outofplane']}.h5",
        damping=f"{RES}/branch/damping.csv",
        hifi_props=list(BRANCH_HIFI_FITS.values()),
    output:
        fit=f"{RES}/branch/outofplane/fit.json",
        curve=f"{RES}/branch/outofplane/curve.csv",
        shapes=f"{RES}/branch/outofplane/shapes.csv",
        plot=report(f"{RES}/branch/outofplane/fit.png", caption="../report/branch.rst",
                    category="Branch (Sec. 5)"),
    log:
        f"{RES}/logs/branch_validate.log",
    params:
        settings=SETTINGS.branch(config),
        code=BRANCH_CODE,
    shell:
        "{HP} stage branch-predict --reference {input.ref} --settings '{params.settings}' "
        "--outdir {RES}/branch/outofplane --load-case outofplane --damping {input.damping} "
        "--item 'out-of-plane pull: validation at calibrated alpha' "
        "--properties-from {BRANCH_PROPS} > {log} 2>&1"


# The hi-fi Y harness beside the ROM (Fig. 18a): one explicit run of the mesoscale model with the
# tensile stage's coverings and the paper's interface values (config branch.hifi).
BRANCH_HIFI = config["branch"]["hifi"]
BRANCH_HIFI_CODE = code_hash("harnesspipe.stages.branch_hifi", "commands/stage.py")


def branch_hifi_order(wc):
    """Scheduling only: when this job and the hi-fi chain are both in this profile's `all`, start
    after the chain's last two-thread fit (cohesive).  Ready together with the chain's first fit, this one-thread job took the core
    a short job had just left while the two-thread fit waited for both -- 7.3 min of the default
    run (bench/RESULTS.md).  ancient(): the fit's content or age never reruns this job."""
    if "chain" in config["hifi"]["pipeline"]["in_all"] and config["profile"] in BRANCH_HIFI["in_all"]:
        return {"after_chain_fits": ancient(f"{RES}/hifi/chain/cohesive/fit.json")}
    return {}


rule branch_hifi:
    """The mesoscale Y harness on the pull test (Fig. 18a): curve, energies, S2 shapes, cost."""
    input:
        unpack(branch_hifi_order),
        table2=f"{RES}/tensile/table2.csv",
        warm=rules.hifi_warmup.output,
    output:
        curve=f"{RES}/branch/hifi/curve.csv",
        summary=f"{RES}/branch/hifi/summary.json",
        energies=f"{RES}/branch/hifi/energies.csv",
    log:
        f"{RES}/logs/branch_hifi.log",
    params:
        settings=lambda wc: SETTINGS.branch_hifi(config, PROFILE),
        code=BRANCH_HIFI_CODE,
    threads: 1
    priority: 2              # the run's longest one-thread job (6.5 min at default) first, beside the chain's one-thread fabric fits, before the virtual tests (1-1.1): at priority 0 it ran last and alone (12.5 of a 68 min default run on a slower machine; bench/RESULTS.md 'Pipeline (default)')
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage branch-hifi --settings '{params.settings}' "
        "--coverings {input.table2} --outdir {RES}/branch/hifi > {log} 2>&1"


rule branch_hifi_all:
    """The hi-fi Y harness in any profile (in `all` for the profiles of branch.hifi.in_all)."""
    input:
        f"{RES}/branch/hifi/summary.json",
