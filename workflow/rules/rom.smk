# Stage 7: reduced-order beam properties of every CWB case (Sec. 4.3, eq. 13 + simplex).

def rom_reference(wc):
    """The curve the ROM of a case is fitted to: the measured mean, or with rom.reference: hifi
    the hi-fi virtual test at the calibrated interface (workflow/rules/hifi.smk)."""
    if config["rom"]["reference"] == "hifi":
        return f"{RES}/hifi/virtual/{wc.case}/curve.csv"
    return f"{RES}/data/{test_id_for('three_point', wc.case)}.h5"


rule rom_fit:
    """eq. 13 (E_eff, first sigma_Y), then Nelder-Mead on the hardening of a beam model."""
    input:
        rom_reference,
        warm=rules.numba_warmup.output,
    output:
        fit=f"{RES}/rom/{{case}}/fit.json",
        curve=f"{RES}/rom/{{case}}/curve.csv",
        trace=f"{RES}/rom/{{case}}/trace.h5",
        shapes=f"{RES}/rom/{{case}}/shapes.csv",
        paraview=f"{RES}/rom/{{case}}/shapes.pvd",
        plot=report(f"{RES}/rom/{{case}}/fit.png", caption="../report/rom_fit.rst",
                    category="ROM (Sec. 4.3)", subcategory="{case}"),
    log:
        f"{RES}/logs/rom_fit_{{case}}.log",
    params:
        settings=lambda wc: SETTINGS.rom(config, PROFILE, wc.case),
        code=code_hash("harnesspipe.stages.rom", "commands/stage.py"),
    threads: 1
    priority: 1
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage rom-fit --case {wildcards.case} --reference {input[0]} "
        "--settings '{params.settings}' --outdir {RES}/rom/{wildcards.case} > {log} 2>&1"


rule table3:
    """Table 3 across all cases: results/rom/table3.csv (case,E,sigma_y,K,n,reference)."""
    input:
        CATALOGUE.rom_fits(config, TESTS, RES),
    output:
        f"{RES}/rom/table3.csv",
    log:
        f"{RES}/logs/table3.log",
    params:
        code=code_hash("harnesspipe.stages.rom", "commands/stage.py"),
    shell:
        "{HP} stage table3 --fits {input} --out {output} > {log} 2>&1"
