"""Golden statistics: every config in tests/golden/ against its baseline, through the gate.

Each golden config is a small, fast version of a shipped config (``configs/<name>.yaml``) or a
benchmark; ``scripts/update_golden.py`` writes its baseline, and only it does (on purpose, with
the verdict against the old baseline printed first). The same config and seed give identical
numbers, so a pass is normally exact; the gate's tolerances (4 combined standard errors for Monte
Carlo, the baseline's relative tolerance for PCE) are what a change of a dependency or of the
code may move a statistic before this test fails. A config that no longer equals the one the
baseline was written from fails too: a baseline describes one config.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from uqguide.config.run_config import load_config
from uqguide.gate.check import (
    ABSENT, check_result, config_differences, format_differences, read_baseline,
)
from uqguide.driver.propagate import run

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "golden"
sys.path.insert(0, str(ROOT / "scripts"))

from update_golden import baseline_path, missing_registrations  # noqa: E402

CONFIGS = sorted(GOLDEN.glob("*.yaml"))
FIX = "if the change is on purpose, run `python scripts/update_golden.py {name}` and commit"


# Goldens that run with the slow tests (.ci/run runs them every time): the two of over 1.5
# CPU-s whose simulator has no cheaper golden, and the second and third dispersion studies of
# a simulator whose cheapest one stays here (gmm_ftc_dispersion, gmm_dispersion_small).
SLOW = {"ftcapn_table5", "ft_as_nominal", "gmm_ftc_dispersion_smooth", "gmm_dispersion",
        "gmm_dispersion_f2"}


@pytest.mark.parametrize("path", [
    pytest.param(p, id=p.stem, marks=[pytest.mark.slow] if p.stem in SLOW else [])
    for p in CONFIGS])
def test_golden_config_matches_its_baseline(path: Path) -> None:
    missing = missing_registrations(path)
    if missing:
        pytest.skip(f"{', '.join(missing)} not registered yet")
    bpath = baseline_path(path)
    assert bpath.is_file(), f"{bpath.name} missing: run `python scripts/update_golden.py " \
                            f"{path.stem}` and commit it"
    baseline = read_baseline(bpath)
    result = run(load_config(path))
    report = check_result(result, baseline, source=str(bpath.relative_to(ROOT)))
    assert report.passed, report.render() + "\n" + FIX.format(name=path.stem)
    changed = [d for d in config_differences(baseline.config, result.config)
               if d[1] is not ABSENT]
    assert not changed, (f"{path.name} no longer is the config of its baseline: "
                         f"{format_differences(changed)}; " + FIX.format(name=path.stem))


def test_every_shipped_config_has_a_golden_version() -> None:
    shipped = sorted((ROOT / "configs").glob("*.yaml"))
    missing = [p.name for p in shipped if not (GOLDEN / p.name).is_file()]
    assert not missing, (f"no golden version of {', '.join(missing)}: add a small, fast copy "
                         f"as tests/golden/<same name>.yaml and run scripts/update_golden.py")
