"""Bad input and faults (issue 34): every config error is one line naming the file or the
dotted key (and the variant), before any job; sweeps and counts are bounded; no signal leaves a
file among the outputs; every CLI error is one line and exit status 1.

The fast tests call the library and the CLI in-process or in a small subprocess; the `slow` ones
run `snakemake -n` on a copy of the workflow.
"""

from __future__ import annotations

import copy
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import test_cli
import yaml

import pih
from pih.__main__ import main
from pih.config import ConfigError
from pih.records.outputs import TEMPORARY_DIR, atomic_path, write_text, write_with
from pih.study.config import (
    MAX_SWEEP_POINTS,
    check_study,
    load_config_file,
    stop_on_config_error,
    study_points,
    sweep_points,
)
from pih.study.schema import check_schema

ROOT = Path(__file__).resolve().parents[1]
SMOKE = yaml.safe_load((ROOT / "config" / "smoke.yaml").read_text())


def smoke() -> dict:
    """The smoke study's config (all sections), a fresh copy to break."""
    return copy.deepcopy(SMOKE)


def one_line(error: BaseException | str) -> str:
    text = str(error)
    assert "\n" not in text.strip(), f"not one line: {text!r}"
    return text


# ---------------------------------------------------------------------------------------------
# Config errors: one line naming the dotted key (JSON schema, before Snakemake's validate)


@pytest.mark.parametrize(
    ("edit", "starts"),
    [
        (lambda c: c["planner"].update(iterations="ten"), "planner.iterations: 'ten'"),
        (lambda c: c.update(plannr={"iterations": 3}), "plannr: unknown key"),
        (lambda c: c["planner"]["dmp"].update(n_basiss=3), "planner.dmp.n_basiss: unknown key"),
        (lambda c: c["planner"].pop("dmp"), "planner.dmp: missing"),
        (lambda c: c.pop("robustness"), "robustness: missing"),
        (lambda c: c.update(planner=[1, 2]), "planner: [1, 2] is not allowed; expected a mapping"),
        (lambda c: c["planner"].update(goal=3), "planner.goal: 3 is not allowed; expected one"),
        (lambda c: c["scene"]["spring"].update(stiffness=[1, 2, "a"]), "scene.spring.stiffness[2]"),
        (lambda c: c["planner"]["dmp"].update(min_amplitude=[1]), "planner.dmp.min_amplitude"),
        (lambda c: c.update(sweep={}), "sweep: empty"),
        (lambda c: c.update(sweep={"planner.seed": []}), "sweep.planner.seed: [] has 0 item"),
        (lambda c: c.update(sweep={"planner.seed": 3}), "sweep.planner.seed: 3 is not allowed"),
        (lambda c: c.update(sweep={"plannr.seed": [1]}), "sweep.plannr.seed: not allowed"),
        (lambda c: c.update(variants={"v1": {"plannr.x": 1}}), "variants.v1.plannr.x: not allowed"),
        (
            lambda c: c.update(variants={"v1": {"planner.seed": [1]}}),
            "variants.v1.planner.seed: [1] is not allowed",
        ),
        (lambda c: c.update(variants=[1]), "variants: [1] is not allowed; expected a mapping"),
        (
            lambda c: c["validation"]["variants"].update(x={"solver.x": [1]}),
            "validation.variants.x.solver.x",
        ),
        (
            lambda c: c["scene"]["solver"].update(discrete_contact_approximation="tamsi"),
            (
                "scene.solver.discrete_contact_approximation: 'tamsi' is no longer available: Drake "
                "1.57 removed TAMSI"
            ),
        ),
        (lambda c: c.update(figure_point=None), "figure_point: None is not allowed"),
        (lambda c: c.update(max_sweep_points=0), "max_sweep_points: 0 is not allowed"),
        (lambda c: c.update(max_sweep_points="many"), "max_sweep_points: 'many'"),
        (lambda c: c["planner"].update(seed=True), "planner.seed: True is not allowed"),
        (lambda c: c["scene"].update(peg=None), "scene.peg: None is not allowed"),
    ],
)
def test_a_schema_error_is_one_line_naming_the_dotted_key(edit, starts):
    config = smoke()
    edit(config)
    with pytest.raises(ConfigError) as raised:
        check_schema(config)
    assert one_line(raised.value).startswith(starts), str(raised.value)
    # The committed schema file (what the workflow checks against) says the same.
    with pytest.raises(ConfigError, match="^" + starts.replace("[", r"\[").replace("(", r"\(")):
        check_schema(config, str(ROOT / "workflow" / "schemas" / "config.schema.json"))


def test_the_shipped_configs_pass_the_schema_check():
    base = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    check_schema(base)
    check_schema(smoke())


def test_a_long_value_is_shortened_in_the_message():
    config = smoke()
    config["planner"]["iterations"] = list(range(1000))
    with pytest.raises(ConfigError) as raised:
        check_schema(config)
    assert len(one_line(raised.value)) < 200


# ---------------------------------------------------------------------------------------------
# Config files: one line naming the file


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("", "empty; expected a mapping"),
        ("# only a comment\n", "empty; expected a mapping"),
        ("- a\n- b\n", "a list, not a mapping"),
        ("just text\n", "a string, not a mapping"),
        ("42\n", "a number, not a mapping"),
        ("true\n", "a boolean, not a mapping"),
        ("planner:\n\titerations: 3\n", "line 2, column 1: not valid YAML"),
        ("{{{{ garbage ::: [\n", "not valid YAML"),
        ("planner: {iterations: 3\n", "not valid YAML"),
        ("a: 1\na: 2\n", "line 2: key 'a' appears twice"),
        ("? [a, b]\n: 1\n", "line 1: a key is a list"),
        ("a: !!python/object/apply:os.system ['id']\n", "not valid YAML"),
        ("a: 1\n\x00\n", "not valid YAML"),
    ],
)
def test_a_bad_config_file_is_one_line_naming_the_file(tmp_path, content, message):
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    with pytest.raises(ConfigError) as raised:
        load_config_file(str(path))
    text = one_line(raised.value)
    assert text.startswith(str(path)) and message in text, text


def test_a_binary_or_missing_config_file_is_one_line_naming_it(tmp_path):
    binary = tmp_path / "bin.yaml"
    binary.write_bytes(b"\xff\xfe\x00garbage\x81")
    with pytest.raises(ConfigError, match=f"^{binary}: not valid YAML"):
        load_config_file(str(binary))
    with pytest.raises(ConfigError, match=f"^{tmp_path / 'nope.yaml'}: cannot read it"):
        load_config_file(str(tmp_path / "nope.yaml"))
    with pytest.raises(ConfigError, match=f"^{tmp_path}: cannot read it"):
        load_config_file(str(tmp_path))


def test_stop_on_config_error_prints_one_line_and_exits_1(capsys):
    with pytest.raises(SystemExit) as exited, stop_on_config_error():
        raise ConfigError("planner.iterations: 0 is not allowed;\n expected an integer >= 1")
    assert exited.value.code == 1
    err = capsys.readouterr().err
    assert err == "config error: planner.iterations: 0 is not allowed; expected an integer >= 1\n"
    with stop_on_config_error():  # anything else passes through
        pass


# ---------------------------------------------------------------------------------------------
# Variants: names checked like validation's, errors name the variant


@pytest.mark.parametrize("name", ["Fast/v1", "v~1", "Fast v1", "../../x", "V1", "v-1", "", "é"])
def test_a_planning_variant_name_that_is_not_a_directory_name_stops(name):
    config = smoke()
    config["variants"] = {"ok": {}, name: {"planner.iterations": 3}}
    config["sweep"] = {"variant": ["ok", name]}
    with pytest.raises(ConfigError) as raised:
        study_points(config)
    assert one_line(raised.value).startswith(f"variants.{name}: {name!r} is not allowed")


def test_a_typo_inside_a_variant_names_the_variant():
    config = smoke()
    config["variants"] = {"v1": {"planner.iteratons": 3}}
    config["sweep"] = {"variant": ["v1"]}
    with pytest.raises(ConfigError) as raised:
        check_study(config, study_points(config))
    text = one_line(raised.value)
    assert text.startswith("variants.v1.planner.iteratons: no config key 'iteratons' in planner")
    assert "sweep key" not in text


def test_a_variant_setting_a_value_out_of_range_names_the_variant():
    config = smoke()
    config["variants"] = {"v1": {"planner.iterations": 0}}
    config["sweep"] = {"variant": ["v1"]}
    with pytest.raises(ConfigError, match=r"^variants\.v1: planner\.iterations: 0"):
        check_study(config, study_points(config))


def test_a_sweep_typo_names_the_sweep_key():
    config = smoke()
    config["sweep"]["planner.no_such_key"] = [1, 2]
    with pytest.raises(ConfigError, match=r"^sweep\.planner\.no_such_key: no config key"):
        check_study(config, study_points(config))
    config = smoke()
    config["sweep"] = {"planner.seed.x": [1]}
    with pytest.raises(ConfigError, match=r"^sweep\.planner\.seed\.x: 'planner\.seed' is not a"):
        check_study(config, study_points(config))


def test_a_scene_error_is_named_as_the_scene_not_the_validation_overrides():
    config = smoke()
    config["scene"]["material"]["friction"] = -0.1
    with pytest.raises(ConfigError) as raised:
        check_study(config, study_points(config))
    assert one_line(raised.value).startswith("scene.material.friction: -0.1 is not allowed")
    # An error the overrides make is still theirs.
    config = smoke()
    config["validation"]["scene_overrides"] = {"material.friction": -0.1}
    with pytest.raises(
        ConfigError, match=r"^validation\.scene_overrides\.material\.friction: -0\.1 is not"
    ):
        check_study(config, study_points(config))


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        (
            {"solver.stiction": 1e-5},
            r"^validation\.scene_overrides\.solver\.stiction: no config key",
        ),
        (
            {"solver": {"stiction_tolerance_m_per_s": 1e-5}},
            (
                r"^validation\.scene_overrides: a nested mapping; write each setting as a dotted "
                r"path, e.g. solver\.stiction_tolerance_m_per_s: 1e-05$"
            ),
        ),
    ],
)
def test_a_bad_scene_override_is_named_by_the_path_the_user_wrote(overrides, message):
    """A path that is no scene key is named as the user wrote it, under the overrides (no
    ``scene.`` the user did not write); a section given as a nested mapping is shown the dotted
    path to write instead."""
    config = smoke()
    config["validation"]["scene_overrides"] = overrides
    with pytest.raises(ConfigError, match=message):
        check_study(config, study_points(config))


def test_a_swept_section_is_shown_the_dotted_path_to_sweep_instead():
    """A sweep level that is a mapping would replace a whole config section."""
    config = smoke()
    config["sweep"]["planner.outer"] = [{"rule": "paper"}]
    with pytest.raises(ConfigError) as raised:
        check_study(config, study_points(config))
    assert one_line(raised.value).startswith(
        "sweep.planner.outer: a nested mapping; write each setting as a dotted path, "
        "e.g. planner.outer.rule: 'paper'"
    )


def test_a_swept_value_out_of_range_names_the_sweep_point():
    config = smoke()
    config["sweep"]["planner.iterations"] = [3, 0]
    with pytest.raises(ConfigError) as raised:
        check_study(config, study_points(config))
    text = one_line(raised.value)
    assert text.startswith("planner.iterations: 0") and "planner.iterations=0" in text
    config = smoke()
    config["planner"]["iterations"] = 0  # the config's own value: no sweep point to blame
    with pytest.raises(ConfigError) as raised:
        check_study(config, study_points(config))
    assert "at sweep point" not in str(raised.value)


# ---------------------------------------------------------------------------------------------
# Bounded sweeps and counts


def test_a_million_point_sweep_stops_with_its_count_before_any_point_is_built(monkeypatch):
    import pih.study.config

    def no_product(*args):
        raise AssertionError("the points were being built")

    monkeypatch.setattr(pih.study.config.itertools, "product", no_product)
    config = smoke()
    config["sweep"] = {f"planner.k{i}": list(range(10)) for i in range(6)}
    start = time.perf_counter()
    with pytest.raises(ConfigError) as raised:
        study_points(config)
    assert time.perf_counter() - start < 0.1
    text = one_line(raised.value)
    assert text.startswith("sweep: 1,000,000 points") and "max_sweep_points = 10,000" in text


def test_the_sweep_limit_is_a_config_key(monkeypatch):
    config = smoke()
    config["sweep"] = {"planner.seed": list(range(30)), "planner.start_x_m": [-0.04, -0.03]}
    config["max_sweep_points"] = 50
    with pytest.raises(ConfigError, match="sweep: 60 points .* exceed max_sweep_points = 50"):
        study_points(config)
    config["max_sweep_points"] = 60
    assert len(study_points(config)) == 60
    check_schema(config)  # a valid key
    assert MAX_SWEEP_POINTS == 10_000
    assert len(sweep_points({"planner.seed": list(range(MAX_SWEEP_POINTS))})) == MAX_SWEEP_POINTS
    with pytest.raises(ConfigError, match="10,001 points"):
        sweep_points({"planner.seed": list(range(MAX_SWEEP_POINTS + 1))})


@pytest.mark.parametrize(
    ("path", "value"),
    [
        ("planner.iterations", 100_000_000_000),
        ("planner.deploy_trials", 10**9),
        ("planner.optimizer.population_size", 10**7),
        ("planner.dmp.n_basis", 10**6),
        ("planner.dmp.duration_s", 1e9),
        ("planner.settle_s", 86400.0),
        ("planner.convergence_window", 10**8),
        ("scene.hole.fillet_facets", 10**8),
    ],
)
def test_counts_and_durations_are_bounded(path, value):
    config = smoke()
    node = config
    *parents, leaf = path.split(".")
    for key in parents:
        node = node[key]
    node[leaf] = value
    with pytest.raises(ConfigError) as raised:
        check_study(config, study_points(config))
    assert one_line(raised.value).startswith(f"{path}: {value!r} is not allowed; expected")


def test_a_bounded_count_set_by_a_variant_names_it():
    config = smoke()
    config["variants"] = {"long": {"planner.iterations": 100_000}}
    config["sweep"] = {"variant": ["long"]}
    with pytest.raises(ConfigError, match=r"^variants\.long: planner\.iterations: 100000"):
        check_study(config, study_points(config))


# ---------------------------------------------------------------------------------------------
# Outputs: temporary files outside the output tree; no signal leaves one among the outputs

WRITER = """
import sys, time
from pathlib import Path
from pih.records.outputs import write_text, write_with

write_text("results/done.md", "a finished output\\n")

def slow(target):
    target.write_bytes(b"partial " * 1000)
    print("writing", flush=True)
    time.sleep(60)

write_with("results/run/partial.rrd", slow)
"""

RRD_WRITER = """
import sys
import numpy as np
from pih.records.outputs import write_text
from pih.records.recordings import record_insertion
from pih.scene.trace import Trace
from pih.scene.config import SceneConfig

write_text("results/done.md", "a finished output\\n")
n = int(sys.argv[1])
q = np.zeros((n, 3))
trace = Trace(
    time_s=np.arange(n) * 0.02, q_robot=q, q_peg=q, q_peg_top=q, q_peg_bottom=q,
    contact_force=np.zeros((n, 3)), contact_patches=np.ones(n, dtype=np.int64),
    spring_force=np.zeros((n, 3)), spring_energy_j=np.zeros(n),
    insertion_depth_m=np.zeros(n), penetration_m=np.zeros(n),
)
record_insertion("results/run/big.rrd", trace, SceneConfig(), "run", {"run_id": "run"})
"""


def files_under(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file()}


def start_writer(work: Path, source: str, *args: str, hangup: str = "SIG_DFL") -> subprocess.Popen:
    """The writer starts with SIGHUP at ``hangup`` and SIGTERM at its default, whatever this
    process inherited (a test run under ``nohup`` ignores SIGHUP, and its children would)."""
    signals = f"import signal\nsignal.signal(signal.SIGHUP, signal.{hangup})\n"
    signals += "signal.signal(signal.SIGTERM, signal.SIG_DFL)\n"
    (work / "writer.py").write_text(signals + textwrap.dedent(source))
    return subprocess.Popen(
        [sys.executable, "writer.py", *args],
        cwd=work,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(Path(pih.__file__).parents[1])},  # this pih
    )


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGHUP])
def test_a_terminated_write_leaves_no_file_anywhere(tmp_path, number):
    writer = start_writer(tmp_path, WRITER)
    assert writer.stdout.readline() == "writing\n"
    assert any(n.endswith(".rrd") for n in files_under(tmp_path / TEMPORARY_DIR))
    assert files_under(tmp_path / "results") == {"done.md"}  # the partial file is outside
    writer.send_signal(number)
    assert writer.wait(timeout=30) == -number  # ended by the signal, as without the handler
    assert files_under(tmp_path / "results") == {"done.md"}
    assert files_under(tmp_path / TEMPORARY_DIR) == set()


def test_an_ignored_hangup_stays_ignored_while_writing(tmp_path):
    """Under ``nohup`` a SIGHUP does not end the writer (no handler replaces SIG_IGN); a
    SIGTERM then still removes its temporary file."""
    writer = start_writer(tmp_path, WRITER, hangup="SIG_IGN")
    assert writer.stdout.readline() == "writing\n"
    writer.send_signal(signal.SIGHUP)
    with pytest.raises(subprocess.TimeoutExpired):
        writer.wait(timeout=2)
    assert any(n.endswith(".rrd") for n in files_under(tmp_path / TEMPORARY_DIR))
    writer.send_signal(signal.SIGTERM)
    assert writer.wait(timeout=30) == -signal.SIGTERM
    assert files_under(tmp_path / TEMPORARY_DIR) == set()


def test_a_killed_write_leaves_its_file_outside_the_results_and_the_next_write_removes_it(
    tmp_path, monkeypatch
):
    writer = start_writer(tmp_path, WRITER)
    assert writer.stdout.readline() == "writing\n"
    writer.kill()
    assert writer.wait(timeout=30) == -signal.SIGKILL
    assert files_under(tmp_path / "results") == {"done.md"}
    left = files_under(tmp_path / TEMPORARY_DIR)
    assert len(left) == 2 and all(n.startswith(".partial.rrd.") for n in left), left
    monkeypatch.chdir(tmp_path)
    write_text("results/other.md", "next\n")
    assert files_under(tmp_path / TEMPORARY_DIR) == set()
    assert files_under(tmp_path / "results") == {"done.md", "other.md"}


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGKILL])
def test_a_recording_killed_mid_write_leaves_nothing_in_results(tmp_path, monkeypatch, number):
    """A real Rerun recording (tens of thousands of logged steps), killed once its temporary
    .rrd exists: nothing in results/ but finished outputs; SIGTERM removes the temporary files,
    and after SIGKILL the next write does."""
    writer = start_writer(tmp_path, RRD_WRITER, "200000")
    temporary = tmp_path / TEMPORARY_DIR
    deadline = time.time() + 60
    while time.time() < deadline and not any(
        n.endswith(".rrd") for n in (files_under(temporary) if temporary.is_dir() else ())
    ):
        assert writer.poll() is None, "the writer ended before the recording was written"
        time.sleep(0.01)
    time.sleep(0.3)  # well into the recording
    assert writer.poll() is None
    writer.send_signal(number)
    assert writer.wait(timeout=60) == -number
    assert files_under(tmp_path / "results") == {"done.md"}
    if number == signal.SIGKILL:
        assert files_under(temporary), "expected SIGKILL's leftovers (outside results/)"
        monkeypatch.chdir(tmp_path)
        write_text("results/next.md", "x\n")
    assert files_under(temporary) == set()


def test_a_write_outside_the_working_directory_cleans_up_beside_the_output(tmp_path, monkeypatch):
    from pih.records.outputs import _HOST

    work, out = tmp_path / "work", tmp_path / "elsewhere"
    work.mkdir()
    monkeypatch.chdir(work)
    with atomic_path(out / "x.parquet") as tmp:
        assert tmp.parent == out and tmp.name.startswith(f".x.parquet.{_HOST}@{os.getpid()}.")
    assert not (work / TEMPORARY_DIR).exists() and files_under(out) == {"x.parquet"}
    # A leftover of a dead process on this host is removed by the next write there; another
    # host's, a live process's and a user's own hidden files are left alone.
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        text=True,
        capture_output=True,
        check=True,
    ).stdout.strip()
    stale = out / f".y.parquet.{_HOST}@{dead}.abc_12.tmp"
    kept = [
        out / ".z.parquet.otherhost@1.abc.tmp",
        out / f".z.parquet.{_HOST}@{os.getppid()}.abc.tmp",
        out / ".hidden",
    ]
    for path in [stale, *kept]:
        path.write_text("partial")
    write_text(out / "y.md", "y\n")
    assert not stale.exists() and all(path.exists() for path in kept)


def test_a_failed_write_leaves_no_temporary_file_and_restores_the_signal_handler(
    tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    before = signal.getsignal(signal.SIGTERM)

    def fail(target):
        target.write_text("partial")
        assert signal.getsignal(signal.SIGTERM) is not before  # cleanup installed meanwhile
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        write_with("results/a.png", fail)
    assert signal.getsignal(signal.SIGTERM) is before
    assert files_under(tmp_path) == set()


def test_a_handler_already_installed_is_left_alone(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    calls = []

    def own(number, frame):
        calls.append(number)

    previous = signal.signal(signal.SIGTERM, own)
    try:
        with atomic_path("results/x.md") as tmp:
            tmp.write_text("x")
            assert signal.getsignal(signal.SIGTERM) is own
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.01)
        assert calls == [signal.SIGTERM] and (tmp_path / "results" / "x.md").exists()
    finally:
        signal.signal(signal.SIGTERM, previous)


# ---------------------------------------------------------------------------------------------
# The command line: one line on stderr, exit status 1


def record_without_run_id(path: Path) -> Path:
    table = pa.table({"a": [1]}).replace_schema_metadata(
        {b"pih.provenance": json.dumps({"step": "x"}).encode()}
    )
    pq.write_table(table, path)
    return path


def assert_one_line_error(capsys, status: int, *expected: str) -> str:
    assert status == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for text in expected:
        assert text in err, err
    return err


def test_show_and_provenance_of_a_record_without_run_id(tmp_path, capsys):
    path = record_without_run_id(tmp_path / "r.parquet")
    status = main(["show", str(path)])  # prints what it has, or one line
    err = capsys.readouterr().err
    assert "Traceback" not in err and (status == 0 or len(err.strip().splitlines()) == 1)
    assert_one_line_error(
        capsys, main(["provenance", str(path), "--key", "run_id"]), "no key 'run_id'"
    )
    assert main(["provenance", str(path)]) == 0
    assert '"step": "x"' in capsys.readouterr().out


@pytest.mark.parametrize(
    ("error", "line"),
    [
        (KeyError("run_id"), "pih show: missing key 'run_id' (KeyError)"),
        (FileExistsError(17, "File exists", "out"), "pih show: out: File exists"),
        (RuntimeError("boom\nsecond line"), "pih show: boom (RuntimeError)"),
    ],
)
def test_an_unexpected_error_is_one_line_unless_its_traceback_is_asked_for(
    tmp_path, capsys, monkeypatch, error, line
):
    import pih.cli.show

    def fail(*args):
        raise error

    monkeypatch.setattr(pih.cli.show, "show", fail)
    assert main(["show", str(tmp_path)]) == 1
    assert capsys.readouterr().err == line + "\n"
    monkeypatch.setenv("PIH_TRACEBACK", "1")
    with pytest.raises(type(error)):
        main(["show", str(tmp_path)])


def test_aggregate_into_an_existing_file_is_refused(tmp_path, capsys):
    target = tmp_path / "afile"
    target.write_text("keep")
    status = main(["aggregate", str(tmp_path), "--output-dir", str(target)])
    assert_one_line_error(capsys, status, f"--output-dir {target}: not a directory")
    assert target.read_text() == "keep"


@pytest.mark.parametrize(
    "command",
    [
        ["redeploy", "RUN", "--start-std-m", "0.001", "--output", "MISSING/x.parquet"],
        ["plot", "RUN", "--output", "MISSING/x.png"],
    ],
)
def test_an_output_in_a_missing_directory_is_refused_and_not_created(tmp_path, capsys, command):
    missing = tmp_path / "nonexistent_dir"
    argv = [a.replace("MISSING", str(missing)).replace("RUN", str(tmp_path)) for a in command]
    assert_one_line_error(capsys, main(argv), f"no directory {missing}")
    assert not missing.exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["aggregate", "NOSUCH", "--output-dir", "OUT"],
        ["redeploy", "NOSUCH", "--start-std-m", "0.001"],
        ["plot", "NOSUCH"],
        ["show", "NOSUCH"],
        ["provenance", "NOSUCH"],
        ["redeploy", "NOSUCH", "--start-std-m", "-1"],
    ],
)
def test_a_missing_input_is_one_line(tmp_path, capsys, argv):
    argv = [
        a.replace("NOSUCH", str(tmp_path / "nosuch")).replace("OUT", str(tmp_path / "o"))
        for a in argv
    ]
    assert_one_line_error(capsys, main(argv), "nosuch")


def test_an_unknown_reference_variant_is_refused_naming_the_known_ones(
    tmp_path, capsys, planning_run
):
    write_study_run = test_cli.write_study_run
    for goal in ("sensed_hole", "explored_argmin"):
        write_study_run(tmp_path, planning_run, "a", goal=goal, variant=("paper", {}))
    tilt = ("tilt", {"planner.outer.goal_tilt": "sensed"})
    write_study_run(
        tmp_path,
        planning_run,
        "b",
        goal="explored_argmin",
        variant=tilt,
        outer={"goal_tilt": "sensed"},
    )
    studies = [str(tmp_path / s / "results") for s in "ab"]
    out = tmp_path / "pooled"
    status = main(
        ["aggregate", *studies, "--output-dir", str(out), "--reference-variant", "nosuch"]
    )
    assert_one_line_error(capsys, status, "'nosuch' is not a variant", "['paper', 'tilt']")
    assert not out.exists()
    assert (
        main(["aggregate", *studies, "--output-dir", str(out), "--reference-variant", "paper"]) == 0
    )
    # Runs that sweep no variant have no reference to compare with.
    capsys.readouterr()
    plain = tmp_path / "plain"
    write_study_run(plain, planning_run, "c", goal="explored_argmin")
    status = main(["aggregate", str(plain), "--output-dir", str(out), "--reference-variant", "x"])
    assert_one_line_error(capsys, status, "they sweep no variant")


planning_run = test_cli.planning_run  # the same fixture: a two-iteration planning run


@pytest.fixture
def workflow_copy(tmp_path, monkeypatch):
    from test_workflow import copy_workflow

    (tmp_path / "work").mkdir()
    work = copy_workflow(tmp_path / "work")
    monkeypatch.chdir(work)
    return work


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "nope.yaml: cannot read it (No such file or directory)"),
        ("", "bad.yaml: empty"),
        ("- a\n- b\n", "bad.yaml: a list, not a mapping"),
        ("{{{{ garbage ::: [\n", "bad.yaml, line 2, column 1: not valid YAML"),
        ("planner:\n\titerations: 3\n", "bad.yaml, line 2, column 1: not valid YAML"),
    ],
)
def test_job_with_a_bad_config_file_is_one_line(workflow_copy, capsys, content, message):
    name = "nope.yaml" if content is None else "bad.yaml"
    if content is not None:
        (workflow_copy / name).write_text(content)
    target = "results/whitney/offset_m~0.001.parquet"
    status = main(["job", target, "--configfile", name])
    assert_one_line_error(capsys, status, f"pih job: {message}")


def test_job_outside_the_workflow_directory_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status = main(["job", "results/whitney/offset_m~0.001.parquet"])
    assert_one_line_error(capsys, status, "pih job: no Snakefile in")


@pytest.mark.slow
def test_job_with_inputs_missing_is_one_line_and_quiet_about_config(workflow_copy, capfd):
    status = main(["job", "results/validation/comparison.parquet"])
    assert status == 1
    out, err = capfd.readouterr()
    assert "is extended by additional config" not in out + err
    assert err.count("\n") == 1 and "input(s) missing" in err and "make them first" in err


@pytest.mark.slow
def test_job_with_a_config_error_is_one_line(workflow_copy, capfd):
    (workflow_copy / "bad.yaml").write_text("planner:\n  iterations: ten\n")
    with pytest.raises(SystemExit) as exited:
        main(["job", "results/whitney/offset_m~0.001.parquet", "--configfile", "bad.yaml"])
    assert exited.value.code == 1
    err = capfd.readouterr().err
    assert "config error: planner.iterations: 'ten' is not allowed" in err
    assert "Traceback" not in err and 'File "' not in err


# ---------------------------------------------------------------------------------------------
# The workflow: `snakemake -n` stops before any job with one line and no stack frames


def dry_run(work: Path, config_text: str | None = None, *args: str):
    from test_workflow import snakemake

    if config_text is not None:
        (work / "bad.yaml").write_text(config_text)
        args = ("--configfile", "bad.yaml", *args)
    return snakemake(work, "-n", *args, check=False)


def config_lines(result) -> list[str]:
    """The output lines that are not Snakemake's own notes about profiles and config files."""
    notes = ("Using workflow specific profile", "Config file config/config.yaml is extended")
    lines = (result.stdout + result.stderr).splitlines()
    return [line for line in lines if not line.startswith(notes)]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> Path:
    from test_workflow import copy_workflow

    return copy_workflow(tmp_path_factory.mktemp("bad_input"))


BIG_SWEEP = yaml.safe_dump(
    {
        "sweep": {
            f"planner.{k}": [0.001 * i for i in range(1, 11)]
            for k in (
                "start_x_m",
                "start_height_m",
                "settle_s",
                "success_tolerance_m",
                "convergence_tolerance",
                "deploy_start_std_m",
            )
        },
        "figure_point": {},
    }
)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("planner:\n  iterations: ten\n", "config error: planner.iterations: 'ten' is not"),
        ("plannr:\n  iterations: 3\n", "config error: plannr: unknown key"),
        (
            "sweep: {variant: [v1]}\nvariants: {v1: {planner.iteratons: 3}}\nfigure_point: {}\n",
            "config error: variants.v1.planner.iteratons: no config key 'iteratons'",
        ),
        ("scene: {material: {friction: -0.1}}\n", "config error: scene.material.friction: -0.1"),
        ("recordings: {series_rate_hz: 0}\n", "config error: recordings.series_rate_hz: 0"),
        (
            "sweep: {variant: [Fast/v1]}\nvariants: {Fast/v1: {}}\nfigure_point: {}\n",
            "config error: variants.Fast/v1: 'Fast/v1' is not allowed as a variant name",
        ),
        (
            "sweep: {variant: ['../../x']}\nvariants: {'../../x': {}}\nfigure_point: {}\n",
            "config error: variants.../../x:",
        ),
        ("planner: {iterations: 100000000000}\n", "config error: planner.iterations: 100000000000"),
        (BIG_SWEEP, "config error: sweep: 1,000,000 points"),
        ("sweep: {planner.seed: [0, 0]}\n", "config error: sweep.planner.seed: repeated level"),
        (
            "max_sweep_points: 1\nsweep: {planner.seed: [0, 1]}\nfigure_point: {}\n",
            "config error: sweep: 2 points (2 planner.seed) exceed max_sweep_points = 1",
        ),
        ("a: 1\na: 2\n", "config error: bad.yaml, line 2: key 'a' appears twice"),
    ],
)
def test_a_bad_config_is_one_line_before_any_job(workdir, text, line):
    start = time.time()
    result = dry_run(workdir, text)
    assert result.returncode == 1
    lines = config_lines(result)
    assert len(lines) == 1 and lines[0].startswith(line), lines
    assert 'File "' not in result.stderr and "Traceback" not in result.stderr
    assert not (workdir / "results").exists() and not (workdir / "logs").exists()
    assert time.time() - start < 60


@pytest.mark.slow
@pytest.mark.parametrize(
    ("text", "what"),
    [
        ("", "empty; expected a mapping"),
        ("- a\n- b\n", "a list, not a mapping"),
        ("{{{{ garbage ::: [\n", "line 2, column 1: not valid YAML"),
        ("a:\n\tb: 1\n", "line 2, column 1: not valid YAML"),
    ],
)
def test_a_config_file_snakemake_cannot_read_is_one_line_naming_it(workdir, text, what):
    """Snakemake reads --configfile files before the Snakefile runs and its message names no
    file (snakemake/snakemake#2439); the pih console names it, in the workflow's one-line form."""
    result = dry_run(workdir, text)
    assert result.returncode == 1
    assert "Traceback" not in result.stderr
    lines = config_lines(result)
    assert len(lines) == 1 and lines[0].startswith("config error: bad.yaml"), lines
    assert what in lines[0]
    assert not (workdir / "results").exists()


def test_the_console_names_the_config_file_snakemake_could_not_read(tmp_path, monkeypatch):
    from pih.workflow.console import config_file_error, configfile_arguments

    good, bad = tmp_path / "good.yaml", tmp_path / "bad.yaml"
    good.write_text("planner: {iterations: 3}\n")
    bad.write_text("- a list\n")
    argv = ["snakemake", "-j2", "--configfile", str(good), str(bad), "-n"]
    assert configfile_arguments(argv) == [str(good), str(bad)]
    assert configfile_arguments(["snakemake", f"--configfile={bad}", "x"]) == [str(bad)]
    message = "WorkflowError:\nConfig file must be given as JSON or YAML with keys at top level."
    line = config_file_error(message, argv)
    assert line.startswith(f"config error: {bad}: a list, not a mapping")
    assert config_file_error("WorkflowError:\nsomething else", argv) is None


@pytest.mark.slow
def test_a_broken_default_config_is_one_line_naming_the_file(tmp_path):
    from test_workflow import copy_workflow

    work = copy_workflow(tmp_path)
    (work / "config" / "config.yaml").write_text("- a list\n")
    result = dry_run(work)
    assert result.returncode == 1
    assert config_lines(result) == [
        "config error: config/config.yaml: a list, not a mapping; expected a mapping of config"
        + " sections (scene:, planner:, sweep:, ...)"
    ]


def test_nested_command_line_values_are_typed_through_the_schema():
    """``--config 'planner={"iterations": 5}'`` reaches the workflow with every nested leaf a
    string; the schema's types read them back (a YAML scalar or list, never code), and what
    still does not fit is named by its key. A value from a config file keeps its type."""
    from pih.study.config import load_config
    from pih.study.schema import check_schema, typed_command_line

    root = Path(__file__).resolve().parents[1]
    schema = str(root / "workflow" / "schemas" / "config.schema.json")
    config = load_config([str(root / "config" / "config.yaml")])
    command_line = {
        "planner": {
            "iterations": "5",
            "optimizer": {"seed": "3"},
            "goal": "deepest_explored",
            "sensing": {"hole_std": "[0.005, 0.001, 0.02]"},
        },
        "scene": {"no_such_key": "1"},
    }
    typed = copy.deepcopy(config)
    typed["scene"]["no_such_key"] = "1"
    for key, value in (("iterations", "5"), ("goal", "deepest_explored")):
        typed["planner"][key] = value
    typed["planner"]["optimizer"]["seed"] = "3"
    typed["planner"]["sensing"]["hole_std"] = "[0.005, 0.001, 0.02]"
    typed_command_line(typed, command_line, schema)
    planner = typed["planner"]
    assert (planner["iterations"], planner["optimizer"]["seed"]) == (5, 3)
    assert planner["sensing"]["hole_std"] == [0.005, 0.001, 0.02]
    assert planner["goal"] == "deepest_explored"  # a string where the schema wants one
    assert typed["scene"]["no_such_key"] == "1"  # an unknown key is the schema check's
    # Not typed when it came from a file; a leaf that is no number still fails, by its key.
    quoted = copy.deepcopy(config)
    quoted["planner"]["iterations"] = "5"
    with pytest.raises(ConfigError, match=r"^planner.iterations: '5' is not allowed"):
        check_schema(quoted, schema)
    quoted["planner"]["iterations"] = "five"
    typed_command_line(quoted, {"planner": {"iterations": "five"}}, schema)
    with pytest.raises(ConfigError, match=r"^planner.iterations: 'five' is not allowed"):
        check_schema(quoted, schema)
