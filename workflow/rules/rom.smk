# Stage 7: reduced-order beam properties of every CWB case (Sec. 4.3, eq. 13 + simplex).

ROM_CASES = sorted(e["item"] for e in TESTS.values()
                   if e.get("kind") == "three_point" and e.get("item") in config["cases"])


def rom_settings(case):
    tp = config["three_point"]
    return json.dumps({
        "r_o": {**config["cases"], **config["hifi"]["extra_cases"]}[case]["r_o"],
        "supports": config["rom"]["supports"],
        "mu": config["rom"]["roller_friction"],
        "reference": config["rom"]["reference"],
        "three_point": {k: tp[k] for k in ("span", "overhang", "deflection")},
        "rom": {k: config["rom"][k] for k in ("model_consistent_E", "linear_window", "yield_deflection",
                                              "simplex_parameters", "simplex_space", "reference_strains",
                                        "simplex", "initial_guess")},
        "mesh": PROFILE["rom"],
        "maxfev": PROFILE["simplex_maxfev"],
    }, sort_keys=True)


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
        settings=lambda wc: rom_settings(wc.case),
        code=code_hash("harnesspipe.stages.rom", "commands/stage.py"),
    threads: 1
    priority: 1
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage rom-fit --case {wildcards.case} --reference {input[0]} "
        "--settings '{params.settings}' --outdir {RES}/rom/{wildcards.case} > {log} 2>&1"


rule table3:
    """Table 3 across all cases: results/rom/table3.csv (case,E,sigma_y,K,n,reference)."""
    input:
        [f"{RES}/rom/{c}/fit.json" for c in ROM_CASES],
    output:
        f"{RES}/rom/table3.csv",
    log:
        f"{RES}/logs/table3.log",
    params:
        code=code_hash("harnesspipe.stages.rom", "commands/stage.py"),
    shell:
        "{HP} stage table3 --fits {input} --out {output} > {log} 2>&1"


if ROM_CASES:
    FITS["rom"] = [f"{RES}/rom/{c}/fit.json" for c in ROM_CASES]
    TARGETS.append(f"{RES}/rom/table3.csv")
