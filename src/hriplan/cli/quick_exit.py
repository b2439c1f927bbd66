"""A `hriplan` process ends as soon as its command is done, without tearing the interpreter down.

After the demo's `plan`, Python's own exit cleared every module and freed, one by one, the
~85,000 objects the imports made and pinocchio's and coal's models: 50-90 ms of CPU (8-10 % of
the process) that nobody sees the result of. What an exit must still do is done here, in
Python's order: the functions registered to run at exit (logging's flush, weakref finalizers
such as a temporary directory's removal), then stdout and stderr, Python's and C's (OMPL and
pinocchio print through C's stdio), then `os._exit` with the command's code, as Ctrl-C already
leaves (cli/errors.py). The files a command writes are closed when written (files.py
`write_atomically`), and hriplan registers no finalizer of its own. Where leaving at once could
lose something, the process exits as Python does: another thread still running (a server's, a
pool's), or a stream that cannot be flushed (a closed pipe: Python then reports it, exit code 120).
"""

from __future__ import annotations

import atexit
import os
import sys
import threading
from typing import NoReturn


def exit_now(code: int) -> NoReturn:
    """End the process with `code` once the exit functions ran and the output is flushed."""
    run_exit_functions = getattr(atexit, "_run_exitfuncs", None)  # CPython's own; elsewhere: exit as Python does
    if threading.active_count() == 1 and run_exit_functions is not None:
        run_exit_functions()  # and forgets them: a fallback below does not run them twice
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except (OSError, ValueError):  # a closed pipe or stream: Python's exit reports it
            pass
        else:
            import ctypes  # loaded already by the libraries a command uses; not by `--help`

            ctypes.CDLL(None).fflush(None)
            os._exit(code)
    sys.exit(code)
