"""Lazy imports: the quick commands do not import chaospy, scipy.stats or pandas (the CPU
figures are measured by benchmarks/startup.py, not asserted here)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PROBE = """
import sys
from uqguide.cli import main
try:
    main(sys.argv[1:], prog_name="uqguide")
except SystemExit:
    pass
print("HEAVY:" + ",".join(m for m in ("chaospy", "scipy.stats", "sklearn", "pandas")
                          if m in sys.modules),
      file=sys.stderr)
"""


def _heavy(*args: str) -> str:
    p = subprocess.run([sys.executable, "-c", PROBE, *args], capture_output=True, text=True,
                       cwd=ROOT, timeout=120)
    assert p.returncode == 0, p.stderr
    return [ln for ln in p.stderr.splitlines() if ln.startswith("HEAVY:")][-1][len("HEAVY:"):]


@pytest.mark.parametrize("args", [
    ("--help",),
    ("validate", "configs/ftcapn_table5.yaml"),       # Monte Carlo and adaptive PCE
    ("validate", "configs/ftcapn_pce_table3.yaml"),   # tensor and Smolyak PCE
])
@pytest.mark.slow
def test_quick_commands_import_no_chaospy_scipy_stats_or_pandas(args):
    assert _heavy(*args) == ""


def test_import_uqguide_and_dir_import_no_numpy_numba_pandas_or_matplotlib():
    """``import uqguide`` and ``dir(uqguide)`` name the API without importing it; resolving
    one of the classes imports its module, still without the compiled kernels or the
    plotting and table libraries."""
    probe = """
import sys
import uqguide
names = dir(uqguide)
heavy = ("numpy", "numba", "pandas", "matplotlib", "h5py", "pydantic", "chaospy", "scipy")
print("BARE:" + ",".join(m for m in heavy if m in sys.modules))
print("DIR:" + ",".join(n for n in ("run", "load_config", "read_result", "Result",
                                    "RunConfig", "Model", "Method") if n in names))
for name in ("Result", "RunConfig", "Model", "Method", "run"):
    getattr(uqguide, name)
print("USED:" + ",".join(m for m in ("numba", "pandas", "matplotlib") if m in sys.modules))
"""
    p = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    lines = dict(ln.split(":", 1) for ln in p.stdout.splitlines() if ":" in ln)
    assert lines["BARE"] == ""
    assert lines["DIR"] == "run,load_config,read_result,Result,RunConfig,Model,Method"
    assert lines["USED"] == ""


@pytest.mark.slow
def test_baseline_and_check_import_none_of_them(tmp_path):
    base = str(tmp_path / "b.json")
    assert _heavy("baseline", "tests/data/result_format1.h5", "-o", base) == ""
    assert _heavy("check", "tests/data/result_format1.h5", "--baseline", base) == ""


def test_the_three_sigma_literals_are_scipys():
    from scipy import stats

    from uqguide.stats.quantiles import THREE_SIGMA

    assert THREE_SIGMA == (float(stats.norm.cdf(-3.0)), 0.5, float(stats.norm.cdf(3.0)))


def test_report_times_are_checked_on_the_grid_the_runs_produce():
    """``uqguide run`` checks the report times against the model's grid before it starts the
    workers; for FTCAPN the grid comes from its nominal run (a run of the compiled kernel,
    which the driver loads anyway before a pool starts), and it is the grid the runs produce."""
    import numpy as np

    import uqguide
    from uqguide.config.report_times import model_time_grid

    c = uqguide.load_config(ROOT / "configs" / "ftcapn_table3.yaml")  # (checks its report times)
    grid = model_time_grid(c.model, c.outputs)
    run = c.model.evaluate(np.zeros((1, c.space.dim)), c.space.names, ["omega_s"]).time
    assert np.array_equal(grid, run) and grid[-1] == 77.5
