import dataclasses

from snakemake.utils import validate

from pih.records.provenance import script_library_hash
from pih.study.config import (
    check_study,
    figure_point,
    planning_space,
    read_config_files,
    recordings_section,
    resolved_sections,
    robustness_section,
    stop_on_config_error,
    study_points,
    validation_scenes,
)
from pih.study.schema import check_schema, typed_command_line

# Stop before any job runs if the config is malformed (schema) or out of range (library), with
# one line naming the file or the dotted key (and the variant).
with stop_on_config_error():
    # No repeated YAML keys; a --configfile defines its own sweep (not merged onto the default's).
    read_config_files(
        config, workflow.configfiles, workflow.overwrite_configfiles or []
    )
    SCHEMA = os.path.join(workflow.basedir, "workflow/schemas/config.schema.json")
    # --config 'planner={"iterations": 5}': Snakemake passes the nested leaves as strings.
    typed_command_line(config, workflow.config_settings.config or {}, SCHEMA)
    check_schema(config, SCHEMA)
    validate(config, "../schemas/config.schema.json")
    # Sweep: each key a dotted config path, each value its levels; a run's directory is named
    # by the last path components and levels (planning_space). At most max_sweep_points
    # (default 10,000), counted before any point is built.
    POINTS = study_points(config)
    check_study(config, POINTS)

SWEEP_PATHS = {path.rsplit(".", 1)[-1]: path for path in config["sweep"]}
PLANNING = planning_space(config, POINTS)


def sweep_point(wildcards):
    """The dotted-path overrides of one planning job."""
    return {SWEEP_PATHS[k]: v for k, v in PLANNING.instance(wildcards).items()}


def resolved_section(section):
    """A planning job's resolved `scene` or `planner` section (its sweep point and variant
    applied) as params: a changed value or variant re-runs the jobs it reaches, no others.
    """
    return lambda wildcards: resolved_sections(config, sweep_point(wildcards))[section]


def library_of(script):
    """The hash of the pih modules a workflow script imports, directly or not: a library edit
    re-runs the jobs whose code it reaches (Snakemake tracks the script, not its imports).
    """
    return script_library_hash(
        os.path.join(workflow.basedir, "workflow", "scripts", script)
    )


# The Rerun recordings' rates, as params of the jobs that write recordings: under Snakemake's
# default rerun triggers a changed rate re-runs those jobs (plans, validation runs) whole;
# `--rerun-triggers mtime` keeps them (docs/workflow.md, "Recordings in detail").
RECORDINGS = dataclasses.asdict(recordings_section(config))

# Each planning run is redeployed once per std (file names carry the std as Python prints it).
ROBUSTNESS_STDS = [str(float(std)) for std in config["robustness"]["start_std_m"]]
# ...and once per model error, from starts offset by the smallest std > 0.
MODEL_ERROR_STD = robustness_section(config).model_error_start_std_m
REDEPLOYMENTS = expand(
    "results/planning/{point}/redeploy_start_std_m~{std}.parquet",
    point=PLANNING.instance_patterns,
    std=ROBUSTNESS_STDS,
) + expand(
    "results/planning/{point}/redeploy_model_error~{error}.parquet",
    point=PLANNING.instance_patterns,
    error=list(config["robustness"].get("model_error") or {}),
)

# What results/summary.md says it summarises: the default config first, then the user's.
USER_CONFIGFILES = [os.path.abspath(f) for f in workflow.overwrite_configfiles or []]
STUDY = {
    "config_files": [
        os.path.relpath(f, workflow.basedir)
        for f in [
            *(
                f
                for f in map(os.path.abspath, workflow.configfiles)
                if f not in USER_CONFIGFILES
            ),
            *USER_CONFIGFILES,
        ]
    ],
    "default": not workflow.overwrite_configfiles,
    "iterations": config["planner"]["iterations"],
    "rollouts_per_iteration": config["planner"]["optimizer"]["population_size"],
    "deploy_trials": config["planner"]["deploy_trials"],
    "deploy_start_std_m": config["planner"]["deploy_start_std_m"],
    "planning_runs": len(POINTS),
}

VALIDATION_OFFSETS = config["validation"]["offsets_m"]
VALIDATION_VARIANTS = list(config["validation"]["variants"])
# Each validation run gets its variant's resolved scene as params, so a changed or added
# variant re-runs its own runs only.
VALIDATION_SCENES = validation_scenes(config)
FIGURE_VARIANTS = config["validation"]["figure_variants"]
FIGURE_POINTS = [
    pattern
    for pattern, row in zip(
        PLANNING.instance_patterns, PLANNING.dataframe.to_dict("records")
    )
    if all(
        row[path.rsplit(".", 1)[-1]] == level
        for path, level in figure_point(config, POINTS).items()
    )
]


wildcard_constraints:
    offset=r"[0-9.e+-]+",
    std=r"[0-9.e+-]+",
    variant=r"[a-z0-9_]+",
    error=r"[a-z0-9_]+",


def record_companions(outputs, carrier):
    """A job's CSV and PDF outputs carry no record of their own: they share the job's record
    with its Parquet file ``carrier`` (for provenance.md)."""
    return {str(f): str(carrier) for f in outputs if str(f).endswith((".csv", ".pdf"))}
