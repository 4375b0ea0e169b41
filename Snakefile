# Inpaint360GS benchmark workflow. Entry point: `make benchmark` (README), or
#   snakemake --cores 2 --profile workflow/profiles/local
# Each rule calls one CLI stage of the package; rules live in workflow/rules/, settings in
# workflow/config/config.yaml (validated against config.schema.yaml).

from snakemake.utils import min_version, validate

min_version("8.0")


configfile: "workflow/config/config.yaml"


def _typed(value):
    """`--config` values arrive as strings below the top level (Snakemake parses nested ones with
    YAML's BaseLoader) and `true` stays a string even at the top: turn YAML booleans and numbers
    back into them so `reduced=true` or `train='{iterations: 1000}'` validate like the file."""
    import yaml

    if isinstance(value, dict):
        return {k: _typed(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_typed(v) for v in value]
    if isinstance(value, str) and value.strip():
        try:
            parsed = yaml.safe_load(value)
        except yaml.YAMLError:
            return value
        if isinstance(parsed, (bool, int, float)):
            return parsed
    return value


config.update(_typed(dict(config)))


def config_error(message):
    """A bad setting: one line on stderr (`config: <setting> ...`) and exit status 2, not a traceback."""
    import sys

    print(f"config: {message}", file=sys.stderr)
    raise SystemExit(2)


def _check_schema():
    """The schema's first complaint, on one line naming the setting (an unknown key, a value out of range)."""
    import jsonschema
    import yaml

    with open("workflow/config/config.schema.yaml") as f:
        schema = yaml.safe_load(f)
    errors = sorted(jsonschema.Draft202012Validator(schema).iter_errors(dict(config)), key=lambda e: [str(x) for x in e.absolute_path])
    if errors:
        e = errors[0]
        where = ".".join(str(x) for x in e.absolute_path) or "(top level)"
        config_error(f"{where}: {e.message}")


_check_schema()
validate(config, "workflow/config/config.schema.yaml")


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/dataset.smk"
include: "workflow/rules/reconstruct.smk"
include: "workflow/rules/object_field.smk"
include: "workflow/rules/inpaint.smk"
include: "workflow/rules/evaluate.smk"
include: "workflow/rules/capture.smk"


rule all:
    input:
        all_targets(),
    default_target: True
