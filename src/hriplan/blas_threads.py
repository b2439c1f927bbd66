"""One BLAS thread per hriplan process (unless the environment names a number): a command's, each
worker of a sweep or of the service, which are the parallelism there (children inherit the
setting), and a process that imports the plug-in API before numpy (a motion manager).

Loading numpy's OpenBLAS starts a thread per core, which spin while the library starts: importing
numpy took 0.15-0.17 s of CPU here instead of 0.12, and on two cores the spinning thread took a
core from the process (the import's wall time 0.26-0.43 s instead of 0.17-0.25). Most of hriplan's
matrices are 3x3 to 6x6 (kinematics, IK) and three-column point clouds, which OpenBLAS computes on
one thread whatever the setting; TOPP-RA's set-up multiplies (gridpoints x 2n) by (2n x 4n), which
it threads for MADAR's two arms: 2-3 times the CPU on two busy cores (benchmarks/bench_toppra.py).
A BLAS library reads the variables once, when it loads: set them before numpy is imported (the
command line and api.py do so when they are imported themselves).
"""

from __future__ import annotations

import os

VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def single_threaded_blas() -> None:
    """Ask every BLAS library for one thread, unless the environment already names a number."""
    for name in VARIABLES:
        os.environ.setdefault(name, "1")
