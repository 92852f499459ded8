"""A recorded run's learned policy deployed again (``pih redeploy``, the workflow's redeploy
rules): from starts offset by N(0, σ²) in x and y, on the run's scene or under a model error.
Above both the planner and the run record, which it joins."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from pih.config import to_mapping
from pih.planning.planner import Planner
from pih.planning.run_record import RecordedRun
from pih.scene.config import SceneConfig
from pih.scene.overrides import scene_with


def deployment_scene(run: RecordedRun, model_error: Mapping[str, Any]) -> SceneConfig:
    """The real scene of a redeployment: the run's, with ``model_error``'s dotted scene settings
    (a ConfigError names ``robustness.model_error``)."""
    if not model_error:
        return run.scene
    return scene_with(to_mapping(run.scene), model_error, "robustness.model_error")


def redeploy(
    run: RecordedRun,
    start_std_m: float,
    workers: int = 1,
    model_error: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """The run's deployment phases deployed again from starts offset by N(0, start_std_m²): the
    deployment it would have made with ``planner.deploy_start_std_m = start_std_m``
    (:meth:`pih.planning.planner.Planner.redeploy`), on the run's scene or, with ``model_error`` (dotted
    scene settings), on :func:`deployment_scene`."""
    config = run.redeployment_config(start_std_m)
    scene = deployment_scene(run, model_error or {})
    planner = Planner.from_configs(scene, config, run.record["seed_key"])
    recorded_hole = np.array([run.scene.hole.x_m, run.scene.hole.y_m, 0.0])
    return planner.redeploy(
        run.rollouts, run.record["result"]["cost_divisors"], workers, recorded_hole
    )
