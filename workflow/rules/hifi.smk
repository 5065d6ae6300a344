# Hi-fi virtual three-point tests (DESIGN stages 3-7 on the mesoscale model, Sec. 4.1-4.3):
#   hifi_crosscheck_all: every Table 3 case at the PAPER's Table 2 and interface values, then
#       eq. 13 + simplex on each curve -> results/hifi/crosscheck/table3.csv beside the paper's;
#   hifi_chain_all: the Sec. 4.2 calibration chain against the measured means (the build state,
#       then mu_rtb -> mu_rtp -> cohesive -> the fabric CWB's end bands -> E2/E1; the steps:
#       stages/chain_settings.STEPS)
#       -> results/hifi/interface.csv, then the virtual test of every case (incl.
#       hifi.extra_cases) at the fitted interface.
# `all` includes the groups named in hifi.pipeline.in_all (stages/targets.py; the chain's fits
# run on the mesh of hifi.pipeline.chain_profile, the virtual tests on the run's profile;
# the whole quick pipeline 23 min on 2 cores, bench/RESULTS.md; crosscheck: 5 more runs).
# Every virtual test is one thread, so two run side by side; a fit step takes its HIFI_STEPS cores.

from harnesspipe.stages import chain_settings as CHAIN

HIFI_CASES = CHAIN.cases(config)
HIFI_CROSSCHECK = CATALOGUE.crosscheck_cases(config)
HIFI_MEASURED = {e["item"]: t for t, e in sorted(TESTS.items()) if e.get("kind") == "three_point"}
HIFI_STEPS = CHAIN.STEPS        # the chain of Sec. 4.2 and its cores (stages/chain_settings.py)
CHAIN.check_windows(config)


def hifi_prepared(case):
    return f"{RES}/data/{test_id_for('three_point', case)}.h5"


def hifi_fit_inputs(wc):
    s = HIFI_STEPS[wc.step]
    return {"refs": [hifi_prepared(c) for c in s["cases"]],
            "table2": f"{RES}/tensile/table2.csv",
            "priors": [f"{RES}/hifi/chain/{p}/fit.json" for p in s["prior"]],
            "warm": rules.hifi_warmup.output[0]}


def hifi_interface_step(case):
    """The chain step whose fit.json holds the interface a virtual test of ``case`` uses."""
    return "fabric" if CHAIN.is_fabric(config, case) else "cohesive"


def hifi_reuse(case):
    """--reuse of a virtual test: the best-point run of the step that calibrated the case on its
    whole stroke at this very interface (cohesive: both plastic-tube CWBs; fabric: the fabric
    CWB) -- the stage takes it when its run_key matches, so the run is not made twice; none when
    the chain ran at another profile's mesh (hifi.pipeline.chain_profile)."""
    step = hifi_interface_step(case)
    if not CHAIN.reuses_fit_runs(config) or case not in HIFI_STEPS[step]["cases"]:
        return ""
    return f"--reuse {RES}/hifi/chain/{step}/{case}"


def hifi_virtual_inputs(wc):
    step = hifi_interface_step(wc.case)
    inputs = {"table2": f"{RES}/tensile/table2.csv", "interface": f"{RES}/hifi/chain/{step}/fit.json",
              "warm": rules.hifi_warmup.output[0]}
    if wc.case in HIFI_MEASURED:
        inputs["ref"] = f"{RES}/data/{HIFI_MEASURED[wc.case]}.h5"
    return inputs


HIFI_CODE = code_hash("harnesspipe.stages.hifi_chain", "commands/stage.py")


rule hifi_crosscheck:
    """Hi-fi test of a Table 3 case at the paper's Table 2 coverings and interface (Sec. 4.1)."""
    input:
        warm=rules.hifi_warmup.output,
    output:
        curve=f"{RES}/hifi/crosscheck/{{case}}/curve.csv",
        summary=f"{RES}/hifi/crosscheck/{{case}}/summary.json",
        energies=f"{RES}/hifi/crosscheck/{{case}}/energies.csv",
    log:
        f"{RES}/logs/hifi_crosscheck_{{case}}.log",
    params:
        settings=lambda wc: CHAIN.run_settings(config, wc.case, PROFILE, crosscheck=True),
        code=HIFI_CODE,
    wildcard_constraints:
        case="|".join(HIFI_CROSSCHECK) or "none^",
    threads: 1
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage hifi-run --case {wildcards.case} --role crosscheck "
        "--settings '{params.settings}' --outdir {RES}/hifi/crosscheck/{wildcards.case} > {log} 2>&1"


rule hifi_crosscheck_rom:
    """eq. 13 + simplex (the ROM stage's fit) on the cross-check curve of one case (Sec. 4.3)."""
    input:
        curve=f"{RES}/hifi/crosscheck/{{case}}/curve.csv",
        warm=rules.numba_warmup.output,
    output:
        fit=f"{RES}/hifi/crosscheck/{{case}}/rom/fit.json",
        curve=f"{RES}/hifi/crosscheck/{{case}}/rom/curve.csv",
        trace=f"{RES}/hifi/crosscheck/{{case}}/rom/trace.h5",
        plot=report(f"{RES}/hifi/crosscheck/{{case}}/rom/fit.png", caption="../report/hifi.rst",
                    category="Hi-fi (Sec. 4)", subcategory="cross-check {case}"),
    log:
        f"{RES}/logs/hifi_crosscheck_rom_{{case}}.log",
    params:
        settings=lambda wc: SETTINGS.rom_on_hifi(config, PROFILE, wc.case),
        code=HIFI_CODE,
    wildcard_constraints:
        case="|".join(HIFI_CROSSCHECK) or "none^",
    threads: 1
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage hifi-rom --case {wildcards.case} --curve {input.curve} "
        "--settings '{params.settings}' --outdir {RES}/hifi/crosscheck/{wildcards.case}/rom > {log} 2>&1"


rule hifi_crosscheck_table:
    """Table 3 from the hi-fi curves: results/hifi/crosscheck/table3.csv (case,E,sigma_y,K,n,reference)."""
    input:
        [f"{RES}/hifi/crosscheck/{c}/rom/fit.json" for c in HIFI_CROSSCHECK],
    output:
        f"{RES}/hifi/crosscheck/table3.csv",
    log:
        f"{RES}/logs/hifi_crosscheck_table.log",
    params:
        code=code_hash("harnesspipe.stages.rom", "commands/stage.py"),
    shell:
        "{HP} stage table3 --fits {input} --out {output} > {log} 2>&1"


rule hifi_fit:
    """One step of the Sec. 4.2 chain (bounded search, Nelder-Mead or a pick among a few values)
    on the measured means."""
    input:
        unpack(hifi_fit_inputs),
    output:
        fit=f"{RES}/hifi/chain/{{step}}/fit.json",
        curve=f"{RES}/hifi/chain/{{step}}/curve.csv",
        trace=f"{RES}/hifi/chain/{{step}}/trace.h5",
        rejected=f"{RES}/hifi/chain/{{step}}/rejected.jsonl",
        plot=report(f"{RES}/hifi/chain/{{step}}/fit.png", caption="../report/hifi.rst",
                    category="Hi-fi (Sec. 4)", subcategory="calibration {step}"),
    log:
        f"{RES}/logs/hifi_fit_{{step}}.log",
    params:
        settings=lambda wc: CHAIN.fit_settings(config, wc.step),
        refs=lambda wc: " ".join(f"{c}={hifi_prepared(c)}" for c in HIFI_STEPS[wc.step]["cases"]),
        code=HIFI_CODE,
    wildcard_constraints:
        step="|".join(HIFI_STEPS),
    threads: lambda wc: HIFI_STEPS[wc.step]["cores"]     # see HIFI_STEPS
    priority: 10      # the chain is the longest path of the run: its steps go first (branch_hifi 2, virtual tests 1-1.1)
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage hifi-fit --step {wildcards.step} --cores {threads} "
        "--settings '{params.settings}' --reference {params.refs} --coverings {input.table2} "
        "--prior {input.priors} --outdir {RES}/hifi/chain/{wildcards.step} > {log} 2>&1"


rule hifi_interface:
    """The calibrated interface: results/hifi/interface.csv (parameter,value)."""
    input:
        [f"{RES}/hifi/chain/{s}/fit.json" for s in HIFI_STEPS],
    output:
        f"{RES}/hifi/interface.csv",
    log:
        f"{RES}/logs/hifi_interface.log",
    params:
        code=HIFI_CODE,
    shell:
        "{HP} stage hifi-interface --fits {input} --out {output} > {log} 2>&1"


rule hifi_virtual:
    """Virtual test of a case at the calibrated interface (validations: no refit)."""
    input:
        unpack(hifi_virtual_inputs),
    output:
        curve=f"{RES}/hifi/virtual/{{case}}/curve.csv",
        summary=f"{RES}/hifi/virtual/{{case}}/summary.json",
        energies=f"{RES}/hifi/virtual/{{case}}/energies.csv",
    log:
        f"{RES}/logs/hifi_virtual_{{case}}.log",
    params:
        settings=lambda wc: CHAIN.run_settings(config, wc.case, PROFILE, crosscheck=False),
        ref=lambda wc, input: f"--reference {input.ref}" if "ref" in input.keys() else "",
        role=lambda wc: CHAIN.role(wc.case),
        reuse=lambda wc: hifi_reuse(wc.case),
        code=HIFI_CODE,
    wildcard_constraints:
        case="|".join(sorted(HIFI_CASES)),
    threads: 1
    priority: lambda wc: CHAIN.virtual_priority(config, wc.case, bool(hifi_reuse(wc.case)))
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage hifi-run --case {wildcards.case} --role {params.role} "
        "--settings '{params.settings}' --coverings {input.table2} --interface {input.interface} "
        "{params.ref} {params.reuse} --outdir {RES}/hifi/virtual/{wildcards.case} > {log} 2>&1"


rule hifi_virtual_rom:
    """eq. 13 + simplex on a virtual test (Sec. 4.3; for the branch: branch.properties_source hifi)."""
    input:
        curve=f"{RES}/hifi/virtual/{{case}}/curve.csv",
        warm=rules.numba_warmup.output,
    output:
        fit=f"{RES}/hifi/virtual/{{case}}/rom/fit.json",
        curve=f"{RES}/hifi/virtual/{{case}}/rom/curve.csv",
        trace=f"{RES}/hifi/virtual/{{case}}/rom/trace.h5",
        plot=report(f"{RES}/hifi/virtual/{{case}}/rom/fit.png", caption="../report/hifi.rst",
                    category="Hi-fi (Sec. 4)", subcategory="virtual test {case}"),
    log:
        f"{RES}/logs/hifi_virtual_rom_{{case}}.log",
    params:
        settings=lambda wc: SETTINGS.rom_on_hifi(config, PROFILE, wc.case),
        code=HIFI_CODE,
    wildcard_constraints:
        case="|".join(sorted(HIFI_CASES)),
    threads: 1
    shell:
        "NUMBA_NUM_THREADS={threads} {HP} stage hifi-rom --case {wildcards.case} --curve {input.curve} "
        "--settings '{params.settings}' --label 'hi-fi virtual test' "
        "--outdir {RES}/hifi/virtual/{wildcards.case}/rom > {log} 2>&1"


rule hifi_crosscheck_all:
    """Table 3 from hi-fi runs at the paper's values (in `all` when hifi.pipeline.in_all names crosscheck)."""
    input:
        CATALOGUE.crosscheck_targets(config, RES),


rule hifi_chain_all:
    """The Sec. 4.2 calibration chain and the virtual tests (in `all` when hifi.pipeline.in_all names chain)."""
    input:
        CATALOGUE.chain_targets(config, RES),
