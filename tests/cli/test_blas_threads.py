"""One BLAS thread in hriplan's commands and in a process that imports the plug-in API first
(hriplan/blas_threads.py, asked for by cli/main.py and api.py): set before numpy loads, a user's
own setting kept. In fresh processes: OpenBLAS reads the variable once, when it loads."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

PROBE = (
    "import os, sys\n"
    "import {module}\n"
    "print('numpy' in sys.modules, os.environ.get('OPENBLAS_NUM_THREADS'), os.environ.get('OMP_NUM_THREADS'))\n"
    "import numpy\n"
    "print(len(os.listdir('/proc/self/task')))\n"  # the process's threads, OpenBLAS's included
)


def _probe(env_value: str | None, module: str = "hriplan.cli.main") -> list[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    if env_value is not None:
        env["OPENBLAS_NUM_THREADS"] = env_value
    probe = PROBE.format(module=module)
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    return out.stdout.split()


@pytest.mark.skipif(not Path("/proc/self/task").is_dir() or (os.cpu_count() or 1) < 2, reason="counts Linux threads")
def test_the_command_line_asks_one_blas_thread_before_numpy_loads():
    # Nothing the command line imports loads numpy before the setting; then numpy starts no thread.
    assert _probe(None) == ["False", "1", "1", "1"]


@pytest.mark.skipif(not Path("/proc/self/task").is_dir() or (os.cpu_count() or 1) < 2, reason="counts Linux threads")
def test_a_users_setting_is_kept():
    assert _probe("2") == ["False", "2", "1", "2"]  # the main thread and one of OpenBLAS's


@pytest.mark.skipif(not Path("/proc/self/task").is_dir() or (os.cpu_count() or 1) < 2, reason="counts Linux threads")
def test_the_plug_in_api_asks_one_blas_thread_before_its_imports_load_numpy():
    # numpy is loaded by the API's own imports, after the setting; a user's setting is kept.
    assert _probe(None, "hriplan.api") == ["True", "1", "1", "1"]
    assert _probe("2", "hriplan.api") == ["True", "2", "1", "2"]
