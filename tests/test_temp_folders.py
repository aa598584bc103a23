"""multiprocessing's temporary folder made one of uqguide's marked folders: removed at a normal
exit, swept after a kill, and nothing else swept."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from uqguide.core import temp_folders
from uqguide.core.temp_folders import MULTIPROCESSING

ROOT = Path(__file__).resolve().parents[1]

# A process that gives multiprocessing its folder, says where multiprocessing puts a socket,
# then exits (argv[1] == "exit") or waits to be killed.
CHILD = """
import sys
from multiprocessing import connection, util
from pathlib import Path
from uqguide.core.temp_folders import MULTIPROCESSING, mark_of, multiprocessing_folder

multiprocessing_folder()
folder = util.get_temp_dir()
print(folder, connection.arbitrary_address("AF_UNIX"), mark_of(Path(folder), MULTIPROCESSING),
      flush=True)
if sys.argv[1] == "wait":
    sys.stdin.read()
"""


@pytest.fixture
def temp_folder(tmp_path, monkeypatch) -> Path:
    """An empty temporary folder for this process and its children."""
    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    monkeypatch.setenv("TMPDIR", str(folder))
    return folder


def _child(how: str) -> tuple[subprocess.Popen, list[str]]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-c", CHILD, how], env=env, text=True,
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE)
    assert proc.stdout is not None
    folder, socket, mark = proc.stdout.readline().split(" ", 2)
    return proc, [folder, socket, mark]


def test_multiprocessing_folder_is_marked_and_removed_at_exit(temp_folder):
    proc, (folder, socket, mark) = _child("exit")
    assert proc.wait(timeout=30) == 0
    assert Path(folder).parent == temp_folder and Path(socket).parent == Path(folder)
    assert Path(folder).name.startswith(MULTIPROCESSING.prefix)
    assert f"'pid': {proc.pid}," in mark
    # no longer than multiprocessing's own name: a socket's path in it (at most 107 bytes on
    # Linux) is no longer than before
    assert len(Path(folder).name) == len("pymp-12345678")
    assert list(temp_folder.iterdir()) == []


def test_a_killed_process_folder_is_swept_and_only_it(temp_folder):
    killed, (left, _, _) = _child("wait")
    live, (kept, _, _) = _child("wait")
    try:
        killed.send_signal(signal.SIGKILL)
        killed.wait(timeout=30)
        assert Path(left).is_dir()  # what a killed run left before the sweep
        (temp_folder / "pymp-abcdefgh").mkdir()  # multiprocessing's own, not uqguide's
        users = temp_folder / f"{MULTIPROCESSING.prefix}mine"  # named like one, unmarked
        users.mkdir()
        copied = temp_folder / f"{MULTIPROCESSING.prefix}copy"
        copied.mkdir()
        (copied / MULTIPROCESSING.mark).write_text(json.dumps({"pid": killed.pid,
                                                               "folder": Path(left).name}))
        assert temp_folders.sweep() == 1
        assert not Path(left).exists() and Path(kept).is_dir()
        assert {p.name for p in temp_folder.iterdir()} == {
            Path(kept).name, "pymp-abcdefgh", users.name, copied.name}
    finally:
        live.communicate("")
    assert not Path(kept).exists()


def test_the_folder_a_process_has_is_kept(monkeypatch, tmp_path):
    from multiprocessing import process

    monkeypatch.setitem(process.current_process()._config, "tempdir", str(tmp_path))
    assert temp_folders.multiprocessing_folder() == str(tmp_path)


@pytest.mark.parametrize("command", ["validate", "run"])
def test_run_and_validate_start_by_sweeping_a_killed_runs_folders(temp_folder, tmp_path,
                                                                   command):
    from click.testing import CliRunner

    from uqguide.cli import main

    dead = subprocess.Popen(["true"])
    dead.wait()
    pid = dead.pid
    left = []
    for kind, name in ((temp_folders.FMU, f"uqguide-fmu-{pid}-abcdefgh"),
                       (MULTIPROCESSING, "uqmp-abcdefgh")):
        folder = temp_folder / name
        folder.mkdir()
        (folder / kind.mark).write_text(json.dumps({"pid": pid, "folder": name}))
        left.append(folder)
    # the sweep comes first: even a config that is not there finds them gone
    res = CliRunner().invoke(main, [command, str(tmp_path / "absent.yaml")])
    assert res.exit_code == 2, res.output
    assert not any(p.exists() for p in left)
