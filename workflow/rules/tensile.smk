# Stage 2: component tensile fits (Sec. 3.2): results/tensile/table2.csv.

rule tensile_fit:
    """Nelder-Mead on the tensile model (tubes), eq. 3 + Nelder-Mead (fabric)."""
    input:
        ref=lambda wc: f"{RES}/data/{test_id_for('tensile', wc.component)}.h5",
        warm=rules.numba_warmup.output,
    output:
        fit=f"{RES}/tensile/{{component}}/fit.json",
        curve=f"{RES}/tensile/{{component}}/curve.csv",
        trace=f"{RES}/tensile/{{component}}/trace.h5",
        plot=report(f"{RES}/tensile/{{component}}/fit.png", caption="../report/tensile.rst",
                    category="Tensile (Sec. 3.2)", subcategory="{component}"),
    log:
        f"{RES}/logs/tensile_fit_{{component}}.log",
    params:
        settings=lambda wc: SETTINGS.tensile(config, PROFILE, wc.component),
        code=code_hash("harnesspipe.stages.tensile", "commands/stage.py"),
    wildcard_constraints:
        component="closed_tube|open_tube|fabric_tube",
    threads: 1
    priority: 10      # Table 2 feeds the hi-fi chain, the longest path of the run: its fits go before the branch and ROM jobs
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage tensile-fit --component {wildcards.component} "
        "--reference {input.ref} --settings '{params.settings}' "
        "--outdir {RES}/tensile/{wildcards.component} > {log} 2>&1"


rule table2:
    """Table 2 across the coverings: results/tensile/table2.csv (component,E,sigma_y,K,n)."""
    input:
        CATALOGUE.tensile_fits(TESTS, RES),
    output:
        f"{RES}/tensile/table2.csv",
    priority: 10
    log:
        f"{RES}/logs/table2.log",
    params:
        code=code_hash("harnesspipe.stages.tensile", "commands/stage.py"),
    shell:
        "{HP} stage table2 --fits {input} --out {output} > {log} 2>&1"
