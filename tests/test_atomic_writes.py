"""Writing a file whole or not at all (files.atomic_path): many writers of one file at once leave
one writer's content, whole, and no temporary; a failed write leaves the old file and no temporary."""

import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from hriplan.files import atomic_path, temporaries, write_atomically

WRITERS = 12
ROUNDS = 5
SIZE = 400_000  # large enough that writes overlap


def _payload(writer: int, size: int = SIZE) -> bytes:
    return bytes([65 + writer]) * size


def test_threads_writing_one_file_at_once_leave_one_whole_content_and_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "cache.json"
    payloads = {_payload(w) for w in range(WRITERS)}
    barrier = threading.Barrier(WRITERS, timeout=30)
    errors: list[BaseException] = []
    foreign: set[int] = set()  # lengths of contents no writer wrote
    reads = 0
    done = threading.Event()

    def write(writer: int) -> None:
        try:
            for _ in range(ROUNDS):
                barrier.wait()
                write_atomically(target, _payload(writer))
        except BaseException as exc:
            errors.append(exc)
            barrier.abort()

    def read() -> None:
        nonlocal reads
        while not done.is_set():
            try:
                content = target.read_bytes()
            except FileNotFoundError:
                continue
            reads += 1
            if content not in payloads:
                foreign.add(len(content))

    reader = threading.Thread(target=read)
    reader.start()
    writers = [threading.Thread(target=write, args=(w,)) for w in range(WRITERS)]
    for t in writers:
        t.start()
    for t in writers:
        t.join()
    done.set()
    reader.join()
    assert not errors, errors[:3]
    assert target.read_bytes() in payloads
    assert reads and not foreign, foreign
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cache.json"]


def test_processes_writing_one_file_at_once_leave_one_whole_content_and_no_temporary(tmp_path: Path) -> None:
    target = tmp_path / "shared" / "cache.json"
    script = (
        "import sys\nfrom hriplan.files import write_atomically\n"
        "w = int(sys.argv[1])\n"
        f"for _ in range({ROUNDS * 4}):\n    write_atomically(sys.argv[2], bytes([65 + w]) * {SIZE})\n"
    )
    processes = [subprocess.Popen([sys.executable, "-c", script, str(w), str(target)]) for w in range(4)]
    assert [p.wait(timeout=120) for p in processes] == [0] * 4
    assert target.read_bytes() in {_payload(w) for w in range(4)}
    assert sorted(p.name for p in target.parent.iterdir()) == ["cache.json"]


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
def test_a_failed_write_keeps_the_old_file_and_removes_its_temporary(tmp_path: Path, error: type) -> None:
    target = write_atomically(tmp_path / "out.json", "old")
    with pytest.raises(error), atomic_path(target) as tmp:
        tmp.write_text("half")
        assert temporaries(target) == [tmp]
        raise error()
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


def test_the_temporary_is_new_each_time_and_the_file_gets_the_mode_a_plain_write_gives(tmp_path: Path) -> None:
    target = tmp_path / "a" / "b.json"  # folders are made
    with atomic_path(target) as first, atomic_path(target) as second:
        assert first != second and first.parent == second.parent == target.parent
    write_atomically(target, "é")
    plain = tmp_path / "plain.json"
    plain.write_text("x")
    assert target.read_text(encoding="utf-8") == "é"
    assert os.stat(target).st_mode == os.stat(plain).st_mode


def test_an_interrupted_command_removes_the_temporaries_of_the_outputs_it_named(tmp_path: Path, monkeypatch) -> None:
    """Ctrl-C leaves by os._exit (cli/errors.py), past every `finally`: the command's named outputs'
    temporaries are found by name and removed, and nothing else."""
    from hriplan.cli import outputs

    monkeypatch.setattr(outputs, "_NAMED", [])
    kept = write_atomically(tmp_path / "kept.json", "{}")
    target = outputs.file_output(tmp_path / "out.json")
    folder = outputs.directory_output(tmp_path / "plots")
    open_writes = [atomic_path(target), atomic_path(folder / "joint_positions.png"), atomic_path(tmp_path / "other")]
    temporaries_made = [write.__enter__() for write in open_writes]  # interrupted inside the block
    assert all(t.exists() for t in temporaries_made)
    outputs.remove_partial_outputs()
    assert [t.exists() for t in temporaries_made] == [False, False, True]  # "other" is no output of the command
    assert kept.read_text() == "{}" and list(folder.iterdir()) == []


def test_an_interrupted_plot_leaves_no_temporary_in_its_step_folders(tmp_path: Path, monkeypatch) -> None:
    """`plot -o DIR` writes DIR/STEP/*.png: Ctrl-C left DIR/STEP/.joint_positions.png.*.tmp (the
    clean-up looked in DIR only). Another file in the folders stays."""
    from hriplan.cli import outputs

    monkeypatch.setattr(outputs, "_NAMED", [])
    plots = outputs.directory_output(tmp_path / "plots")
    step = plots / "take_can"
    step.mkdir(parents=True)
    tmp = step / ".joint_positions.png.5f3a9c.tmp"  # as atomic_path names it, left by a kill
    tmp.write_bytes(b"half a png")
    (step / "kept.png").write_bytes(b"png")
    assert temporaries(step / "joint_positions.png") == [tmp]
    outputs.remove_partial_outputs()  # what the interrupt handler runs
    assert sorted(p.name for p in step.iterdir()) == ["kept.png"]
