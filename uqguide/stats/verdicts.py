"""Verdicts on requirements: ``pass`` when the one-sided lower confidence bound of the success
probability reaches the requirement's, ``fail`` when the upper bound is below it, else
``undecided`` with the further runs that would decide it at the current estimate.

Model runs: exact one-sided Clopper-Pearson bounds (the quantile form is the same verdict as
Wilks' order statistic, :func:`wilks_rank`); a run that stopped when decided: a confidence
sequence valid under optional stopping (:func:`sequence_bounds`); subset simulation: its
lognormal interval (approximate); a PCE: its validation runs' distribution-free bounds where
they hold at the confidence asked, else ``undecided``. The plan (:func:`runs_to_pass`) and the
derivations: docs/requirements.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from statistics import NormalDist

from ..core.events import EventEstimate, EventSpec, clopper_pearson
from ..core.requirements import RequirementSpec

__all__ = ["CV_ONE_SIDED", "Verdict", "count_verdict", "decide", "log_mixture",
           "method_verdicts", "mixture_prior", "one_sided_bounds", "plan_lines", "runs_to_decide",
           "runs_to_pass", "sequence_bounds", "sequence_decided", "wilks_rank"]

#: How the bounds of counted runs are made: fixed ``n``, or a run stopped when decided.
EXACT, SEQUENTIAL = "exact (Clopper-Pearson)", "confidence sequence (beta-binomial mixture)"

#: One-sided coverage of each end of a validated PCE's event interval: its pieces' two-sided
#: levels are Bonferroni-split from 95%, so each end misses with at most 2.5%
#: (docs/pce.md#events-corrected-by-the-validation-runs).
CV_ONE_SIDED = 0.975

#: The subset-simulation interval's normal quantile (``uqguide.methods.subset_simulation``).
_SUBSET_Z = 1.96

#: Largest run count :func:`runs_to_decide` and :func:`runs_to_pass` search.
_MAX_RUNS = 10**15


def one_sided_bounds(k: float, n: float, confidence: float) -> tuple[float, float]:
    """Exact one-sided lower and upper Clopper-Pearson bounds of a binomial probability, each
    holding with probability at least ``confidence`` (>= 0.5), from ``k`` successes of ``n``."""
    return clopper_pearson(k, n, 2.0 * confidence - 1.0)


def mixture_prior(target: float) -> tuple[float, float]:
    """The mixing ``Beta(a, b)`` of :func:`log_mixture`: mean ``target``, the smaller of ``a``,
    ``b`` equal to 1 (fixed by the requirement, before any run)."""
    return (max(1.0, target / (1.0 - target)), max(1.0, (1.0 - target) / target))


def log_mixture(k: float, n: float, p: float, prior: tuple[float, float]) -> float:
    """``ln M_n(p)``, Robbins' (1970) beta-binomial mixture martingale of ``k`` successes in
    ``n`` runs against the success probability ``p``: ``B(a + k, b + n - k) / B(a, b) /
    (p^k (1 - p)^(n - k))``. Under ``p`` it exceeds ``1 / alpha`` at any run with probability
    at most ``alpha`` (Ville's inequality), however the stopping depends on the runs."""
    from scipy.special import betaln, xlog1py, xlogy

    a, b = prior
    return float(betaln(a + k, b + n - k) - betaln(a, b) - xlogy(k, p) - xlog1py(n - k, -p))


def sequence_bounds(k: float, n: float, confidence: float, target: float
                    ) -> tuple[float, float]:
    """The ends of the confidence sequence ``{p: M_n(p) < 1 / (1 - confidence)}`` (an interval
    around ``k / n``; :func:`log_mixture` with :func:`mixture_prior` of ``target``): the success
    probability lies within it at every ``n`` at once with probability ``confidence``."""
    from scipy.optimize import brentq

    if n <= 0:
        return 0.0, 1.0
    prior, level = mixture_prior(target), math.log(1.0 / (1.0 - confidence))
    p_hat = k / n

    def excess(p: float) -> float:
        return log_mixture(k, n, p, prior) - level

    if excess(p_hat) >= 0:  # the sequence is empty here (probability < 1 - confidence)
        return p_hat, p_hat
    lo = 0.0 if k <= 0 else brentq(excess, 1e-300, p_hat, xtol=1e-15, rtol=1e-14)
    hi = 1.0 if k >= n else brentq(excess, p_hat, 1.0 - 1e-16, xtol=1e-15, rtol=1e-14)
    return float(lo), float(hi)


def sequence_decided(k: float, n: float, confidence: float, target: float) -> bool:
    """Whether the confidence sequence excludes ``target`` (a ``pass`` or ``fail`` that stays
    right with probability ``confidence`` however the runs were stopped): ``M_n(target) >=
    1 / (1 - confidence)``."""
    return n > 0 and k != n * target and log_mixture(
        k, n, target, mixture_prior(target)) >= math.log(1.0 / (1.0 - confidence))


def decide(lower: float, upper: float, target: float) -> str:
    """``pass`` (``lower >= target``), ``fail`` (``upper < target``) or ``undecided``."""
    if lower >= target:
        return "pass"
    if upper < target:
        return "fail"
    return "undecided"


def _first(ok: Callable[[int], bool], start: int) -> int | None:
    """The least ``n >= start`` with ``ok(n)`` for a predicate false then true (doubling, then
    bisection); None when it is not true by :data:`_MAX_RUNS`."""
    if ok(start):
        return start
    lo, hi = start, max(2 * start, start + 1)
    while not ok(hi):
        if hi >= _MAX_RUNS:
            return None
        lo, hi = hi, min(2 * hi, _MAX_RUNS)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid, hi)
    return hi


def runs_to_decide(estimate: float, target: float, confidence: float, n: int,
                   sequential: bool = False) -> float:
    """Further runs (beyond ``n``) after which the bounds at the current ``estimate`` of the
    success probability decide against ``target`` (``sequential``: the confidence sequence's):
    0 when decided, ``inf`` when the estimate is the target (no count decides it)."""
    if not 0.0 <= estimate <= 1.0 or estimate == target:
        return math.inf if estimate == target else math.nan

    def decided(m: int) -> bool:
        if sequential:
            return sequence_decided(estimate * m, m, confidence, target)
        lo, hi = one_sided_bounds(estimate * m, m, confidence)
        return decide(lo, hi, target) != "undecided"

    m = _first(decided, max(n, 1))
    return math.inf if m is None else float(m - n)


def runs_to_pass(target: float, confidence: float, failures: int = 0) -> int:
    """The least runs whose lower bound reaches ``target`` with ``failures`` of them failing:
    the least ``n`` with ``P(Bin(n, 1 - target) <= failures) <= 1 - confidence``
    (``ceil(ln(1 - confidence) / ln(target))`` for none)."""
    from scipy.special import bdtr

    zero = math.ceil(math.log1p(-confidence) / math.log(target))
    if failures == 0:
        return zero
    found = _first(lambda n: float(bdtr(failures, n, 1.0 - target)) <= 1.0 - confidence,
                   zero + failures)
    assert found is not None, "bdtr falls to 0 as n grows"
    return found


def wilks_rank(n: int, quantile: float, confidence: float) -> int | None:
    """The rank ``r`` (1-based) of the order statistic that bounds the ``quantile`` above with
    ``confidence`` (Wilks 1941): the least ``r`` with ``P(Bin(n, quantile) < r) >=
    confidence``; None when ``n`` runs are too few. ``y_(r) < b`` exactly when ``k >= r`` runs
    are below ``b``, which is when :func:`count_verdict` passes."""
    from .quantiles import binomial_ppf

    r = binomial_ppf(confidence, n, quantile) + 1
    return r if r <= n else None


@dataclass
class Verdict:
    """The verdict on one requirement by one method.

    ``estimate``, ``lower``, ``upper``: the success probability and its one-sided bounds
    (NaN where there are none); ``runs``: behind them; ``runs_to_decide``: further runs that
    would decide it at the current estimate (0 decided, NaN not known, inf never); ``basis``:
    how the bounds were made, or why there are none.
    """

    requirement: str
    label: str
    verdict: str
    estimate: float
    lower: float
    upper: float
    runs: int
    runs_to_decide: float
    basis: str

    def as_dict(self) -> dict[str, object]:
        """The fields but requirement and label, flat (for storage); see :meth:`from_dict`."""
        d = asdict(self)
        del d["requirement"], d["label"]
        return d

    @classmethod
    def from_dict(cls, requirement: str, label: str, d: Mapping[str, object]) -> Verdict:
        def num(key: str) -> float:
            return float(d[key])  # type: ignore[arg-type]

        return cls(requirement, label, str(d["verdict"]), num("estimate"), num("lower"),
                   num("upper"), int(num("runs")), num("runs_to_decide"), str(d["basis"]))


def count_verdict(name: str, label: str, k: int, n: int, target: float, confidence: float,
                  sequential: bool = False) -> Verdict:
    """The verdict from ``k`` successes of ``n`` runs (exact, distribution-free); of a run that
    stopped when decided (``sequential``), by its confidence sequence."""
    if n <= 0:
        return Verdict(name, label, "undecided", math.nan, math.nan, math.nan, 0, math.nan,
                       "no successful runs")
    if sequential:
        lo, hi = sequence_bounds(k, n, confidence, target)
        # (decided by the martingale itself: the roots' last digits must not flip it)
        v = decide(lo, hi, target) if sequence_decided(k, n, confidence, target) \
            else "undecided"
    else:
        lo, hi = one_sided_bounds(k, n, confidence)
        v = decide(lo, hi, target)
    further = 0.0 if v != "undecided" else runs_to_decide(k / n, target, confidence, n,
                                                          sequential)
    return Verdict(name, label, v, k / n, lo, hi, n, further,
                   SEQUENTIAL if sequential else EXACT)


def _subset_verdict(req: RequirementSpec, label: str, ev: EventEstimate) -> Verdict:
    """From subset simulation's failure probability ``p_f``: success ``1 - p_f``, its bounds
    from the method's lognormal spread at the requirement's confidence (approximate)."""
    p = ev.probability
    z = NormalDist().inv_cdf(req.confidence)
    if p > 0 and ev.ci[1] > p:
        s = math.log(ev.ci[1] / p) / _SUBSET_Z
        f_lo, f_hi = p * math.exp(-z * s), min(1.0, p * math.exp(z * s))
    else:  # the event was never reached: the method's bound on p_f only
        f_lo, f_hi = 0.0, ev.ci[1]
    lo, hi = 1.0 - f_hi, 1.0 - f_lo
    return Verdict(req.name, label, decide(lo, hi, req.target), 1.0 - p, lo, hi, ev.n_used,
                   math.nan, "approximate (subset, lognormal)")


def _complement(a: EventSpec, b: EventSpec) -> bool:
    """Whether ``b`` is ``a``'s complement: the same output, component and threshold, the other
    side (the threshold itself has probability zero for a continuous output)."""
    return (a.output, a.component, a.threshold()) == (b.output, b.component, b.threshold()) \
        and (a.below is None) != (b.below is None)


def method_verdicts(label: str, requirements: Sequence[RequirementSpec],
                    events: Mapping[str, EventEstimate], specs: Sequence[EventSpec],
                    sequential: bool = False) -> dict[str, Verdict]:
    """Every requirement's verdict by one method, from its event estimates ``events`` (by
    name) of the config's events ``specs`` (the requirements' own among them); ``sequential``:
    the method stopped its runs when the requirements were decided."""
    by_name = {s.name: s for s in specs}
    out = {}
    for req in requirements:
        ev = events.get(req.name)
        subset = next((e for name, e in events.items() if e.estimator == "subset"
                       and name in by_name and _complement(req.event(), by_name[name])), None)
        nan = math.nan
        if subset is not None:
            out[req.name] = _subset_verdict(req, label, subset)
        elif ev is None:
            out[req.name] = Verdict(req.name, label, "undecided", nan, nan, nan, 0, nan,
                                    "no estimate of this event")
        elif ev.estimator == "count":
            out[req.name] = count_verdict(req.name, label, ev.n_in, ev.n_used, req.target,
                                          req.confidence, sequential)
        elif ev.estimator == "surrogate+cv" and req.confidence <= CV_ONE_SIDED:
            lo, hi = ev.ci
            out[req.name] = Verdict(req.name, label, decide(lo, hi, req.target),
                                    ev.probability, lo, hi, ev.n_used, nan,
                                    f"validation runs ({100 * CV_ONE_SIDED:g}% one-sided)")
        else:
            why = (f"validation runs bound at {100 * CV_ONE_SIDED:g}% one-sided, not "
                   f"{100 * req.confidence:g}%" if ev.estimator == "surrogate+cv" else
                   "surrogate draws only (pce_adaptive's validation_runs bound it)")
            out[req.name] = Verdict(req.name, label, "undecided", ev.probability, nan, nan,
                                    ev.n_used, nan, why)
    return out


def plan_lines(requirements: Sequence[RequirementSpec]) -> list[str]:
    """Per requirement (:class:`~uqguide.core.requirements.RequirementSpec`), the runs that pass
    it with 0, 1 and 2 of them outside its success event (``uqguide validate``)."""
    lines = ["requirements (runs to pass with 0 / 1 / 2 runs outside the success event):"]
    for r in requirements:
        n = [runs_to_pass(r.target, r.confidence, f) for f in (0, 1, 2)]
        lines.append(f"  {r.name}: {r.describe()}: {n[0]:,} / {n[1]:,} / {n[2]:,}")
    return lines
