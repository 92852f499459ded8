"""Every script under ``benchmarks/`` runs: each imports (fast), and each runs end to end at a
tiny setting and prints its machine-readable last line (slow: a few seconds each). A config or
library change that breaks a benchmark fails here, not when somebody next measures."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ["--configfile", "config/config.yaml", "config/smoke.yaml"]
TINY = {
    "rollout": (["--runs", "1", "--naive-runs", "1"], r"^converged_vs_2ms_baseline=\S+ step_ms="),
    "planner": (["--iterations", "1", *SMOKE], r"^speedup_vs_sap_0p5ms=\S+ verdict=(PASS|FAIL)$"),
    "solvers": (
        ["--iterations", "1", "--start-x-m", "-0.031", "--seed", "4", *SMOKE]
        + ["--variants", "hydroelastic", "point"],
        r"^point: \d+ ms per rollout; .* on the other side of the 1 mm test$",
    ),
    "step_convergence": (
        ["--rollouts", "1", "--set", "scene.solver.time_step_s=0.002"],
        r"^flips=\d of 1 vs_reference_ms=0\.0625 median_dp2_um=\S+ verdict=PARTIAL$",
    ),
}
"""Each benchmark's tiny setting and the pattern of its last line."""


def test_every_benchmark_script_has_a_tiny_setting_here():
    assert sorted(TINY) == sorted(p.stem for p in (ROOT / "benchmarks").glob("*.py"))


@pytest.mark.parametrize("name", sorted(TINY))
def test_every_benchmark_script_imports(name):
    """What a moved or renamed library module breaks: the script's imports."""
    spec = importlib.util.spec_from_file_location(
        f"bench_{name}", ROOT / "benchmarks" / f"{name}.py"
    )
    assert spec is not None and spec.loader is not None
    spec.loader.exec_module(importlib.util.module_from_spec(spec))


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(TINY))
def test_every_benchmark_script_runs_at_a_tiny_setting(name, tmp_path):
    arguments, last_line = TINY[name]
    check = tmp_path / "step_check.parquet"
    if name == "step_convergence":
        arguments = [*arguments, "--output", str(check)]
    result = subprocess.run(
        [sys.executable, f"benchmarks/{name}.py", *arguments],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "OMP_NUM_THREADS": "1"},
    )
    assert result.returncode == 0, result.stderr[-3000:]
    assert re.search(last_line, result.stdout.strip().splitlines()[-1]), result.stdout[-2000:]
    if name == "step_convergence":
        # The verdict as data: every replayed rollout beside the reference, the verdict with it.
        from pih.records.outputs import read_provenance

        table = pd.read_parquet(check)
        # One trial per point (the paper-scale study's 11 starts), start source and method.
        assert table["part"].value_counts().to_dict() == {"deployments": 11 * 2 * 3, "set": 1}
        assert (table["flipped"] == (table["inserted"] != table["reference_inserted"])).all()
        provenance = read_provenance(check)
        assert provenance["verdict"] == result.stdout.strip().splitlines()[-1]
        assert provenance["config"]["scene"]["solver"]["time_step_s"] == 0.002
        assert provenance["machine"]["cpu"]
