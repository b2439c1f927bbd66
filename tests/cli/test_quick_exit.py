"""A `hriplan` process leaves at once when its command is done (cli/quick_exit.py), losing nothing:
exit codes, Python's and C's buffered output, exit functions, another thread's work."""

import os
import subprocess
import sys

# Buffered as a user's process is (this sandbox sets PYTHONUNBUFFERED, which unbuffers C's stdio too).
BUFFERED = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}

# The process's own command line (app() reads sys.argv), with what an exit must not lose: an exit
# function, which leaves output in C's stdio buffer (a pipe's is flushed only when full or at
# exit), and the line Python printed before the command.
PROCESS = """
import atexit, ctypes, sys, threading, time
from pathlib import Path
from hriplan.cli.main import app
where, extra, sys.argv = Path(sys.argv[1]), sys.argv[2], ["hriplan", *sys.argv[3:]]
atexit.register(lambda: ((where / "atexit").write_text("ran"), ctypes.CDLL(None).printf(b"from C\\n")))
print("from Python")
if extra == "no_private":  # a Python without CPython's private atexit._run_exitfuncs
    del atexit._run_exitfuncs
if extra == "thread":
    threading.Thread(target=lambda: (time.sleep(0.3), (where / "thread").write_text("done"))).start()
app()
"""


def _process(tmp_path, extra, *argv):
    out = subprocess.run(
        [sys.executable, "-c", PROCESS, str(tmp_path), extra, *argv],
        capture_output=True,
        text=True,
        timeout=300,
        env=BUFFERED,
    )
    ran = {p.name: p.read_text() for p in tmp_path.iterdir()}
    return out.returncode, out.stdout, out.stderr, ran


def test_exit_codes_output_and_exit_functions_are_kept(tmp_path):
    code, out, err, ran = _process(tmp_path, "", "--version")
    assert (code, err, ran) == (0, "", {"atexit": "ran"})
    assert sorted(out.splitlines()) == ["from C", "from Python", "hriplan 0.1.0"]
    code, out, err, ran = _process(tmp_path, "", "plan", str(tmp_path / "missing.yaml"))
    assert code == 2 and err.startswith("error: ") and "missing.yaml" in err and ran == {"atexit": "ran"}
    assert sorted(out.splitlines()) == ["from C", "from Python"]
    code, _, err, _ = _process(tmp_path, "", "plann")
    assert code == 2 and "No such command 'plann'" in err


def test_another_thread_finishes_first(tmp_path):
    code, out, _, ran = _process(tmp_path, "thread", "--version")
    assert code == 0 and ran == {"atexit": "ran", "thread": "done"}
    assert "from C" in out


def test_without_cpythons_private_exit_runner_the_process_exits_as_python_does(tmp_path):
    code, out, err, ran = _process(tmp_path, "no_private", "--version")
    assert (code, err, ran) == (0, "", {"atexit": "ran"})
    assert sorted(out.splitlines()) == ["from C", "from Python", "hriplan 0.1.0"]


def test_in_process_calls_still_raise_system_exit():
    """A call with arguments (a test, a script) is not the process's command line: SystemExit."""
    probe = (
        "from hriplan.cli.main import app\n"
        "try:\n"
        "    app(['--version'])\n"
        "except SystemExit as done:\n"
        "    print('caught', done.code)\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.splitlines() == ["hriplan 0.1.0", "caught 0"]
