"""The `hriplan` command: version, robot info and URDF export, clear errors."""

import subprocess
import sys

import numpy as np
import pinocchio as pin

from hriplan.planner.trajectory import TrajectoryFile
from independent import constraint_violations


def run(*args):
    return subprocess.run([sys.executable, "-m", "hriplan.cli", *args], capture_output=True, text=True, timeout=300)


def test_version_and_help():
    assert run("--version").stdout.startswith("hriplan 0.1.0")
    assert "robot" in run("--help").stdout


def test_robot_urdf_loads_back_in_pinocchio(madar):
    out = run("robot", "urdf", "madar")
    assert out.returncode == 0
    model = pin.buildModelFromXML(out.stdout)
    assert model.existJointName("right_wrist_3_joint") and model.existFrame("left_tool")
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    assert np.allclose(
        data.oMf[model.getFrameId("right_wrist_3_link")].translation, (-0.3247, 0.1914, 0.8139), atol=1e-4
    )
    assert "/site-packages/" not in out.stdout and "package://example-robot-data/robots/" in out.stdout
    from hriplan.cli.urdf_export import package_root

    geoms = pin.buildGeomFromUrdfString(model, out.stdout, pin.COLLISION, package_dirs=[str(package_root())])
    assert geoms.ngeoms > 30


def test_robot_info_lists_groups_and_collision_parts():
    out = run("robot", "info", "ur5")
    assert out.returncode == 0
    assert "group arm (6 joints)" in out.stdout and "elbow_joint" in out.stdout and "collision parts: 7" in out.stdout


def test_unknown_robot_is_one_line_and_exit_2():
    out = run("robot", "info", "pr2")
    assert out.returncode == 2
    assert out.stderr.strip() == "error: unknown robot 'pr2'; known robots: madar, ur5"
    bad_hand = run("robot", "info", "madar", "--hand", "right")
    assert bad_hand.returncode == 2 and "SIDE=POSTURE" in bad_hand.stderr and "Traceback" not in bad_hand.stderr


SCENARIO = __import__("pathlib").Path(__file__).parents[2] / "benchmarks" / "scenarios" / "b_madar_handover.json"


def test_solve_writes_a_validated_trajectory(tmp_path):
    out = tmp_path / "traj.json"
    result = run("solve", str(SCENARIO), "--seed", "1", "-o", str(out))
    assert result.returncode == 0, result.stderr
    assert "approach_cone" in result.stdout and "closest approach to a person" in result.stdout
    import json

    data = json.loads(out.read_text())
    assert data["schema"] == "hriplan.trajectory" and data["joint_names"][0] == "right_shoulder_pan_joint"
    assert all(v <= 1e-4 for v in data["report"]["max_violation"].values())
    assert constraint_violations(TrajectoryFile.model_validate(data)) == []


def test_solve_failures_have_exit_codes(tmp_path):
    import json

    problem = json.loads(SCENARIO.read_text())
    problem["start"]["right_wrist_2_joint"] += 0.5  # tilts the can beyond its tolerance
    tilted = tmp_path / "tilted.json"
    tilted.write_text(json.dumps(problem))
    failed = run("solve", str(tilted))
    assert failed.returncode == 1 and "planning failed (invalid_start): start violates upright" in failed.stderr
    problem["constraints"]["constraints"][0]["tolerance"] = -1
    broken = tmp_path / "broken.json"
    broken.write_text(json.dumps(problem))
    bad = run("solve", str(broken))
    assert bad.returncode == 2 and bad.stderr.startswith(
        f"error: {broken}: constraints.constraints.0.orientation.tolerance"
    )


HEAVY = (
    "ompl",
    "toppra",
    "scipy",
    "matplotlib",
    "meshcat",
    "hriplan.planner.session",
    "hriplan.planner.search.ompl_solver",
    "hriplan.planner.timing",
)


def test_constraints_and_help_do_not_import_the_planner():
    """Latency: `constraints` reasons only; OMPL, TOPP-RA, scipy and matplotlib load when a motion is planned."""
    probe = (
        "import sys\n"
        "from hriplan.cli.main import app\n"
        "for argv in (['--help'], ['constraints', sys.argv[1], '-q']):\n"
        "    try:\n"
        "        app(argv, prog_name='hriplan')\n"
        "    except SystemExit as exit:\n"
        "        assert exit.code == 0, exit.code\n"
        f"    print('loaded', sorted(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    example = __import__("pathlib").Path(__file__).parents[2] / "examples" / "handover_full_can.yaml"
    out = subprocess.run([sys.executable, "-c", probe, str(example)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert [line for line in out.stdout.splitlines() if line.startswith("loaded")] == ["loaded []", "loaded []"], (
        out.stdout
    )


COMMANDS = [
    "solve",
    "view",
    "plot",
    "plan",
    "constraints",
    "explain",
    "query",
    "validate",
    "import-kautham",
    "schema",
    "robot info",
    "robot urdf",
    "ontology export",
]


def test_help_has_examples_exit_codes_and_every_option_explained():
    from typer.main import get_command
    from typer.testing import CliRunner

    from hriplan.cli.main import app

    top = CliRunner().invoke(app, ["--help"]).stdout
    assert "Examples:" in top and "Exit codes:" in top and "130" in top
    root = get_command(app)
    for command in COMMANDS:
        text = CliRunner().invoke(app, [*command.split(), "--help"]).stdout
        assert "<bool>" not in text, command
        cmd = root
        for part in command.split():
            cmd = cmd.commands[part]
        unexplained = [p.name for p in cmd.params if not getattr(p, "help", "x")]
        assert not unexplained, (command, unexplained)
    plan_help = CliRunner().invoke(app, ["plan", "--help"]).stdout
    assert "--seed" in plan_help and "--project-start" in plan_help
