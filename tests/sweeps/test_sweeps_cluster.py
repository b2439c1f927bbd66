"""Sweeps on a real Ray cluster: a head node in its own process (2 CPUs, token authentication,
and a node environment where hriplan cannot be imported), joined by `hriplan sweep --ray-address`.

The nodes get the driver's hriplan through Ray's runtime_env; a wrong address, an unreachable
one or a wrong token is one line and exit 2 with nothing created; RAY_ADDRESS alone is not joined.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("ray")

HERE = Path(__file__).resolve().parent
GIVE = HERE.parents[1] / "examples" / "handover_full_can_receiver.yaml"
TOKEN = {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": "0f" * 32}  # the cluster's token
CLIENT = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")} | {"PYTHONPATH": os.pathsep.join(sys.path)}


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """The head node's address; its workers import a `hriplan` that fails (a node without it)."""
    node = tmp_path_factory.mktemp("node")
    (node / "hriplan").mkdir()
    (node / "hriplan" / "__init__.py").write_text('raise ImportError("this node has no hriplan")\n')
    env = CLIENT | TOKEN | {"PYTHONPATH": str(node)}
    head = subprocess.Popen(
        [sys.executable, str(HERE / "ray_head.py"), "2"],
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    address = head.stdout.readline().strip()
    assert address.count(":") == 1, address
    yield address
    head.stdin.close()
    try:
        head.wait(timeout=120)
    except subprocess.TimeoutExpired:
        head.kill()


def sweep(out: Path, *options: str, env: dict | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    """A derive-only sweep of three seeds by the command line, in its own process."""
    command = [sys.executable, "-m", "hriplan.cli", "sweep", str(GIVE), "--vary", "planning.seed=1:3:1"]
    command += ["-o", str(out), "--derive-only", "-q", *options]
    return subprocess.run(command, env=env or CLIENT | TOKEN, capture_output=True, text=True, timeout=timeout)


def test_nodes_get_this_hriplan_through_the_runtime_env(cluster, tmp_path):
    """The node's own hriplan does not import: the workers run the driver's, uploaded by Ray
    (the runtime_env's py_modules). Four workers asked of two CPUs: two start (was: a hang)."""
    from hriplan.sweeps.results import read_results

    done = sweep(tmp_path / "s", "--ray-address", cluster, "--workers", "4")
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("3 variants: 3 run, 0 already done; 3 succeeded in every step")
    rows = read_results(tmp_path / "s")
    assert sorted(r["status"] for r in rows) == ["derived"] * 3 and len({r["worker"] for r in rows}) <= 2
    # without hriplan in the runtime_env the node's own is imported: one line, nothing written
    bare = sweep(tmp_path / "bare", "--ray-address", cluster, "--ray-runtime-env", '{"py_modules": null}')
    assert (
        bare.returncode == 2
        and bare.stderr == "error: a Ray worker could not start: ImportError: this node has no hriplan\n"
    )
    assert not (tmp_path / "bare").exists()


@pytest.mark.parametrize(
    ("address", "env", "says"),
    [
        ("nonsense", {}, "error: --ray-address 'nonsense' is not HOST:PORT"),
        ("127.0.0.1:1", {}, "error: cannot reach the Ray cluster at 127.0.0.1:1 ("),
        # TEST-NET-3: nothing answers (or, behind a proxy that accepts every connection, Ray's retries end)
        ("203.0.113.1:6379", {}, "error: cannot "),
        ("CLUSTER", {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": "1e" * 32}, "error: the Ray cluster at "),
        ("CLUSTER", {}, "error: the Ray cluster at "),  # no token given
    ],
)
def test_a_cluster_that_cannot_be_joined_is_one_line_and_nothing_is_created(cluster, tmp_path, address, env, says):
    """Were a traceback (a malformed address, a token mismatch after 21 s) or endless retries with
    the output folder made (an unreachable address). The bound is Ray's own retries, cut to ~10 s."""
    address = cluster if address == "CLUSTER" else address
    failed = sweep(tmp_path / "s", "--ray-address", address, env=CLIENT | env, timeout=60)
    assert failed.returncode == 2 and failed.stderr.startswith(says) and failed.stderr.count("\n") == 1, failed.stderr
    if address == cluster:
        assert "refused this client's token: set RAY_AUTH_MODE=token and RAY_AUTH_TOKEN" in failed.stderr
    assert failed.stdout == "" and not (tmp_path / "s").exists()


def test_ray_address_in_the_environment_is_not_joined(cluster, tmp_path):
    """--engine ray with RAY_ADDRESS set starts a local runtime (was: joined it and crashed with
    'num_cpus ... must not be provided'); a cluster is joined only with --ray-address."""
    done = sweep(tmp_path / "s", "--engine", "ray", "--workers", "1", env=CLIENT | TOKEN | {"RAY_ADDRESS": cluster})
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("3 variants: 3 run, 0 already done; 3 succeeded in every step")
