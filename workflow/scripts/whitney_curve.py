"""Whitney's theoretical curve for one lateral offset (paper §2.3)."""

from pih import whitney
from pih.config import from_mapping
from pih.scene import SceneConfig
from pih.traces import write_table
from pih.validation import whitney_params
from pih.workflow import ValidationSection, job_provenance, logged

CURVE_COLUMNS = {
    "depth_m": ("m", "insertion depth l of the tip below the hole entrance"),
    "f_x_n": ("N", "lateral force, Whitney's sign (negative toward the error side)"),
    "f_z_n": ("N", "insertion force (downward push)"),
    "moment_nm": ("N*m", "support moment about the tip"),
    "theta_rad": ("rad", "peg tilt, positive toward the error side"),
    "u_m": ("m", "lateral position of the compliance centre"),
    "phase": ("", "contact phase"),
}

with logged(snakemake.log[0]):
    scene = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    section = from_mapping(ValidationSection, snakemake.params.validation, "validation")
    offset = float(snakemake.wildcards.offset)
    params = whitney_params(scene, offset)
    curve = whitney.curve(params, max_depth_m=scene.peg.length_m)
    record = job_provenance(
        snakemake,
        "whitney_curve",
        config={"scene": snakemake.params.scene},
        extra={"whitney": params.__dict__},
    )
    write_table(
        curve,
        snakemake.output.curve,
        record,
        CURVE_COLUMNS,
        extra_metadata={"phase_boundaries": whitney.phase_boundaries(params)},
    )
    print(f"offset {offset} m: {len(curve)} points, boundaries {whitney.phase_boundaries(params)}")
