"""Whitney's theoretical curve for one lateral offset (paper §2.3), to the peg's length."""

from pih.config import from_mapping
from pih.records.outputs import write_table
from pih.scene.config import SceneConfig
from pih.validation.experiment import whitney_params
from pih.whitney import theory as whitney
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    scene = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    offset = float(snakemake.wildcards.offset)
    params = whitney_params(scene, offset)
    curve = whitney.curve(params, max_depth_m=scene.peg.length_m)
    bounds = whitney.phase_boundaries(params)
    record = job_provenance(
        snakemake,
        "whitney_curve",
        point={"offset_m": offset},
        config={"scene": snakemake.params.scene},
        extra={"whitney": vars(params)},
    )
    write_table(
        curve,
        snakemake.output.curve,
        record,
        whitney.CURVE_COLUMNS,
        extra_metadata={"phase_boundaries": bounds},
    )
    print(f"{len(curve)} points; phase boundaries {bounds}")
