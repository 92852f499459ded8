"""What a redeployment file records of itself beside its rows: the provenance fields of a run's
policy deployed again, alike whether the workflow's redeploy job made it or a published run was
redeployed in place (:func:`pih.publishing.redeploy.redeploy_published`)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pih.config import to_mapping
from pih.planning.run_record import RecordedRun
from pih.study.redeployment import deployment_scene


def redeployment_fields(
    run: RecordedRun, start_std_m: float, model_error: Mapping[str, Any]
) -> dict[str, Any]:
    """:func:`pih.records.provenance.record`'s fields of ``run`` redeployed from starts offset by
    N(0, start_std_m²), on its scene or under ``model_error`` (``{}``, or its ``name`` and dotted
    scene ``settings``): the sweep point, seeds and seed key the run drew with, the real scene
    and the redeployment's planner config."""
    scene = deployment_scene(run, model_error.get("settings", {}))
    return {
        "point": run.record["sweep_point"],
        "seeds": run.record["seeds"],
        "config": {
            "scene": to_mapping(scene),
            "planner": to_mapping(run.redeployment_config(start_std_m)),
        },
        "simulator": scene.simulator_settings(),
        "extra": {"seed_key": run.record["seed_key"], "model_error": dict(model_error)},
    }
