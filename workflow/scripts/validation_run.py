"""Quasi-static straight-down insertion in Drake at one offset, in one validation variant (paper §2.4)."""

from pih.config import from_mapping
from pih.records.config import RecordingsConfig
from pih.records.outputs import write_trace
from pih.records.recordings import record_insertion
from pih.scene.config import SceneConfig
from pih.scene.simulation import PegInHoleScene
from pih.validation.config import ValidationConfig
from pih.validation.experiment import STORED_COLUMNS, run_insertion, stored_samples
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    variant = snakemake.wildcards.variant
    scene = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    experiment = from_mapping(
        ValidationConfig, snakemake.params.experiment, "validation.experiment"
    )
    offset = float(snakemake.wildcards.offset)
    trace = run_insertion(PegInHoleScene(scene), offset, experiment)
    record = job_provenance(
        snakemake,
        "validation_run",
        point={"variant": variant, "offset_m": offset},
        config={
            "scene": snakemake.params.scene,
            "validation": {"variant": variant, "experiment": snakemake.params.experiment},
        },
        simulator=scene.simulator_settings(),
    )
    kept = stored_samples(trace, scene, offset, experiment)
    write_trace(trace, snakemake.output.trace, record, kept, STORED_COLUMNS)
    record_insertion(
        snakemake.output.recording,
        trace,
        scene,
        record["run_id"],
        {**record, "recordings": snakemake.params.recordings},
        from_mapping(RecordingsConfig, snakemake.params.recordings, "recordings").for_validation(),
    )
    print(
        f"{trace.status} {trace.reason}; {len(trace)} steps ({len(kept)} stored), "
        f"deepest {trace.insertion_depth_m.max():.5f} m"
    )
