"""Engines: local worker processes and a real local Ray runtime (2 CPUs) give the same results;
a rerun skips finished variants; a worker that dies is retried once, then recorded, and run again
on --retry-failed; a Ray cluster whose CPUs are all taken is one line after a bound; Ctrl-C and
SIGTERM stop the workers and keep what is done."""

from __future__ import annotations

import sys
from functools import partial
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the helpers, for spawned workers too

import sweeps_helpers as helpers

from hriplan.sweeps.engines import LocalEngine, RayEngine
from hriplan.sweeps.run import run_sweep
from hriplan.sweeps.variants import expand, parse_vary, run_key

ray = pytest.importorskip("ray")

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
GIVE = EXAMPLES / "handover_full_can_receiver.yaml"
TAKE = EXAMPLES / "handover_full_can.yaml"


@pytest.fixture
def log_dir(tmp_path):
    return tmp_path


def _by_key(directory: Path) -> dict:
    from hriplan.sweeps.results import read_results

    return {(r["key"], r["step_index"]): r for r in read_results(directory)}


@pytest.fixture(scope="module")
def ray_runtime():
    RayEngine(workers=2)._connect()  # the module's runtime, shut down at its end
    yield RayEngine(workers=2)  # an engine on a runtime it did not start leaves it running
    ray.shutdown()


def test_ray_and_local_give_the_same_results(tmp_path, ray_runtime):
    derive = expand(TAKE, [parse_vary("humans.alice.position=[-0.2:0.0:0.1, 1.35:1.45:0.1]")])
    # a generous time limit: the machine is shared, and a seeded plan is only repeatable if it finishes
    planned = expand(GIVE, [parse_vary("planning.time_limit=120"), parse_vary("objects.can.fill_level=Full,Empty")])
    results = {}
    for name, engine in {"local": LocalEngine(2), "ray": ray_runtime}.items():
        run_sweep(derive, tmp_path / name / "derive", engine, plan=False, progress=False)
        summary = run_sweep(planned, tmp_path / name / "plan", engine, progress=False)
        assert summary.ran == 2 and summary.solved == 2
        results[name] = _by_key(tmp_path / name / "derive") | _by_key(tmp_path / name / "plan")
    local, remote = results["local"], results["ray"]
    assert local.keys() == remote.keys() and len({k for k, _ in local}) == 6 + 2
    # some positions leave the can out of alice's reach: those variants are errors with the reason
    assert {r["status"] for r in local.values()} == {"derived", "error", "solved"}
    for k, row in local.items():
        for column in (
            "status",
            "reason",
            "constraint_kinds",
            "velocity_scale",
            "path_length",
            "duration",
            "min_separation.bob",
        ):
            assert row.get(column) == remote[k].get(column), (k, column)
    planned_rows = [r for r in local.values() if r["status"] == "solved" and not r["step"].endswith("_release")]
    assert len(planned_rows) == 2 and all(r["path_length"] > 0 for r in planned_rows)
    # the rules see each variant's facts: a full can brings constraints an empty one does not
    kinds = {r["vary.objects.can.fill_level"]: set(r["constraint_kinds"].split(",")) for r in planned_rows}
    assert kinds["Full"] > kinds["Empty"]


def _derive_locally(variants, folder, work):
    """A derive-only sweep on two local workers, each variant run by `work`."""
    return run_sweep(variants, folder, LocalEngine(2), plan=False, work=work, progress=False)


def test_rerun_skips_finished_variants_and_widening_runs_only_the_new(tmp_path, log_dir):
    def sweep(seeds: str) -> int:
        variants = expand(GIVE, [parse_vary(f"planning.seed={seeds}")])
        return _derive_locally(variants, tmp_path / "s", partial(helpers.counting, log_dir)).ran

    assert sweep("1,2") == 2 and len(helpers.calls(log_dir)) == 2
    assert sweep("1,2") == 0 and len(helpers.calls(log_dir)) == 2
    assert sweep("1,2,3") == 1 and len(helpers.calls(log_dir)) == 3
    assert len(_by_key(tmp_path / "s")) == 3


@pytest.mark.parametrize("engine", ["local", "ray"])
def test_a_dying_worker_is_retried_once_then_recorded(tmp_path, log_dir, engine, request):
    engine = LocalEngine(2) if engine == "local" else request.getfixturevalue("ray_runtime")
    variants = expand(GIVE, [parse_vary("planning.seed=6:8:1")])
    summary = run_sweep(
        variants, tmp_path / "s", engine, plan=False, work=partial(helpers.dies_on_seed_7, log_dir), progress=False
    )
    rows = list(_by_key(tmp_path / "s").values())
    dead = [r for r in rows if r["status"] == "worker_died"]
    assert len(dead) == 1 and '"seed":7' in dead[0]["task"] and "died on each of 2 attempts" in dead[0]["reason"]
    assert sorted(r["status"] for r in rows) == ["derived"] * 2 + ["worker_died"]
    seven = run_key(next(v for v in variants if v.task.planning.seed == 7), plan=False)
    assert helpers.calls(log_dir).count(seven) == 2 and summary.solved == 2


def test_retry_failed_runs_a_died_variant_again_and_keeps_only_its_latest_rows(tmp_path, log_dir):
    from hriplan.sweeps.results import read_results

    variants = expand(GIVE, [parse_vary("planning.seed=6:8:1")])
    _derive_locally(variants, tmp_path / "s", partial(helpers.dies_on_seed_7, log_dir))
    assert sorted(r["status"] for r in read_results(tmp_path / "s")) == ["derived"] * 2 + ["worker_died"]
    counting = partial(helpers.counting, log_dir)
    assert _derive_locally(variants, tmp_path / "s", counting).ran == 0  # a rerun alone keeps the failure
    summary = run_sweep(
        variants, tmp_path / "s", LocalEngine(2), plan=False, work=counting, progress=False, retry_failed=True
    )
    assert summary.ran == 1 and summary.solved == 3 and summary.statuses == {"derived": 3}
    rows = read_results(tmp_path / "s")  # the died row is replaced, not kept beside the new one
    assert sorted(r["status"] for r in rows) == ["derived"] * 3 and len({r["key"] for r in rows}) == 3
    assert [r["status"] for r in rows if '"seed":7' in r["task"]] == ["derived"]
    seven = run_key(next(v for v in variants if v.task.planning.seed == 7), plan=False)
    assert helpers.calls(log_dir).count(seven) == 3 and helpers.calls(log_dir)[-1] == seven  # died twice, ran again


def test_more_workers_than_the_cluster_has_cpus_start_only_as_many(tmp_path, ray_runtime):
    """Four actors asked of a 2-CPU runtime: two start and take every variant (was: four actors,
    two of which could never start, and the variants given to them waited for ever)."""
    from hriplan.sweeps.results import read_results

    variants = expand(GIVE, [parse_vary("planning.seed=1:4:1")])
    summary = run_sweep(variants, tmp_path / "s", RayEngine(workers=4), plan=False, progress=False)
    rows = read_results(tmp_path / "s")
    assert summary.solved == 4 and sorted(r["status"] for r in rows) == ["derived"] * 4
    assert 1 <= len({r["worker"] for r in rows}) <= 2


def test_a_cluster_whose_cpus_are_all_taken_is_one_line_after_the_bound(tmp_path, ray_runtime):
    from hriplan import HriplanError

    holders = [ray.remote(num_cpus=1)(helpers.Holder).remote() for _ in range(2)]
    ray.get([h.ping.remote() for h in holders])  # both CPUs of the 2-CPU runtime are held
    try:
        variants = expand(GIVE, [parse_vary("planning.seed=1,2")])
        engine = RayEngine(workers=2, start_timeout=3)
        with pytest.raises(HriplanError, match=r"^no Ray worker started within 3 s \(the cluster has 2 CPUs"):
            run_sweep(variants, tmp_path / "s", engine, plan=False, progress=False)
        assert not (tmp_path / "s").exists()  # nothing is created before a worker has started
    finally:
        for holder in holders:
            ray.kill(holder)


def test_a_worker_that_dies_once_is_retried_and_its_variant_kept(tmp_path, log_dir):
    variants = expand(GIVE, [parse_vary("planning.seed=6:8:1")])
    _derive_locally(variants, tmp_path / "s", partial(helpers.dies_once_on_seed_7, log_dir))
    assert sorted(r["status"] for r in _by_key(tmp_path / "s").values()) == ["derived"] * 3


def test_batch_from_the_command_line_then_its_report(tmp_path):
    from typer.testing import CliRunner

    from hriplan.cli.main import app

    out = tmp_path / "b"
    result = CliRunner().invoke(
        app, ["batch", str(GIVE), str(TAKE), "-o", str(out), "--derive-only", "--workers", "1", "-q"]
    )
    assert result.exit_code == 0, result.output
    assert result.output.startswith("2 variants: 2 run, 0 already done; 2 succeeded in every step")
    rows = _by_key(out)
    assert sorted({Path(r["source"]).name for r in rows.values()}) == sorted([GIVE.name, TAKE.name])
    assert sorted(r["step"] for r in rows.values()) == ["hand_over", "place_can", "take_can"]
    again = CliRunner().invoke(app, ["batch", str(GIVE), str(TAKE), "-o", str(out), "--derive-only", "-q"])
    assert again.output.startswith("2 variants: 0 run, 2 already done")
    assert CliRunner().invoke(app, ["sweep", "--report", str(out)]).exit_code == 0
    assert (out / "variants.png").stat().st_size > 5_000 and "2 variants, 2 succeeded" in (
        out / "report.html"
    ).read_text()


def test_an_interrupt_right_after_a_variant_was_kept_counts_it(tmp_path, monkeypatch):
    """Ctrl-C or SIGTERM can land after the store kept a variant's rows and before the sweep
    counted it: the count it says is kept is the variants whose rows the folder holds."""
    from hriplan.sweeps.results import ResultStore, read_results
    from hriplan.sweeps.run import SweepInterrupted

    kept_rows = ResultStore.add
    calls = []

    def add_then_interrupted(self, rows):
        kept_rows(self, rows)
        calls.append(len(rows))
        if len(calls) == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(ResultStore, "add", add_then_interrupted)
    variants = expand(GIVE, [parse_vary("planning.seed=1:4:1")])
    with pytest.raises(SweepInterrupted, match=r"^interrupted: 2 variants kept in "):
        run_sweep(variants, tmp_path / "s", LocalEngine(1), plan=False, progress=False)
    assert len({r["key"] for r in read_results(tmp_path / "s")}) == 2


@pytest.mark.parametrize(
    ("signal_name", "code", "engine"), [("SIGINT", 130, "local"), ("SIGTERM", 143, "local"), ("SIGTERM", 143, "ray")]
)
def test_ctrl_c_or_sigterm_stops_the_workers_keeps_what_is_done_and_a_rerun_resumes(
    tmp_path, signal_name, code, engine
):
    """Ctrl-C and SIGTERM (a scheduler, `timeout`, `docker stop`) alike: the workers (the local
    pool's processes, or the local Ray runtime's) end with the sweep, the finished rows are kept
    (SIGTERM orphaned the local pool, and ray.init's own handler exited at once with 15)."""
    import os
    import signal
    import subprocess
    import time

    out = tmp_path / "s"
    command = [
        sys.executable,
        "-m",
        "hriplan.cli",
        "sweep",
        str(GIVE),
        "--vary",
        "planning.seed=1:40:1",
        "-o",
        str(out),
        "--derive-only",
        "--workers",
        "2",
        "--engine",
        engine,
    ]
    env = os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)}
    process = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = process.stderr.readline()  # the first progress line: one variant is done
    assert first.startswith("... 1/40 variants"), first
    workers = helpers.children(process.pid)
    assert len(workers) >= 2  # the pool's workers and resource tracker, or Ray's services
    process.send_signal(getattr(signal, signal_name))
    _, err = process.communicate(timeout=120)
    assert process.returncode == code, err
    kept = int(err.split("interrupted: ")[1].split()[0])
    assert 1 <= kept < 40 and len(_by_key(out)) == kept and not list((out / "parts").glob("*"))
    for _ in range(300):  # a bounded wait for the workers to be gone (orphans would stay for ever)
        if not any(helpers.alive(pid) for pid in workers):
            break
        time.sleep(0.1)
    assert [pid for pid in workers if helpers.alive(pid)] == []
    rerun = subprocess.run(command + ["-q"], env=env, capture_output=True, text=True, timeout=600)
    assert rerun.returncode == 0 and rerun.stdout.startswith(f"40 variants: {40 - kept} run, {kept} already done"), (
        rerun.stdout
    )
    assert len(_by_key(out)) == 40


def test_with_no_route_out_the_ray_sweep_prints_only_its_own_lines(tmp_path):
    """Offline (as the CI machine is), Ray's core warns on file descriptor 2 that it cannot reach
    8.8.8.8 to learn its own address: the sweep's stderr stays its own (was: that warning first,
    so every one-line contract broke). Run in a network namespace with only loopback."""
    import os
    import shutil
    import subprocess

    if not shutil.which("unshare") or subprocess.run(["unshare", "-rn", "true"], capture_output=True).returncode:
        pytest.skip("no network namespace can be made here (the CI machine is offline by itself)")
    command = [sys.executable, "-m", "hriplan.cli", "sweep", str(GIVE), "--vary", "planning.seed=1:2:1"]
    command += ["-o", str(tmp_path / "s"), "--derive-only", "--workers", "1", "--engine", "ray"]
    offline = ["unshare", "-rn", "sh", "-c", 'ip link set lo up 2>/dev/null || ifconfig lo up; exec "$@"', "sh"]
    env = os.environ | {"PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run(offline + command, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and done.stdout.startswith("2 variants: 2 run"), done.stderr
    assert [line for line in done.stderr.splitlines() if not line.startswith("... ")] == [], done.stderr


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads process states from /proc")
def test_a_pool_given_up_ends_its_workers_even_one_that_would_not_end_by_itself():
    """A broken pool is given up with `_stop`: its workers are ended, not left to finish or to
    wait for work (a worker left behind makes the interpreter's exit wait for it for ever)."""
    import multiprocessing
    import time
    from concurrent.futures import ProcessPoolExecutor, wait

    from hriplan.sweeps.engines import _stop

    pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"))
    wait([pool.submit(time.sleep, 0.0)])  # the worker started
    pool.submit(time.sleep, 60.0)  # busy for a minute: shutting down alone would wait for it
    (worker,) = list(pool._processes.values())
    _stop(pool)
    deadline = time.monotonic() + 10.0
    while helpers.alive(worker.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not helpers.alive(worker.pid)
