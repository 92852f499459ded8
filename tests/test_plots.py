"""Figures: deterministic bytes with provenance inside, and aggregates that survive failures."""

import hashlib

import numpy as np
import pandas as pd
from PIL import Image

from pih import plots
from pih.provenance import record


def _saved(tmp_path, name):
    fig = plots.cost_band_figure(
        pd.DataFrame(
            {"method": "a", "iteration": [1, 2], "mean": [2.0, 1.0], "std": 0.1, "count": 3}
        )
    )
    png, pdf = tmp_path / f"{name}.png", tmp_path / f"{name}.pdf"
    plots.save(fig, png, pdf, provenance=record("fig", point={"k": 1}))
    return png, pdf


def test_figures_carry_stable_provenance_and_rerun_byte_identical(tmp_path):
    first, second = _saved(tmp_path, "a"), _saved(tmp_path, "b")
    for a, b in zip(first, second):
        assert hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest()
    text = Image.open(first[0]).text["pih.provenance"]
    assert '"run_id":"fig/k=1"' in text and "created_utc" not in text
    assert b"fig/k=1" in first[1].read_bytes()


def test_cost_bands_of_runs_where_everything_diverged_still_plot(tmp_path):
    bands = pd.DataFrame(
        {"method": "a", "iteration": [1, 2], "mean": np.nan, "std": np.nan, "count": 0}
    )
    plots.save(plots.cost_band_figure(bands), tmp_path / "all_diverged.png")
    assert (tmp_path / "all_diverged.png").stat().st_size > 1000
