"""Start-up (issue 21): a command imports what it uses. Asserted on `sys.modules` after the command
ran in a fresh process, not on timing; `benchmarks/bench_startup.py` measures the seconds."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "handover_full_can.yaml"

# Never used by `plan` (without --html/--plots) or `validate`: plotting (TOPP-RA imports pyplot at
# module level), the viewer, the service, the sweep engines' data and cluster libraries, and the
# Pellet route's OWL library (the derivation is cached on disk, or the in-process rules reason).
UNUSED = ("matplotlib", "matplotlib.pyplot", "meshcat", "fastapi", "uvicorn", "pyarrow", "ray", "owlready2")

PROBE = (
    "import sys\n"
    "from hriplan.cli.main import app\n"
    "try:\n"
    "    app(sys.argv[2:], prog_name='hriplan')\n"
    "except SystemExit as exit:\n"
    "    assert exit.code in (0, None), exit.code\n"
    "print('loaded:', ' '.join(m for m in sys.argv[1].split(',') if m in sys.modules))\n"
)


def loaded_after(args: list[str], watched: tuple[str, ...], env: dict[str, str] | None = None) -> list[str]:
    """Which of `watched` are in sys.modules after `hriplan ARGS` ran in a fresh process."""
    out = subprocess.run(
        [sys.executable, "-c", PROBE, ",".join(watched), *args],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
    )
    assert out.returncode == 0, out.stderr
    [line] = [line for line in out.stdout.splitlines() if line.startswith("loaded:")]
    return line.removeprefix("loaded:").split()


# Not used by a warm `plan` with the default planner: the ontology's triples (the schema is on disk,
# every situation's reasoning cached), OMPL (CBiRRT plans; OMPL's seeds come from search/seeds.py)
# and scipy (timing's spline is planner/natural_spline.py; only a leave phase minimises with scipy).
WARM_PLAN_UNUSED = ("rdflib", "hriplan.ontology.schema_reader", "ompl", "hriplan.planner.search.ompl_solver", "scipy")


def test_plan_and_validate_import_no_plotting_viewer_or_service(tmp_path):
    plan = ["plan", str(EXAMPLE), "-q", "-o", str(tmp_path / "can.json")]
    loaded_after(plan, UNUSED)  # warm: the derivation and the schema cached on disk, as a second `plan` finds them
    assert loaded_after(plan, UNUSED + WARM_PLAN_UNUSED) == []
    validate = ["validate", str(tmp_path / "can.take_can.json"), "-q"]
    # Without --task, validate re-checks the file: no task pipeline, no rules, no planner search or timing.
    # Its ISO/TS 15066 policy reads the ontology's values from the schema on disk: no rdflib either.
    reasoning = ("hriplan.tasks.pipeline", "hriplan.rules.infer", "toppra", "ompl", "scipy", "rdflib")
    assert loaded_after(validate, UNUSED + reasoning) == []


def test_toppra_plots_and_splines_still_load_what_they_use():
    """TOPP-RA's modules get stand-ins for pyplot and scipy while they are imported (planner/
    timing.py): nothing of matplotlib or scipy loads with them, and toppra's own plots and splines
    load the real modules when used."""
    probe = (
        "import sys\n"
        "import numpy as np\n"
        "import hriplan.planner.timing\n"
        "import toppra, toppra.algorithm.algorithm as algorithm, toppra.parametrizer as parametrizer\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('matplotlib', 'scipy')))\n"
        "print(type(algorithm.plt.figure()).__name__)\n"
        "import matplotlib.pyplot\n"
        "print(algorithm.plt.plot is matplotlib.pyplot.plot, parametrizer.plt.subplot is matplotlib.pyplot.subplot)\n"
        "print(type(sys.modules['matplotlib.pyplot']).__name__)\n"
        "path = toppra.SplineInterpolator([0.0, 1.0, 3.0], [[0.0], [1.0], [0.0]], bc_type='natural')\n"
        "from scipy.interpolate import CubicSpline\n"
        "print(type(path.cspl) is CubicSpline, float(path(2.0)[0]) == float(CubicSpline([0, 1, 3], [0, 1, 0], bc_type='natural')(2.0)))\n"
        "print(type(sys.modules['scipy.interpolate']).__name__)\n"
    )
    assert _probed(probe).splitlines() == ["[]", "Figure", "True True", "module", "True True", "module"]


def test_toppra_imported_after_matplotlib_is_left_alone():
    probe = (
        "import matplotlib.pyplot\n"
        "import hriplan.planner.timing\n"
        "import toppra.algorithm.algorithm as algorithm\n"
        "print(algorithm.plt is matplotlib.pyplot)\n"
    )
    assert _probed(probe).split() == ["True"]


def _probed(probe: str) -> str:
    """What `probe` prints, run in a fresh process with a non-interactive matplotlib backend."""
    env = dict(os.environ, MPLBACKEND="Agg")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=300, env=env)
    assert out.returncode == 0, out.stderr
    return out.stdout
