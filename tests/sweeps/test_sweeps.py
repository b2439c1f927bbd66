"""Sweep variants, result rows and files, and the command line (no worker processes here)."""

from __future__ import annotations

import io
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pyarrow.parquet as pq
import pytest
from typer.testing import CliRunner

from hriplan import HriplanError
from hriplan.cli.main import app
from hriplan.planner import session as session_module
from hriplan.sweeps.results import ResultStore, read_results
from hriplan.sweeps.variants import batch, expand, parse_vary
from hriplan.sweeps.worker import run_variant, separation_columns

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TAKE = EXAMPLES / "handover_full_can.yaml"
GIVE = EXAMPLES / "handover_full_can_receiver.yaml"


def test_ranges_are_inclusive_and_integer_ranges_stay_integers():
    assert parse_vary("objects.x.fill_level=0.5:1.5:0.25").grid() == [0.5, 0.75, 1.0, 1.25, 1.5]
    seeds = parse_vary("planning.seed=1:7:3").grid()
    assert seeds == [1, 4, 7] and all(isinstance(s, int) for s in seeds)


def test_lists_json_and_grids():
    assert parse_vary("humans.bob.role=Receiver,Bystander").grid() == ["Receiver", "Bystander"]
    assert parse_vary("humans.bob.position=[[0, 1.4], [0.2, 1.5]]").grid() == [[0, 1.4], [0.2, 1.5]]
    grid = parse_vary("humans.bob.position=[0.4:0.8:0.2, 1.0:2.0:1.0]").grid()
    assert grid == [[0.4, 1.0], [0.4, 2.0], [0.6, 1.0], [0.6, 2.0], [0.8, 1.0], [0.8, 2.0]]
    assert parse_vary("humans.bob.position=[0.1|0.3, 1.5]").grid() == [[0.1, 1.5], [0.3, 1.5]]


@pytest.mark.parametrize(
    "text, says",
    [
        ("planning.seed", r"--vary takes PATH=VALUES \(e.g. planning.seed=1,2,3\), got 'planning.seed'"),
        ("=1,2", r"--vary takes PATH=VALUES .*, got '=1,2'"),
        ("planning.seed=3:1:1", r"--vary planning.seed: range '3:1:1' needs LOW:HIGH:STEP with LOW <= HIGH"),
        ("planning.seed=1:2:0", r"--vary planning.seed: range '1:2:0' needs LOW:HIGH:STEP with .* STEP > 0"),
        ("humans.b.position=[1:2:1", r"--vary humans.b.position: a grid is \[RANGE, RANGE, ...\], got '\[1:2:1'"),
    ],
)
def test_malformed_vary_is_an_error(text, says):
    with pytest.raises(HriplanError, match=f"^{says}"):
        parse_vary(text)


def test_cross_product_sets_the_named_fields_of_validated_tasks():
    variants = expand(
        GIVE, [parse_vary("humans.bob.position=[0.0:0.1:0.1, 1.45]"), parse_vary("objects.can.fill_level=Full,Empty")]
    )
    assert len(variants) == 4 and len({v.key for v in variants}) == 4
    got = {(v.task.humans[0].position, v.task.objects[0].fill_level) for v in variants}
    assert got == {((0.0, 1.45), "Full"), ((0.0, 1.45), "Empty"), ((0.1, 1.45), "Full"), ((0.1, 1.45), "Empty")}
    # everything not varied is the base task's; keys are stable from one expansion to the next
    assert all(v.task.planning.seed == 1 and v.task.scene.tables[0].top == 0.72 for v in variants)
    again = expand(
        GIVE, [parse_vary("humans.bob.position=[0.0:0.1:0.1, 1.45]"), parse_vary("objects.can.fill_level=Full,Empty")]
    )
    assert [v.key for v in again] == [v.key for v in variants]


def test_one_component_of_a_vector_by_index():
    variants = expand(GIVE, [parse_vary("humans.bob.position.1=1.4,1.5")])
    assert [v.task.humans[0].position for v in variants] == [(0.0, 1.4), (0.0, 1.5)]


def test_random_draws_are_reproducible_and_inside_the_ranges():
    dims = [parse_vary("humans.bob.position=[-0.3:0.3:0.1, 1.3:1.6:0.1]"), parse_vary("planning.seed=1:1000:1")]
    first, second = expand(GIVE, dims, samples=12, seed=5), expand(GIVE, dims, samples=12, seed=5)
    assert [v.key for v in first] == [v.key for v in second] and len(first) == 12
    for v in first:
        x, y = v.task.humans[0].position
        assert -0.3 <= x <= 0.3 and 1.3 <= y <= 1.6 and 1 <= v.task.planning.seed <= 1000
    assert [v.key for v in expand(GIVE, dims, samples=12, seed=6)] != [v.key for v in first]


@pytest.mark.parametrize(
    ("vary", "message"),
    [
        ("humans.zed.position=1", "no item 'zed' in the list (names: bob)"),
        ("humans.bob.positon=1", "no field 'positon'"),
        ("objects.can.fill_level=Brimming", 'variant objects.can.fill_level="Brimming": objects.0.fill_level'),
        ("humans.bob.role=Nobody", 'variant humans.bob.role="Nobody": humans.0.role'),
    ],
)
def test_bad_paths_and_values_name_the_problem(vary, message):
    with pytest.raises(HriplanError, match=None) as info:
        expand(GIVE, [parse_vary(vary)])
    assert message in str(info.value) and "\n" not in str(info.value)


def test_cli_bad_vary_is_one_line_and_exit_2(tmp_path):
    result = CliRunner().invoke(app, ["sweep", str(GIVE), "--vary", "humans.zed.position=1", "-o", str(tmp_path / "s")])
    assert result.exit_code == 2
    assert result.output.strip().count("\n") == 0 and result.output.startswith("error: --vary humans.zed.position")
    assert CliRunner().invoke(app, ["sweep", str(GIVE), "-o", str(tmp_path / "s")]).exit_code == 2
    assert CliRunner().invoke(app, ["sweep", "--report", str(tmp_path / "nothing")]).exit_code == 2
    assert CliRunner().invoke(app, ["batch", str(tmp_path / "missing.yaml"), "-o", str(tmp_path / "b")]).exit_code == 2


def test_store_parts_compact_dedupe_and_resume_keys(tmp_path):
    store = ResultStore(tmp_path, flush_rows=2)
    store.add([{"key": "a", "step_index": 0, "status": "solved", "vary.role": "Giver"}])
    assert not list((tmp_path / "parts").glob("*.parquet"))  # buffered
    store.add([{"key": "b", "step_index": 0, "status": "error", "vary.role": 3.5}])  # mixed types: text
    assert len(list((tmp_path / "parts").glob("part-*.parquet"))) == 1
    assert store.finished_keys() == {"a", "b"}
    store.add([{"key": "a", "step_index": 0, "status": "failed"}])  # a repeat: the latest wins
    path = store.compact(csv=True)
    assert path == tmp_path / "results.csv" and path.read_text().count("\n") == 3
    assert not list((tmp_path / "parts").glob("*")) and not list(tmp_path.glob(".*.tmp"))
    table = pq.read_table(tmp_path / "results.parquet")
    assert sorted(zip(table["key"].to_pylist(), table["status"].to_pylist())) == [("a", "failed"), ("b", "error")]
    assert sorted(ResultStore(tmp_path).finished_keys()) == ["a", "b"]
    assert len(read_results(tmp_path)) == 2


def test_separation_per_person_from_traces_or_the_closest_pair():
    old = SimpleNamespace(min_human_distance=0.21, closest_pair=("right_hand_finger_1", "bob/right_hand"))
    assert separation_columns(old, ["ann", "bob"]) == {
        "min_separation.ann": None,
        "min_separation.bob": 0.21,
        "ssm_worst_margin": None,
    }
    traces = [
        SimpleNamespace(person="ann", min_separation=0.8, worst_margin=0.3),
        SimpleNamespace(person="bob", min_separation=0.2, worst_margin=-0.1),
    ]
    new = SimpleNamespace(min_human_distance=0.2, closest_pair=("x", "bob/torso"), separation=traces)
    assert separation_columns(new, ["ann", "bob"]) == {
        "min_separation.ann": 0.8,
        "min_separation.bob": 0.2,
        "ssm_worst_margin": -0.1,
    }


def test_a_planned_row_reproduces_a_direct_plan_of_its_task(monkeypatch):
    """The row holds the variant's task: planning it directly gives the row's numbers. Both plan
    on the worker's one session for the robot and hands, built once."""
    monkeypatch.setattr(session_module, "_WORKER_SESSIONS", {})
    from hriplan.tasks.model import TaskFile
    from hriplan.tasks.pipeline import TaskRunner

    variant = expand(GIVE, [parse_vary("planning.seed=3")])[0]
    row, release = run_variant(variant)
    assert row["status"] == "solved" and row["step"] == "hand_over"
    assert (release["status"], release["step"]) == ("solved", "hand_over_release")
    direct = TaskRunner(TaskFile.model_validate_json(row["task"])).run(plan=True).steps[0]
    report = direct.trajectory.report
    assert row["path_length"] == pytest.approx(report.path_length, rel=1e-9)
    assert row["duration"] == pytest.approx(report.duration, rel=1e-9)
    assert row["min_separation.bob"] == pytest.approx(report.min_human_distance) and report.min_human_distance > 0
    assert row["constraint_kinds"].split(",") == sorted(
        {c.kind for c in direct.derivation.constraints} | {v.kind for v in direct.derivation.velocity}
    )
    # independent of the planner's report: the joint-space length of the trajectory's points
    points = [p.positions for p in direct.trajectory.points]
    length = sum(sum((a - b) ** 2 for a, b in zip(p, q)) ** 0.5 for p, q in zip(points, points[1:]))
    assert row["path_length"] == pytest.approx(length, rel=0.05)
    # a second variant on the same robot and hands reuses this worker's sessions (the task's
    # hands, and the hand opened to let go)
    sessions = list(session_module._WORKER_SESSIONS.values())
    assert sorted(s.robot.hand_postures["right"] for s in sessions) == ["power", "release"]
    run_variant(expand(GIVE, [parse_vary("planning.seed=4")])[0])
    assert list(session_module._WORKER_SESSIONS.values()) == sessions


def test_batch_keys_files_and_a_failed_derivation_is_an_error_row(tmp_path):
    variants = batch([GIVE, TAKE, GIVE])
    assert len(variants) == 2 and variants[0].source == str(GIVE)
    far = expand(TAKE, [parse_vary("humans.alice.position=[[1.5, 3.0]]")])[0]
    (row,) = run_variant(far, plan=False)
    assert row["status"] == "error" and "cannot reach" in row["reason"] and row["step_index"] == -1
    assert json.loads(row["task"])["humans"][0]["position"] == [1.5, 3.0]


def test_report_maps_success_and_separation_over_the_varied_position(tmp_path):
    from hriplan.sweeps.report import per_variant, write_report

    store = ResultStore(tmp_path)
    for i, (x, y) in enumerate([(0.0, 1.2), (0.0, 1.4), (0.2, 1.2), (0.2, 1.4)]):
        common = {
            "key": f"k{i}",
            "vary.humans.bob.position.0": x,
            "vary.humans.bob.position.1": y,
            "vary.planning.seed": 1,
        }
        store.add(
            [
                common | {"step_index": 0, "status": "solved", "min_separation.bob": 0.30 + i},
                common | {"step_index": 1, "status": "solved" if i != 3 else "timeout", "min_separation.bob": 0.25 + i},
            ]
        )
    store.compact()
    records = {r["key"]: r for r in per_variant(read_results(tmp_path))}
    assert [records[f"k{i}"]["success"] for i in range(4)] == [True, True, True, False]
    assert records["k2"]["separation"] == pytest.approx(2.25)  # the smaller of its two steps
    page = write_report(tmp_path)
    assert page == tmp_path / "report.html" and "4 variants, 3 succeeded in every step" in page.read_text()
    image = tmp_path / "success_map.png"
    assert image.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and image.stat().st_size > 10_000
    result = CliRunner().invoke(app, ["sweep", "--report", str(tmp_path)])
    assert result.exit_code == 0 and "report.html" in result.output


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_is_a_bar_on_a_terminal_and_plain_lines_otherwise():
    from hriplan.sweeps.progress import Progress

    terminal, log = _Terminal(), io.StringIO()
    for stream in (terminal, log):
        progress = Progress(3, stream=stream, every=0.0)
        for _ in range(3):
            progress.advance()
        progress.close()
    assert "3/3" in terminal.getvalue() and "variant/s" in terminal.getvalue() and "\r" in terminal.getvalue()
    lines = log.getvalue().splitlines()
    assert lines[-1].startswith("... 3/3 variants,") and "ETA 0 s" in lines[-1] and len(lines) == 3


@pytest.mark.parametrize(
    ("first", "second", "message"),
    [
        ("planning.seed=1,2", "planning.seed=3", "--vary planning.seed is given twice: give all its values in one"),
        ("humans.bob.position=[[0, 1.4]]", "humans.bob.position.1=1.5", "--vary humans.bob.position.1 overlaps"),
    ],
)
def test_a_path_varied_twice_is_one_line(first, second, message):
    with pytest.raises(HriplanError) as info:
        expand(GIVE, [parse_vary(first), parse_vary(second)])  # was: the last one silently won
    assert str(info.value).startswith(message) and "\n" not in str(info.value)


def test_the_run_key_changes_with_the_mode_the_rules_the_robot_and_the_version(tmp_path, monkeypatch):
    """A result is reused only for the same task, mode, rule files' contents, robot description and
    hriplan version (a derive-only row was reused by a planning run: it planned nothing)."""
    from dataclasses import replace

    import hriplan
    from hriplan.robots.descriptions import registry
    from hriplan.sweeps.variants import run_key

    rules = tmp_path / "extra.rules"
    rules.write_text("# no rules yet\n")
    base = expand(GIVE, [parse_vary("planning.seed=3")])[0]
    variant = base.model_copy(update={"task": base.task.model_copy(update={"rule_files": [str(rules)]})})
    planned = run_key(variant, plan=True)
    assert run_key(variant, plan=True) == planned and len(planned) == 16  # stable
    assert run_key(variant, plan=False) != planned
    rules.write_text("# one rule changed\n")
    changed_rules = run_key(variant, plan=True)
    assert changed_rules != planned
    madar = registry.DESCRIPTIONS["madar"]
    monkeypatch.setitem(registry.DESCRIPTIONS, "madar", replace(madar, postures={**madar.postures, "new": {}}))
    changed_robot = run_key(variant, plan=True)
    assert changed_robot != changed_rules
    monkeypatch.setattr(hriplan, "__version__", "99.0")
    assert run_key(variant, plan=True) != changed_robot


def _pixels(image: Path, colour: str) -> int:
    """How many pixels of the PNG have exactly this colour."""
    import matplotlib.colors
    import matplotlib.image

    rgb = (matplotlib.image.imread(image)[:, :, :3] * 255).round()
    want = np.array(matplotlib.colors.to_rgb(colour)) * 255
    return int((np.abs(rgb - want.round()) < 0.5).all(axis=2).sum())


def test_report_maps_a_numeric_axis_against_words_and_tells_failure_kinds_apart(tmp_path):
    """A position component against the fill level (was a blank map) with three failure kinds:
    each kind its own colour in the outcome panel and its count on the page."""
    from hriplan.sweeps.report import OUTCOME_COLOURS, write_report

    store = ResultStore(tmp_path)
    outcomes = {(-0.2, "Full"): "timeout", (0.0, "Full"): "worker_died", (0.2, "Full"): "solved"}
    outcomes |= {(-0.2, "Empty"): "error", (0.0, "Empty"): "solved", (0.2, "Empty"): "solved"}
    for i, ((x, fill), status) in enumerate(outcomes.items()):
        store.add(
            [
                {
                    "key": f"k{i}",
                    "vary.humans.bob.position.0": x,
                    "vary.objects.can.fill_level": fill,
                    "step_index": 0,
                    "status": status,
                    "reason": f"why {status}",
                    "min_separation.bob": 0.3 + 0.1 * i if status == "solved" else None,
                }
            ]
        )
    store.compact()
    page = write_report(tmp_path).read_text()
    assert "6 variants, 3 succeeded in every step; failed: 1 timeout, 1 worker_died, 1 error." in page
    assert "<td>worker_died</td><td>why worker_died</td>" in page
    image = tmp_path / "success_map.png"
    cell = 5_000  # one cell of the 3 x 2 map is far more pixels than any legend or colour bar patch
    for kind in ("timeout", "worker_died", "error"):
        assert _pixels(image, OUTCOME_COLOURS[kind]) > cell, kind
    assert _pixels(image, OUTCOME_COLOURS["success"]) > 3 * cell  # three solved cells
    assert _pixels(image, OUTCOME_COLOURS["invalid_path"]) < cell  # no such outcome


def test_derive_only_then_plan_in_one_folder_is_refused_unless_merged(tmp_path):
    """A derive-only run does not pass for a planned one (was: 'succeeded' with nothing planned).
    The folder's manifest records each run; --save-trajectories keeps each variant's files."""
    from hriplan.planner.trajectory import load_trajectory
    from independent import constraint_violations

    out = tmp_path / "s"
    sweep = ["sweep", str(GIVE), "--vary", "planning.seed=3", "-o", str(out), "--workers", "1", "-q"]
    derived = CliRunner().invoke(app, [*sweep, "--derive-only"])
    assert derived.exit_code == 0 and derived.output.startswith("1 variants: 1 run"), derived.output
    refused = CliRunner().invoke(app, sweep)
    assert refused.exit_code == 2 and refused.output.count("\n") == 1
    assert refused.output.startswith(f"error: {out} holds the results of another mode (derive-only, this one is plan)")
    other = CliRunner().invoke(app, ["sweep", str(TAKE), "--vary", "planning.seed=3", "-o", str(out), "--derive-only"])
    assert other.exit_code == 2 and "holds the results of another task (handover_full_can_receiver.yaml" in other.output
    planned = CliRunner().invoke(app, [*sweep, "--merge", "--save-trajectories"])
    assert planned.exit_code == 0 and planned.output.startswith("1 variants: 1 run, 0 already done; 1 succeeded")
    rows = read_results(out)
    assert sorted((r["mode"], r["status"]) for r in rows) == [
        ("derive-only", "derived"),
        ("plan", "solved"),
        ("plan", "solved"),
    ]
    for row in (r for r in rows if r["mode"] == "plan"):
        trajectory = load_trajectory(out / row["trajectory_file"])
        assert trajectory.step == row["step"] and constraint_violations(trajectory) == []
        assert trajectory.points[-1].time_from_start == pytest.approx(row["duration"])
    manifest = json.loads((out / "sweep.json").read_text())
    assert [r["identity"]["mode"] for r in manifest["runs"]] == ["derive-only", "plan"]
    from datetime import datetime

    from hriplan import __version__

    for run in manifest["runs"]:
        assert run["version"] == __version__ and datetime.fromisoformat(run["started"]).tzinfo is not None
        assert run["spec"]["vary"] == ["planning.seed=3"] and run["spec"]["file"] == str(GIVE)


@pytest.mark.parametrize(
    ("option", "says"),
    [
        ("{bad", "error: --ray-runtime-env: line 1: not valid JSON"),
        ("[1]", "error: --ray-runtime-env: a runtime_env is a mapping (pip, py_modules, env_vars, ...), got '[1]'"),
        ("missing.yaml", "error: --ray-runtime-env: missing.yaml: no such file"),
    ],
)
def test_a_bad_runtime_env_is_one_line_before_ray_starts(tmp_path, option, says):
    out = tmp_path / "s"
    result = CliRunner().invoke(
        app,
        [
            "sweep",
            str(GIVE),
            "--vary",
            "planning.seed=1",
            "-o",
            str(out),
            "--engine",
            "ray",
            "--ray-runtime-env",
            option,
        ],
    )
    assert result.exit_code == 2 and result.output.startswith(says) and result.output.count("\n") == 1
    assert not out.exists()
