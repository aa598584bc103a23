"""A script that starts a run with worker processes but has no ``if __name__ == "__main__":``
guard gets one clear error, not a loop.

Spawned workers (and guard processes, with ``timeout_s``) re-import the parent's main script. An
unguarded ``uqguide.run(...)`` there used to start the run again in every worker, crash on the run
lock, and send the driver into bisecting and retrying every chunk in fresh pools (12 minutes and
6,000 lines of tracebacks before it was killed). Each case runs a real script in a subprocess.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

CONFIG = """{
    "name": "guarded",
    "model": {"name": "lognormal", "a": [0.3, 0.2]},
    "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0, "std": 1} for i in (1, 2)],
    "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 400}],
    "seed": 1%s}"""

#: A safety net for a regression back to the loop, far above a healthy run's few seconds.
STUCK_S = 180


def _script(tmp_path: Path, *, guard: bool, workers: int, timeout_s: float | None) -> Path:
    extra = f', "timeout_s": {timeout_s}' if timeout_s else ""
    call = (f"cfg = uqguide.load_config({CONFIG % extra})\n"
            f"result = uqguide.run(cfg, workers={workers}, out='out')\n"
            "print('n_runs', result.run('mc').n_runs)\n")
    if guard:
        call = "def main():\n" + textwrap.indent(call, "    ") + \
               "\n\nif __name__ == '__main__':\n    main()\n"
    path = tmp_path / "study.py"
    path.write_text("import uqguide\n\n" + call)
    return path


def _run(path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(path)], cwd=path.parent, capture_output=True,
                          text=True, timeout=STUCK_S)


@pytest.mark.slow
@pytest.mark.parametrize("workers, timeout_s", [(2, None), (1, 30.0)],
                         ids=["process-pool", "guard-process"])
def test_an_unguarded_script_gets_one_error_that_names_the_fix(tmp_path, workers, timeout_s):
    done = _run(_script(tmp_path, guard=False, workers=workers, timeout_s=timeout_s))
    assert done.returncode != 0
    assert done.stderr.count("Traceback") == 1, done.stderr[-3000:]
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("uqguide.errors.WorkerStartError:"), last
    assert 'if __name__ == "__main__":' in last
    assert "n_runs" not in done.stdout


@pytest.mark.slow
def test_the_same_script_with_the_guard_runs(tmp_path):
    done = _run(_script(tmp_path, guard=True, workers=2, timeout_s=None))
    assert done.returncode == 0, done.stderr[-3000:]
    assert "n_runs 400" in done.stdout
    assert (tmp_path / "out" / "guarded.h5").is_file()
