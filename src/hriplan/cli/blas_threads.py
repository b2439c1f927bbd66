"""hriplan's commands run numpy's OpenBLAS on one thread (unless OPENBLAS_NUM_THREADS says otherwise).

Loading OpenBLAS starts a thread per core, which spin while the library starts: importing numpy
took 0.15-0.19 s of CPU here instead of 0.12, and on two cores the spinning thread took a core
from the process (the import's wall time 0.26-0.43 s instead of 0.17-0.25). hriplan's matrices
are 3x3 to 6x6 (kinematics, IK) and point clouds of three columns, which OpenBLAS computes on one
thread whatever the setting; a sweep's workers, which inherit the setting, run in parallel
processes already. OpenBLAS reads the variable once, when numpy loads it: this is set before
a command imports numpy (`tests/cli/test_blas_threads.py` checks that nothing imports it sooner).
"""

from __future__ import annotations

import os

VARIABLE = "OPENBLAS_NUM_THREADS"


def use_one_blas_thread() -> None:
    """Ask OpenBLAS for one thread, unless the environment already names a number."""
    os.environ.setdefault(VARIABLE, "1")
