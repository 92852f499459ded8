"""Quasi-static straight-down insertion in Drake at one offset and contact model (paper §2.4)."""

from pih.config import from_mapping
from pih.recordings import record_insertion
from pih.scene import PegInHoleScene, SceneConfig
from pih.traces import write_trace
from pih.validation import run_insertion, validation_scene_config
from pih.workflow import ValidationSection, job_provenance, logged

with logged(snakemake.log[0]):
    section = from_mapping(ValidationSection, snakemake.params.validation, "validation")
    base = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    scene_config = validation_scene_config(
        base.replace(solver__contact_model=snakemake.wildcards.model), section.experiment
    )
    offset = float(snakemake.wildcards.offset)
    trace = run_insertion(PegInHoleScene(scene_config), offset, section.experiment)
    record = job_provenance(
        snakemake,
        "validation_run",
        config={"scene": snakemake.params.scene, "validation": snakemake.params.validation},
        simulator=scene_config.simulator_settings(),
    )
    write_trace(trace, snakemake.output.trace, record)
    record_insertion(snakemake.output.recording, trace, scene_config, record["run_id"], record)
    print(
        f"{snakemake.wildcards.model} offset {offset} m: {trace.status} {trace.reason}; {len(trace)} steps, final depth {trace.insertion_depth_m[-1]:.5f} m"
    )
