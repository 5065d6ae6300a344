# Virtual test campaigns (issue 28; DESIGN stage 10): a construction catalogue -> the hi-fi
# virtual test of each construction at the calibrated interface -> eq. 13 + simplex -> one row
# of results/campaign/<catalogue>/properties.csv, the campaign page beside it and the solver
# cards of the library (cards/calculix|abaqus|lsdyna/<construction>/, harnesspipe cards).
#   snakemake --cores 2 campaign --config campaign=config/campaigns/demo.yaml [profile=quick]
# The catalogue is checked when the workflow is parsed (a bad entry stops here, naming the
# construction and the key).  Each construction's rules get settings built from its entry alone
# (harnesspipe.campaign.settings): adding an entry runs that construction only, an unchanged
# catalogue reruns nothing.  A construction whose run fails becomes a failed row; the others go on.

from harnesspipe.campaign import settings as CAMPAIGN_SETTINGS

CAMPAIGN = CAMPAIGN_SETTINGS.catalogue(config)     # None without --config campaign=FILE
CAMPAIGN_HIFI_CODE = code_hash("harnesspipe.campaign.virtual", "commands/campaign.py")
CAMPAIGN_ROM_CODE = code_hash("harnesspipe.campaign.library", "commands/campaign.py")

if CAMPAIGN is not None:
    CAMP = CAMPAIGN_SETTINGS.folder(CAMPAIGN, RES)
    CAMPAIGN_INTERFACE = CAMPAIGN_SETTINGS.interface(config, RES)
    CAMPAIGN_COVERINGS = CAMPAIGN_SETTINGS.coverings(config, RES)
    CAMPAIGN_NAMES = "|".join(CAMPAIGN.constructions)

    rule campaign_hifi:
        """The hi-fi virtual three-point test of one construction (Sec. 4.1) at the campaign's interface."""
        input:
            warm=rules.hifi_warmup.output,
        output:
            result=f"{CAMP}/{{construction}}/hifi/result.json",
            curve=f"{CAMP}/{{construction}}/hifi/curve.csv",
        log:
            f"{RES}/logs/campaign_{CAMPAIGN.name}/{{construction}}_hifi.log",
        params:
            settings=lambda wc: CAMPAIGN_SETTINGS.hifi(CAMPAIGN, wc.construction, config, PROFILE,
                                                       CAMPAIGN_INTERFACE, CAMPAIGN_COVERINGS),
            code=CAMPAIGN_HIFI_CODE,
        wildcard_constraints:
            construction=CAMPAIGN_NAMES,
        threads: 1
        shell:
            "NUMBA_NUM_THREADS={threads} {HP} campaign hifi --construction {wildcards.construction} "
            "--settings '{params.settings}' --outdir {CAMP}/{wildcards.construction}/hifi > {log} 2>&1"

    rule campaign_rom:
        """eq. 13 + simplex on a construction's virtual test (Sec. 4.3): its row of the library."""
        input:
            result=f"{CAMP}/{{construction}}/hifi/result.json",
            curve=f"{CAMP}/{{construction}}/hifi/curve.csv",
            warm=rules.numba_warmup.output,
        output:
            f"{CAMP}/{{construction}}/property.json",
        log:
            f"{RES}/logs/campaign_{CAMPAIGN.name}/{{construction}}_rom.log",
        params:
            settings=lambda wc: CAMPAIGN_SETTINGS.rom(CAMPAIGN, wc.construction, config, PROFILE),
            code=CAMPAIGN_ROM_CODE,
        wildcard_constraints:
            construction=CAMPAIGN_NAMES,
        threads: 1
        shell:
            "NUMBA_NUM_THREADS={threads} {HP} campaign rom --construction {wildcards.construction} "
            "--hifi {CAMP}/{wildcards.construction}/hifi --settings '{params.settings}' "
            "--outdir {CAMP}/{wildcards.construction} > {log} 2>&1"

    rule campaign_library:
        """The property library: results/campaign/<catalogue>/properties.csv, one row per construction."""
        input:
            [f"{CAMP}/{c}/property.json" for c in CAMPAIGN.constructions],
        output:
            f"{CAMP}/properties.csv",
        log:
            f"{RES}/logs/campaign_{CAMPAIGN.name}/library.log",
        params:
            code=CAMPAIGN_ROM_CODE,
        shell:
            "{HP} campaign library --rows {input} --out {output} > {log} 2>&1"

    rule campaign_page:
        """The campaign's HTML page: the library, every construction's curves, EI and yield curvature by feature."""
        input:
            f"{CAMP}/properties.csv",
        output:
            f"{CAMP}/index.html",
        log:
            f"{RES}/logs/campaign_{CAMPAIGN.name}/page.log",
        params:
            code=code_hash("harnesspipe.campaign.page", "commands/campaign.py"),
            title=f"Campaign {CAMPAIGN.name} ({CAMPAIGN.path})",
        shell:
            "{HP} campaign page --library {input} --title '{params.title}' --out {output} > {log} 2>&1"


    rule campaign_cards:
        """Solver cards of every ok row of the library (harnesspipe cards): cards/<format>/<case>/."""
        input:
            f"{CAMP}/properties.csv",
        output:
            f"{CAMP}/cards/{{format}}/README.md",
        log:
            f"{RES}/logs/campaign_{CAMPAIGN.name}/cards_{{format}}.log",
        params:
            code=code_hash("harnesspipe.cards", "commands/cards.py"),
        wildcard_constraints:
            format="calculix|abaqus|lsdyna",
        shell:
            "{HP} cards --table {input} --format {wildcards.format} --out {CAMP}/cards/{wildcards.format} "
            "> {log} 2>&1"


rule campaign:
    """Target: the property library, page and solver cards of --config campaign=CATALOGUE."""
    input:
        lambda wc: CAMPAIGN_SETTINGS.targets(CAMPAIGN, RES),
