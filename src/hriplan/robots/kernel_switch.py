"""Whether hriplan uses its compiled kernels: the collision certifier (`free_certifier.py`), the
constraint terms (`planner/constraints/compiled.py`), the kinematic walk of many states
(`batch_kinematics.py`) and the ISO/TS 15066 monitor's selection (`safety/approach_kernels.py`).

Why a switch: importing numba and loading its cached kernels costs ~1 s in every new process,
more than a short `hriplan plan` spends where they help; long runs (benchmarks, a service, a
motion manager) gain. Set HRIPLAN_KERNELS=1 (with numba installed: `pip install hriplan[fast]`),
call `use_kernels(True)`, or `planner.kernels.load_kernels()` to load them at once (`hriplan
serve` does). Without numba the kernels stay off and everything works as before.
"""

from __future__ import annotations

import importlib.util
import os


def _wanted(on: bool) -> bool:
    return on and importlib.util.find_spec("numba") is not None


# Decided once, at import (HRIPLAN_KERNELS=1), not at every check: `in_collision` asks it each state.
_on = _wanted(os.environ.get("HRIPLAN_KERNELS", "") == "1")


def use_kernels(on: bool) -> None:
    """Turn the kernels on or off in this process (on needs numba). Checkers already built keep
    the certifiers they made, but stop asking them when off."""
    global _on
    _on = _wanted(on)


def kernels_on() -> bool:
    """True if the kernels are wanted (use_kernels, else HRIPLAN_KERNELS=1) and numba is installed."""
    return _on
