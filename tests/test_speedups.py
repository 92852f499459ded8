"""The output-identical speed-ups (docs/simulation.md): a preloaded allocator and Drake's
unsampled output ports leave a contact-rich rollout's trajectory bit-identical."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from pih.records.provenance import allocator
from pih.workflow.jobs import preloaded_allocator

# One contact-rich rollout: the tip pressed down onto the chamfer 1 mm beside the axis and on into
# the hole (final pose and its hash printed as JSON).
ROLLOUT = """
import hashlib, json, sys
import numpy as np
from pih.records.provenance import allocator
from pih.scene.simulation import PegInHoleScene
from pih.scene.trace import RobotTrajectory
from pih.scene.config import SceneConfig
scene = PegInHoleScene(SceneConfig().replace(solver__sampled_output_ports=sys.argv[1] == "1"))
hole = scene.config.hole
t = np.arange(0.0, 1.5 + 1e-9, 0.01)
start = scene.peg_top_from_bottom([hole.x_m - 0.001, hole.top_y_m + 0.002, 0.02])
stop = scene.peg_top_from_bottom([hole.x_m, hole.y_m + 0.003, 0.0])
s = np.clip(t / 1.2, 0, 1)[:, None]
trace = scene.rollout(RobotTrajectory(t, start + s * (stop - start)))
print(json.dumps({"allocator": allocator(), "status": trace.status,
    "final": trace.q_peg_bottom[-1].tolist(),
    "sha": hashlib.sha256(trace.q_peg_bottom.tobytes()).hexdigest()}))
"""


def rollout(sampled: bool, preload: str = "") -> dict:
    env = {**os.environ, "LD_PRELOAD": preload}
    out = subprocess.run(
        [sys.executable, "-c", ROLLOUT, "1" if sampled else "0"],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_unsampled_ports_and_allocator_give_the_same_trajectory():
    reference = rollout(sampled=True)
    assert reference["status"] == "ok"
    assert reference["allocator"] == "glibc"
    unsampled = rollout(sampled=False)
    assert unsampled["sha"] == reference["sha"]
    preload = preloaded_allocator()
    if not preload:
        pytest.skip("neither tcmalloc nor jemalloc is installed")
    fast = rollout(sampled=False, preload=preload)
    assert fast["allocator"].startswith(os.path.basename(preload))
    assert fast["sha"] == reference["sha"]
    assert np.array_equal(fast["final"], reference["final"])


def test_this_process_reports_its_allocator():
    assert allocator() in {"glibc", "unknown"} or allocator().startswith(
        ("libtcmalloc", "libjemalloc")
    )
