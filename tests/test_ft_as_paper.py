"""The paper's comparison (ft-as-controller.md sections 11-13) reproduced by the ``ft_as`` model.

The full reproduction (h = 0.01 s, T = 3000 s, five controllers in one batch) costs about 5 s
in the compiled kernel, so it runs in the default suite. Tolerances are the spec's: accuracy
bounds x3, orderings with a 10 % margin, section 12.2 values within x3 (accuracies) and 10 %
(settling times, delta-v).
"""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.models.ft_as import FTAS
from uqguide.models.ft_as.model import Variant
from uqguide.papers import nominal_figures, nominal_report
from uqguide.papers.ft_as.report import ChaoticFigures, nominal_runs, report_rows, roundoff_runs


# The reproduction at the paper's step (h = 0.01 s, with the 7-member round-off ensemble)
# costs ~30 CPU-s with its figures: its tests are marked slow. The default suite checks the
# same report at h = 0.1 s (the ``coarse`` tests below: claim C1, the inputs C5, every row with
# a tolerance, the chaotic rows' statistic, the figures) and section 13's coarse profile.
@pytest.fixture(scope="module")
def paper():
    model = FTAS()
    rows = nominal_report(model)
    variants, res = nominal_runs(model)
    return {r.quantity: r for r in rows}, {v.label: i for i, v in enumerate(variants)}, res, model


@pytest.mark.slow
def test_observer_converges_within_5s_C1(paper):
    rows, idx, res, _ = paper
    for lab in ("FT-AS", "Case 1", "Case 2"):
        t = res.settle["eps1"][idx[lab], 1]  # |eps1| <= 1e-3
        assert t <= 5.0, lab
        assert t == pytest.approx(2.4, rel=0.10)  # spec 12.2
    # the literal FT-AS cannot: its FT-DO sees the unsaturated command (spec 8.1)
    assert not res.settled("eps1")[idx["FT-AS literal"], 1]


@pytest.mark.slow
def test_final_accuracies_C2_C4(paper):
    # final-window maxima of chattering loops are chaotic: the rows hold the median over the
    # round-off ensemble and judge the bound on its worst run; only that is asserted
    rows, idx, res, _ = paper
    bounds = {"FT-AS": (2e-4, 1e-4), "Case 1": (5e-3, 1e-4), "Case 2": (0.5, 2e-3)}
    for lab, (b_r, b_s) in bounds.items():
        r_row, s_row = rows[f"{lab}: C2 final max|r_e,k|"], rows[f"{lab}: C4 final max|sigma_e,k|"]
        assert r_row.kind == s_row.kind == "chaotic" and "median of 7 runs" in s_row.statistic
        assert s_row.statistic.endswith("check: every run")
        assert r_row.ok and r_row.paper == b_r, lab
        assert s_row.ok and s_row.paper == b_s, lab
    # literal FT-AS diverges in position (documented behaviour, spec 13), in every run
    assert rows["FT-AS literal: |r_e(T)| (documented divergence)"].ok is True


@pytest.mark.slow
def test_velocity_claims_C3(paper):
    rows, idx, res, _ = paper
    assert rows["C3 final max|v_e,k| spread (max/min of 3 controllers)"].value <= 3.0
    tv = {lab: res.settle["v_e"][idx[lab], 0] for lab in ("FT-AS", "Case 1", "Case 2")}
    assert 1.1 * tv["FT-AS"] < tv["Case 2"] and 1.1 * tv["Case 1"] < tv["Case 2"]


@pytest.mark.slow
def test_inputs_C5(paper):
    rows, idx, res, _ = paper
    lim = np.array([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])
    for lab in ("FT-AS", "FT-AS-P", "Case 2"):
        assert np.all(res.peak_applied[idx[lab]] <= lim), lab
    i1 = idx["Case 1"]
    assert res.peak_applied[i1, :3].max() > 2.0  # exceeds initially: 3008 N in the spec
    assert res.peak_applied[i1, :3].max() == pytest.approx(3008.0, rel=0.01)
    assert np.all(res.peak_late[i1] <= lim)  # then within (after 300 s)


@pytest.mark.slow
def test_sliding_variables_C6(paper):
    rows, idx, res, _ = paper
    st = {lab: res.settle["s_trans"][idx[lab], 0] for lab in ("FT-AS", "Case 1", "Case 2")}
    assert st["Case 2"] > 1.1 * max(st["FT-AS"], st["Case 1"])
    assert 1 / 3 <= st["FT-AS"] / st["Case 1"] <= 3  # "~", factor 3
    # s4..6: at the spec's h = 0.05 s Case 2 is the slowest by far (128 s vs 57-59 s)
    assert rows["C6 s4..6: FT-AS < Case 2 (h = 0.05 s)"].ok is True
    # Case 1 < FT-AS holds, but by 2-3 %, not the 10 % margin: reported, not claimed
    sr = {lab: res.settle["s_rot"][idx[lab], 0] for lab in ("FT-AS", "Case 1")}
    assert sr["Case 1"] < sr["FT-AS"]
    assert rows["C6 s4..6: Case 1 < FT-AS (h = 0.01 s)"].ok is False


@pytest.mark.slow
def test_spec_reference_table_12_2(paper):
    rows, idx, res, _ = paper
    spec_rows = [r for q, r in rows.items() if "spec 12.2" in q]
    assert len(spec_rows) == 4 * 7
    failing = [r.quantity for r in spec_rows if r.ok is not True]
    assert failing == []


@pytest.mark.slow
def test_reproducible_rows_move_less_than_a_tenth_of_their_tolerance_under_roundoff(paper):
    # The round-off robustness check of the report: rebuild every row from each perturbed
    # member of the ensemble (inputs moved by 1e-12 relative, as another CPU or the NumPy
    # kernel would move them). A row marked reproducible must keep its verdict and move by
    # less than 1 %, a tenth of the tightest tolerance of the report (10 %); "printed digits"
    # rows must print the same digits. Chaotic rows are the ensemble's median in every case.
    rows, idx, res, model = paper
    chaos = ChaoticFigures([res, *roundoff_runs(model)])
    base = report_rows(model, res, chaos)
    assert [r.quantity for r in base] == [q for q in rows if "h = 0.05 s" not in q]
    for member in roundoff_runs(model):
        for a, b in zip(base, report_rows(model, member, chaos)):
            if a.kind != "reproducible":
                continue
            assert a.ok == b.ok, a.quantity
            if isinstance(a.value, float) and isinstance(b.value, float):
                assert b.value == pytest.approx(a.value, rel=1e-2, abs=1e-12), a.quantity
            else:
                assert a.value == b.value, a.quantity


@pytest.mark.slow
def test_chaotic_rows_name_their_statistic(paper):
    rows, *_ = paper
    chaotic = [r for r in rows.values() if r.kind == "chaotic"]
    assert len(chaotic) == 4 * 3 + 1 + 1 + 2 + 4 * 4  # C2/C4, literal, C3, C5 late, 12.2, impulse
    for r in chaotic:
        assert r.statistic.startswith("median of 7 runs under 1e-12 input perturbations; range")


@pytest.mark.slow
def test_report_rows_are_checked_where_a_tolerance_exists(paper):
    rows, idx, res, _ = paper
    known_deviations = {  # documented in the report notes and the final report
        "C6 s4..6: Case 1 < FT-AS (h = 0.01 s)",
        "C6 s4..6: FT-AS < Case 2 (h = 0.01 s)",
        "C6 s4..6: Case 1 < FT-AS (h = 0.05 s)",
    }
    bad = [q for q, r in rows.items() if r.ok is False and q not in known_deviations]
    assert bad == []


@pytest.fixture(scope="module")
def coarse():
    model = FTAS({"step": 0.1})
    rows = nominal_report(model)
    variants, res = nominal_runs(model)
    return {r.quantity: r for r in rows}, {v.label: i for i, v in enumerate(variants)}, res, model


@pytest.mark.slow
def test_coarse_observer_converges_within_5s_C1(coarse):
    rows, idx, res, _ = coarse
    for lab in ("FT-AS", "Case 1", "Case 2"):
        assert res.settle["eps1"][idx[lab], 1] == pytest.approx(2.4, rel=0.10), lab  # 12.2
    assert not res.settled("eps1")[idx["FT-AS literal"], 1]


# 2.8 CPU-s (the coarse nominal runs): with the slow tests; FT-AS keeps its golden, round-off
# and model tests in the default suite
@pytest.mark.slow
def test_coarse_inputs_C5(coarse):
    rows, idx, res, _ = coarse
    lim = np.array([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])
    for lab in ("FT-AS", "FT-AS-P", "Case 2"):
        assert np.all(res.peak_applied[idx[lab]] <= lim), lab
    i1 = idx["Case 1"]
    assert res.peak_applied[i1, :3].max() == pytest.approx(3008.0, rel=0.01)
    # (that it is within the limits after 300 s holds at h = 0.01 s, not at 0.1 s)


# 2.9 CPU-s, nearly all the coarse nominal runs of the fixture: with the slow tests since the
# default suite measured 149 CPU-s in a fresh clone (2026-11-27 night); FT-AS keeps its golden,
# its round-off case, its conformance check and the model tests in the default suite
@pytest.mark.slow
def test_coarse_report_rows_are_checked_and_name_their_statistic(coarse):
    rows, *_ = coarse
    known_deviations = {  # the h-dependent C6 orderings (spec 12.4), documented
        "C6 s1..3: Case 2 slowest (h = 0.1 s)",
        "C6 s4..6: Case 1 < FT-AS (h = 0.1 s)",
        "C6 s4..6: Case 1 < FT-AS (h = 0.05 s)",
    }
    bad = [q for q, r in rows.items() if r.ok is False and q not in known_deviations]
    assert bad == []
    assert len([q for q in rows if "spec 12.2" in q]) == 4 * 7
    chaotic = [r for r in rows.values() if r.kind == "chaotic"]
    assert len(chaotic) == 4 * 3 + 1 + 1 + 2 + 4 * 4
    for r in chaotic:
        assert r.statistic.startswith("median of 7 runs under 1e-12 input perturbations; range")


@pytest.mark.slow
def test_coarse_nominal_figures_are_written(tmp_path):
    # drawing 3000 s of records costs ~19 CPU-s whatever the step: 60 s show the same figures
    paths = nominal_figures(FTAS({"step": 0.1, "duration": 60.0, "output_interval": 10.0,
                                  "final_window": 10.0, "late_time": 30.0}), tmp_path)
    assert sorted(p.name for p in paths) == sorted(
        f"ft_as_{k}.png" for k in ("observer", "sliding", "tracking", "force", "torque"))
    for p in paths:
        with open(p, "rb") as f:
            assert f.read(8) == b"\x89PNG\r\n\x1a\n"


def test_coarse_profile_of_section_13():
    # spec section 13 integration test: h = 0.1 s, T = 3000 s, one batch of all configurations
    model = FTAS({"step": 0.1})
    variants = [
        Variant("literal", "ft_as", False),
        Variant("FT-AS-P", "ft_as", False, 0.01),
        Variant("FT-AS-A", "ft_as", True),
        Variant("Case 1", "case1"),
        Variant("Case 2", "case2"),
    ]
    res = model.run(model.nominal_values(5), variants, ("r_e",))
    assert np.linalg.norm(res.records["r_e"][0, -1]) > 1e3
    assert np.all(res.final_max["r_e"][1:].max(axis=1) < 1e-3)
    assert np.all(res.final_max["sigma_e"][1:].max(axis=1) < 2e-4)
    assert res.settle["eps1"][2, 1] <= 5.0
    lim = np.array([2.0, 2.0, 2.0, 1.0, 1.0, 1.0])
    assert np.all(res.peak_applied[[0, 1, 2, 4]] <= lim)


def test_convergence_time_versus_initial_state_C7():
    # spec 12.5: Case 1 settles in 534-745 s for 0.1-4x the paper's IC; saturated controllers
    # slow down with the IC (an authority limit, so the paper's claim fails for them).
    model = FTAS({"step": 0.1, "duration": 4000.0})
    scales = np.array([0.1, 1.0, 4.0])
    vals = model.nominal_values(6)
    vals["initial_error_scale"] = np.tile(scales, 2)
    variants = [Variant("Case 1", "case1")] * 3 + [Variant("FT-AS", "ft_as", True)] * 3
    res = model.run(vals, variants)
    t_case1 = res.settle["r_e"][:3, 4]
    assert np.all((t_case1 > 0.9 * 534) & (t_case1 < 1.1 * 745))
    t_ftas = res.settle["r_e"][3:, 4]
    assert t_ftas[0] < t_ftas[1] < t_ftas[2]


@pytest.mark.slow
def test_nominal_figures_are_written(paper, tmp_path):
    *_, model = paper
    paths = nominal_figures(model, tmp_path)  # reuses the cached nominal batch
    names = sorted(p.name for p in paths)
    assert names == sorted(
        f"ft_as_{k}.png" for k in ("observer", "sliding", "tracking", "force", "torque")
    )
    for p in paths:
        with open(p, "rb") as f:
            assert f.read(8) == b"\x89PNG\r\n\x1a\n"


def test_chaotic_verdicts_use_the_whole_ensemble():
    from uqguide.papers.ft_as.report import above, at_most, within_factor_of_range
    from uqguide.models.roundoff import Spread

    sp = Spread.of(np.array([1.8e-8, 2.3e-8, 3.0e-8, 1.1e-7, 4.2e-7]))
    assert at_most(1e-6)[1](sp) and not at_most(3e-7)[1](sp)  # one run above: the claim fails
    assert above(1e-8)[1](sp) and not above(2e-8)[1](sp)
    assert within_factor_of_range(2.3e-8)[1](sp)  # the spec's prototype value is one draw
    assert not within_factor_of_range(5e-9)[1](sp) and not within_factor_of_range(2e-6)[1](sp)
