# harnesspipe: calibration of FE models of automotive wire harnesses.
#   snakemake --cores 2                      full reproduction (default profile)
#   snakemake --cores 2 --config profile=quick
#   snakemake --report results/report/snakemake.html
#   snakemake --cores 2 campaign --config campaign=config/campaigns/demo.yaml   (workflow/rules/campaign.smk)
import json
import sys

from snakemake.utils import min_version

min_version("9.0")

configfile: "config/config.yaml"

from harnesspipe import config as hp_config
from harnesspipe.provenance import code_hash, source_hash
from harnesspipe.stages import stage_settings as SETTINGS   # the settings rules pass to stages
from harnesspipe.stages import targets as CATALOGUE   # targets, stage fits, report inputs

hp_config.validate(config, source="config/config.yaml (with --config overrides)")

PY = sys.executable          # shell rules use Snakemake's own interpreter (DESIGN sec. 7)
HP = f'"{PY}" -m harnesspipe'
DATA = config["data_dir"]
RES = "results"
PROFILE = hp_config.resolution(config)


include: "workflow/rules/common.smk"
include: "workflow/rules/data.smk"
include: "workflow/rules/tensile.smk"
include: "workflow/rules/rom.smk"
include: "workflow/rules/branch.smk"
include: "workflow/rules/hifi.smk"
include: "workflow/rules/report.smk"
include: "workflow/rules/campaign.smk"


rule all:
    input:
        CATALOGUE.final_targets(config, TESTS, RES),
    default_target: True
