"""The collector paused while a command imports (hriplan/collector.py): on again after, whatever happens
in the block, and frozen only when the block loaded modules. In fresh processes, so that what
the tests' process has imported and frozen does not count."""

from __future__ import annotations

import subprocess
import sys


def _run(code: str) -> list[str]:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


PRELUDE = "import gc, sys\nfrom hriplan.collector import collector_paused_while_importing as paused\n"


def test_paused_while_importing_then_frozen_and_on_again():
    code = PRELUDE + (
        "assert 'fractions' not in sys.modules and gc.get_freeze_count() == 0\n"
        "with paused():\n"
        "    import fractions\n"
        "    print(gc.isenabled())\n"
        "print(gc.isenabled(), gc.get_freeze_count() > 1000, gc.get_count()[0] < 100)\n"
    )
    # Off in the block; after it on, the objects of the process frozen, the young generation empty.
    assert _run(code) == ["False", "True", "True", "True"]


def test_a_block_that_loads_nothing_freezes_nothing():
    code = PRELUDE + "with paused():\n    import gc\nprint(gc.isenabled(), gc.get_freeze_count())\n"
    assert _run(code) == ["True", "0"]


def test_on_again_when_the_block_raises():
    code = PRELUDE + (
        "try:\n"
        "    with paused():\n"
        "        import fractions\n"
        "        raise KeyError\n"
        "except KeyError:\n"
        "    pass\n"
        "print(gc.isenabled(), gc.get_freeze_count() > 0)\n"
    )
    assert _run(code) == ["True", "True"]


def test_a_collector_the_caller_turned_off_stays_off():
    code = PRELUDE + (
        "gc.disable()\nwith paused():\n    import fractions\nprint(gc.isenabled(), gc.get_freeze_count())\n"
    )
    assert _run(code) == ["False", "0"]


def test_commands_leave_the_collector_on_with_their_imports_frozen(tmp_path):
    """`plan` and `validate` import in the paused block; the work (here: a missing file, exit 2)
    runs with the collector on."""
    for command in (["plan", str(tmp_path / "none.yaml")], ["validate", str(tmp_path / "none.json")]):
        code = (
            "import gc, sys\n"
            "from hriplan.cli.main import app\n"
            "try:\n"
            f"    app({command!r}, prog_name='hriplan')\n"
            "except SystemExit as exit:\n"
            "    print(exit.code)\n"
            "print(gc.isenabled(), gc.get_freeze_count() > 50000, 'hriplan.planner.replay' in sys.modules)\n"
        )
        assert _run(code) == ["2", "True", "True", "True"], command
