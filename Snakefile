# Inpaint360GS benchmark workflow. Entry point: `make benchmark` (README), or
#   snakemake --cores 2 --profile workflow/profiles/local
# Each rule calls one CLI stage of the package; rules live in workflow/rules/, settings in
# workflow/config/config.yaml (validated against config.schema.yaml).

from snakemake.utils import min_version, validate

min_version("8.0")


configfile: "workflow/config/config.yaml"


validate(config, "workflow/config/config.schema.yaml")


include: "workflow/rules/common.smk"
include: "workflow/rules/dataset.smk"
include: "workflow/rules/reconstruct.smk"


rule all:
    input:
        all_targets(),
    default_target: True
