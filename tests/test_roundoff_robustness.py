"""The round-off robustness check: paper-figure checks and golden baselines under round-off.

Two CPUs give different last bits; so do the compiled and the NumPy kernels of one simulator,
and so does a 1e-12 relative move of the inputs. Every golden baseline and every paper-figure
check must hold in all three, or it asserts something that a user on another machine would see
fail without any change of the code:

- ``perturbed``: every model input moved by 1e-12 relative (``UQGUIDE_PERTURB``);
- ``numpy``: the NumPy reference kernels instead of the compiled ones (the test oracles of
  ``tests/oracles``, put in their place in this process).

A paper-figure check holds under round-off when every row of the nominal report keeps its
verdict and every row marked reproducible moves by less than 1 % (a tenth of the tightest
tolerance the reports use, 10 %); chaotic rows show a robust statistic and keep their verdict.
A golden baseline holds when the gate passes; the statistics its round-off ensemble found
chaotic (``scripts/update_golden.py``) are reported by the gate, not checked.

Cheap cases run in the default suite; the others are marked ``roundoff`` and run by ``.ci/run``
(``python -m pytest -q -m roundoff``).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from uqguide.config.run_config import load_config
from uqguide.gate.check import check_result, read_baseline
from tests.oracles import substituted
from uqguide.models.roundoff import PERTURB_ENV
from uqguide.papers import nominal_report
from uqguide.driver.propagate import run

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "golden"
MODES = ("perturbed", "numpy")

# Cases that cost more than about 1 CPU-s in a mode (the NumPy kernels of the closed loops run
# 50-100x slower than the compiled ones): they run in the marked suite only. Every simulator
# keeps cheaper cases in the default suite (ft_as: its dispersion, perturbed; gmm: the
# small dispersion and the nominal runs).
EXPENSIVE = {
    ("ft_as_nominal", "perturbed"), ("gmm_ftc_dispersion", "numpy"),
    ("gmm_ftc_dispersion_smooth", "numpy"), ("gmm_ftc_nominal", "numpy"),
    ("ftcapn_table5", "numpy"), ("ftcapn_table5", "perturbed"),
    ("ftcapn_table4_rotating", "numpy"), ("ftcapn_pce_table3", "numpy"),
    ("ftcapn_pce_table3", "perturbed"), ("gmm_dispersion", "numpy"),
    ("gmm_dispersion_f2", "numpy"), ("gmm_dispersion_small", "numpy"),
    ("gmm_ftc_dispersion", "perturbed"), ("gmm_ftc_dispersion_smooth", "perturbed"),
    ("gmm_dispersion", "perturbed"), ("gmm_dispersion_f2", "perturbed"),
    # the GMM paper's nominal figures under the NumPy kernel: gmm_nominal stays here, its two
    # variants (the E configuration, the second figure set) run in the marked suite
    ("gmm_nominal_e", "numpy"), ("gmm_nominal_f2", "numpy"),
}  # fmt: skip
# FT-AS's NumPy reference costs about 20 ms per step of a batch (its kernel 0.1 ms): the paper
# profile (300,000 steps) would take hours. FT-AS is checked under round-off in the perturbed
# mode, its report carries a 5-member round-off ensemble of its own, and the NumPy reference is
# held to the compiled kernel over the saturated start (tests/test_ft_as_model.py).
SKIPPED = {("ft_as_nominal", "numpy"), ("ft_as_dispersion", "numpy")}


def _cases(names: list[str]) -> list:
    out = []
    for name in names:
        for mode in MODES:
            if (name, mode) in SKIPPED:
                continue
            marks = [pytest.mark.roundoff] if (name, mode) in EXPENSIVE else []
            out.append(pytest.param(name, mode, id=f"{name}-{mode}", marks=marks))
    return out


@contextmanager
def _mode(monkeypatch: pytest.MonkeyPatch, mode: str) -> Iterator[None]:
    if mode == "perturbed":
        monkeypatch.setenv(PERTURB_ENV, "1e-12")
        yield
    else:
        with substituted():
            yield


GOLDEN_NAMES = sorted(p.stem for p in GOLDEN.glob("*.yaml"))


@pytest.mark.parametrize(("name", "mode"), _cases(GOLDEN_NAMES))
def test_golden_baseline_holds_under_roundoff(name: str, mode: str, monkeypatch) -> None:
    monkeypatch.delenv(PERTURB_ENV, raising=False)
    baseline = read_baseline(GOLDEN / f"{name}.baseline.json")
    with _mode(monkeypatch, mode):
        report = check_result(run(load_config(GOLDEN / f"{name}.yaml")), baseline)
    assert report.passed, f"{mode}: " + report.render()


NOMINAL_NAMES = sorted(p.stem for p in (ROOT / "configs").glob("*_nominal*.yaml"))


def _rows(name: str) -> list:
    return nominal_report(load_config(ROOT / "configs" / f"{name}.yaml").model)


@pytest.mark.parametrize(("name", "mode"), _cases(NOMINAL_NAMES))
def test_paper_figure_checks_hold_under_roundoff(name: str, mode: str, monkeypatch) -> None:
    monkeypatch.delenv(PERTURB_ENV, raising=False)
    exact = _rows(name)
    with _mode(monkeypatch, mode):
        moved = _rows(name)
    assert [r.quantity for r in moved] == [r.quantity for r in exact]
    for a, b in zip(exact, moved):
        if a.kind == "timing":
            continue
        assert b.ok == a.ok, f"{mode}: {a.quantity}: verdict {a.ok} -> {b.ok} ({a.value} -> " \
                             f"{b.value})"
        if a.kind != "reproducible":
            continue
        if isinstance(a.value, float) and isinstance(b.value, float):
            assert b.value == pytest.approx(a.value, rel=1e-2, abs=1e-12), f"{mode}: {a.quantity}"
        else:
            assert b.value == a.value, f"{mode}: {a.quantity}"
