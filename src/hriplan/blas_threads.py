"""One BLAS thread per hriplan process (unless the environment names a number): a command's, and
each worker of a sweep, which are the parallelism there (children inherit the setting).

Loading numpy's OpenBLAS starts a thread per core, which spin while the library starts: importing
numpy took 0.15-0.17 s of CPU here instead of 0.12, and on two cores the spinning thread took a
core from the process (the import's wall time 0.26-0.43 s instead of 0.17-0.25). hriplan's
matrices are 3x3 to 6x6 (kinematics, IK) and three-column point clouds, which OpenBLAS computes on
one thread whatever the setting. A BLAS library reads the variables once, when it loads: set them
before numpy is imported (the command line does so when it is imported itself).
"""

from __future__ import annotations

import os

VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def single_threaded_blas() -> None:
    """Ask every BLAS library for one thread, unless the environment already names a number."""
    for name in VARIABLES:
        os.environ.setdefault(name, "1")
