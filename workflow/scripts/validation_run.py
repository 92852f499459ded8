"""Quasi-static straight-down insertion in Drake at one offset, in one validation variant (paper §2.4)."""

from pih.config import from_mapping, to_mapping
from pih.outputs import write_trace
from pih.recordings import record_insertion
from pih.scene import PegInHoleScene
from pih.study_config import ValidationSection
from pih.validation import run_insertion
from pih.workflow import job_provenance, logged

with logged(snakemake.log[0]):
    section = from_mapping(ValidationSection, snakemake.params.validation, "validation")
    variant = snakemake.wildcards.variant
    scene = section.scene(snakemake.params.scene, variant)
    offset = float(snakemake.wildcards.offset)
    trace = run_insertion(PegInHoleScene(scene), offset, section.experiment)
    record = job_provenance(
        snakemake,
        "validation_run",
        point={"variant": variant, "offset_m": offset},
        config={"scene": to_mapping(scene), "validation": snakemake.params.validation},
        simulator=scene.simulator_settings(),
    )
    write_trace(trace, snakemake.output.trace, record)
    record_insertion(snakemake.output.recording, trace, scene, record["run_id"], record)
    print(
        f"{trace.status} {trace.reason}; {len(trace)} steps, deepest {trace.insertion_depth_m.max():.5f} m"
    )
