"""``pih scene``: a study's planar scene drawn (README's picture)."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line, missing_parent


def scene(configfiles: list[Path], output: Path) -> int:
    """Draw the scene of the study ``configfiles`` give (the peg at its start and inserted, the
    hole, the spring and the robot frame) into ``output``, its provenance the scene's config."""
    from pih.config import ConfigError, from_mapping
    from pih.records.provenance import record
    from pih.reporting import plots
    from pih.scene.config import SceneConfig
    from pih.study.config import load_config

    if missing_parent("scene", "--output", output):
        return 1
    try:
        config = load_config([str(f) for f in configfiles])
        drawn = from_mapping(SceneConfig, config["scene"])
        start = {k: config["planner"][k] for k in ("start_x_m", "start_height_m")}
    except (OSError, ConfigError, KeyError) as error:
        print(f"pih scene: {first_line(error)}", file=sys.stderr)
        return 1
    figure = plots.scene_figure(drawn, start["start_x_m"], start["start_height_m"])
    provenance = record("scene", config={"scene": config["scene"], "planner": start})
    plots.save(figure, output, provenance=provenance)
    print(output)
    return 0
