"""The demo's collision builds (issue 21): how many collision models, people models and pinocchio
GeometryData the demo's `plan` makes, and the CPU time of building them, for this checkout and
another tree in the same run (fresh processes, taking turns).

Run: PYTHONPATH=src .venv/bin/python benchmarks/bench_builds.py [--src /tmp/base/src] [--rounds 3]
The time is the CPU spent in CollisionChecker.set_world and the builds it starts or leaves for the
first question (`_ready`, `_people_ready`; the outermost call only); the plan's work is the CPU
of `hriplan plan examples/handover_full_can.yaml` in the process after its imports (the
derivation cache on disk is warm after any earlier run of the demo).
"""

from __future__ import annotations

import contextlib
import io
import statistics
import tempfile
import time
from pathlib import Path

from cpu_spent import outermost_cpu
from trees import runs_by_tree

EXAMPLE = Path(__file__).parents[1] / "examples" / "handover_full_can.yaml"
# (label, attributes of CollisionChecker counted; one a tree lacks is left out)
COUNTED = (
    ("collision models built", ("_build_new",)),
    ("people models built", ("_build_person_models", "_new_person_models")),
)
TIMED = ("set_world", "_ready", "_people_ready")


def measure() -> dict:
    """Plan the demo in this process and count its builds."""
    import pinocchio as pin

    from hriplan.cli.main import app
    from hriplan.robots.collision import CollisionChecker

    found = {label: 0 for label, _ in COUNTED} | {"GeometryData made": 0, "build CPU ms": 0.0}
    for label, names in COUNTED:
        for name in (n for n in names if hasattr(CollisionChecker, n)):
            setattr(CollisionChecker, name, _counting(getattr(CollisionChecker, name), label, found))
    pin.GeometryModel.createData = _counting(pin.GeometryModel.createData, "GeometryData made", found)
    depth = [0]

    def add_build(seconds: float) -> None:
        found["build CPU ms"] += 1e3 * seconds

    for name in (n for n in TIMED if hasattr(CollisionChecker, n)):
        setattr(CollisionChecker, name, outermost_cpu(getattr(CollisionChecker, name), depth, add_build))
    with tempfile.TemporaryDirectory() as out:
        started = time.process_time()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            with contextlib.suppress(SystemExit):  # given its arguments, the CLI ends with sys.exit, not
                app(["plan", str(EXAMPLE), "-o", f"{out}/plan.json"], prog_name="hriplan")  # os._exit
        found["plan work CPU ms"] = 1e3 * (time.process_time() - started)
    return found


def _counting(original, label: str, found: dict):
    def counted(*a, **k):
        found[label] += 1
        return original(*a, **k)

    return counted


def main() -> None:
    runs, other = runs_by_tree(__doc__.splitlines()[0], __file__, measure)
    labels = list(runs["this checkout"][0])
    trees = list(runs)
    print(f"| the demo's plan, median of {len(runs['this checkout'])} | " + " | ".join(trees) + " |")
    print("|---|" + "---|" * len(trees))
    for label in labels:
        values = [statistics.median(r[label] for r in runs[tree]) for tree in trees]
        print(f"| {label} | " + " | ".join(f"{v:.0f}" for v in values) + " |")


if __name__ == "__main__":
    main()
