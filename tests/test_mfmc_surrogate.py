"""Issue 30 item 1: a PCE of the study as a fidelity level of ``mfmc``
(``fidelities: [{dt: 0.01}, {surrogate: tpce}]``).

The model is ``euler_decay`` (explicit Euler on ``y' = -k y``, ``k ~ U(a, b)`` independent of
``y0``); its level with step ``dt`` has the exact mean ``E[y0] ((1 - a dt)^(n+1) -
(1 - b dt)^(n+1)) / ((n + 1) dt (b - a))`` at ``t = n dt``. The PCE is fitted to the model as
configured, ``dt = 0.1``, whose mean differs from ``dt = 0.01``'s by more than the estimate's
error: the estimate must be ``dt = 0.01``'s all the same (the surrogate only cancels noise).
"""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.driver.execution import ProcessExecutor, SerialExecutor
from uqguide.driver.propagate import run
from uqguide.errors import ConfigError

K_LOW, K_HIGH, T_END = 0.5, 1.5, 2.0
FINE, COARSE = 0.01, 0.1
#: seconds per run pinned (the allocation a function of the config alone): the fine level's
#: 200 steps against a polynomial's few multiply-adds
COSTS = [1e-4, 1e-7]


def _exact_mean(dt: float) -> float:
    n = round(T_END / dt)
    return ((1 - K_LOW * dt) ** (n + 1) - (1 - K_HIGH * dt) ** (n + 1)) / \
        ((n + 1) * dt * (K_HIGH - K_LOW))


def _raw(seed: int = 11, **mfmc) -> dict:
    return {
        "model": {"name": "euler_decay", "dt": COARSE, "t_end": T_END},
        "inputs": [{"name": "k", "dist": "uniform", "low": K_LOW, "high": K_HIGH},
                   {"name": "y0", "dist": "normal", "mean": 1.0, "std": 0.1}],
        "outputs": ["y_end"],
        "methods": [{"name": "pce_tensor", "label": "tpce", "m": 5},
                    {"name": "mfmc", "fidelities": [{"dt": FINE}, {"surrogate": "tpce"}],
                     "costs": COSTS, "n_pilot": 50, "budget_cpu_s": 0.05, "chunk_size": 1024,
                     "bootstrap": 0, **mfmc}],
        "seed": seed}


@pytest.mark.parametrize("seed", [11, pytest.param(12, marks=pytest.mark.slow),
                                  pytest.param(13, marks=pytest.mark.slow)])
def test_a_pce_level_leaves_the_estimate_the_models_and_cuts_its_error(seed):
    result = run(validate_config(_raw(seed)))
    pce, mf = result.runs[0].estimate, result.runs[1]
    st, d = mf.estimate.stats["y_end"], mf.estimate.diagnostics
    assert mf.success, mf.message
    exact = _exact_mean(FINE)
    # unbiased for the fine model: within 4 of its standard errors of dt = 0.01's mean ...
    assert abs(st.mean[0] - exact) < 4 * st.sem[0]
    # ... and not the surrogate's, whose mean (dt = 0.1's) lies many standard errors away
    assert abs(pce.stats["y_end"].mean[0] - _exact_mean(COARSE)) < 1e-6
    assert abs(_exact_mean(COARSE) - exact) > 10 * st.sem[0]
    # the surrogate's rows capped at surrogate_ratio (100) times the fine level's (both
    # floored from one real m_0), and the budget spent
    m0, m1 = d["runs_per_level"]
    assert 100 * m0 <= m1 < 100 * (m0 + 1) and "capped at surrogate_ratio" in d["note"]
    assert float(np.dot(d["runs_per_level"], COSTS)) <= 0.05 * (1 + 1e-9)
    # it pays: the fine model's plain MC at the same (pinned) cost has a twice larger error
    mc_sem = st.std[0] / np.sqrt(0.05 / COSTS[0])
    assert st.sem[0] < mc_sem / 2
    assert d["levels"] == f"dt={FINE}; surrogate of tpce"
    # what the PCE method spent is charged to the saving
    assert d["surrogate_cpu_s"] == pytest.approx(result.runs[0].model_seconds +
                                                 result.runs[0].fit_seconds)


def test_a_surrogate_level_is_held_within_its_memory_and_says_so():
    # one output of one column: 10,000 values are 10,000 rows, below the 100x cap's 45,000
    d = run(validate_config(_raw(surrogate_values=1e4))).runs[1].estimate.diagnostics
    m0, m1 = d["runs_per_level"]
    assert m1 == 10_000 and m0 < m1
    assert "surrogate rows held at 10000 (1 values per row" in d["note"]


@pytest.mark.slow
def test_a_pce_level_gives_the_same_bits_on_two_workers():
    cfg = validate_config(_raw(bootstrap=50))
    serial = run(cfg, SerialExecutor(4096)).runs[1].estimate.stats["y_end"]
    pool = ProcessExecutor(2, batch_size=300)
    try:
        pooled = run(cfg, pool).runs[1].estimate.stats["y_end"]
    finally:
        pool.close()
    for stat in ("mean", "std", "skewness", "kurtosis", "sem"):
        np.testing.assert_array_equal(getattr(serial, stat), getattr(pooled, stat))
    np.testing.assert_array_equal(serial.ci["std"], pooled.ci["std"])


@pytest.mark.parametrize("change, message", [
    ({"fidelities": [{"surrogate": "tpce"}, {"dt": FINE}]},
     "methods[1]: fidelities[0] is the highest fidelity, whose statistics are "
     "estimated: it must be the model, not {surrogate: ...}"),
    ({"fidelities": [{"dt": FINE}, {"surrogate": "tpce", "dt": 0.2}]},
     "a surrogate level is {surrogate: LABEL} alone"),
    ({"fidelities": [{"dt": FINE}, {"surrogate": "mc"}]},
     "methods[1].fidelities[1]: surrogate 'mc' is not the label of a method listed before "
     "this one; allowed: tpce"),
    ({"fidelities": [{"dt": FINE}, {"surrogate": "mfmc"}]},
     "methods[1].fidelities[1]: surrogate 'mfmc' is not the label of a method listed before "
     "this one; allowed: tpce"),
])
def test_a_surrogate_level_names_a_pce_method_listed_before(change, message):
    raw = _raw(**change)
    raw["methods"].append({"name": "monte_carlo", "label": "mc", "n_samples": 100})
    with pytest.raises(ConfigError) as err:
        validate_config(raw)
    assert message in str(err.value)


def test_a_monte_carlo_method_is_no_surrogate():
    raw = _raw(fidelities=[{"dt": FINE}, {"surrogate": "mc"}])
    raw["methods"].insert(0, {"name": "monte_carlo", "label": "mc", "n_samples": 100})
    with pytest.raises(ConfigError) as err:
        validate_config(raw)
    assert str(err.value) == ("methods[2].fidelities[1]: surrogate 'mc' is not a PCE method; "
                              "allowed: tpce")
