"""Monte Carlo propagation (uq-methods.md section 4.1).

Designs: pseudo-random (numpy ``Generator``), Latin hypercube and scrambled Sobol'
(``scipy.stats.qmc``), drawn on the unit cube and mapped to the inputs by their inverse CDFs.

Reproducibility: the samples are drawn in fixed-size chunks of ``chunk_size``, chunk ``i`` from
the child ``i`` of one ``SeedSequence`` derived from the run's seed and the method's label.
The numbers therefore depend on the seed, the label and ``chunk_size``, never on how many
workers evaluate the chunks. LHS and Sobol' are stratified within each chunk (a chunk is an
independent randomised replicate); keep ``chunk_size`` a power of two for Sobol'.

Statistics are the population estimators of uq-methods.md section 3 over the runs that did not
fail; failed runs are counted and their reasons tallied in the diagnostics.
"""

from __future__ import annotations

import logging
import time
import zlib
from collections import Counter
from typing import Literal

import numpy as np
from pydantic import Field
from scipy.stats import qmc

from ..inputs import InputSpace
from ..models.base import ModelOutput
from ..stats import covariance, sample_statistics
from .base import Design, Estimate, Method, MethodSettings

log = logging.getLogger(__name__)

# Keep inverse CDFs finite: a unit-cube coordinate of exactly 0 or 1 maps to +-inf for a normal.
_U_EPS = 2.0**-53


class MonteCarloSettings(MethodSettings):
    """Settings of ``monte_carlo``.

    Attributes
    ----------
    n_samples : int
        Number of model runs.
    sampling : {"random", "lhs", "sobol"}
        Design of the samples within each chunk.
    chunk_size : int
        Samples per random stream (changes the numbers; fixed so that the worker count does not).
    bootstrap : int
        Bootstrap resamples for the 95% intervals of std, skewness and kurtosis (0: none).
    bootstrap_times : {"report", "all"}
        Where a time series gets bootstrap intervals: at the config's report times and the
        final step (default; cheap), or at every step.
    """

    n_samples: int = Field(ge=1, le=100_000_000)
    sampling: Literal["random", "lhs", "sobol"] = "random"
    chunk_size: int = Field(default=8192, ge=1, le=10_000_000)
    bootstrap: int = Field(default=200, ge=0, le=100_000)
    bootstrap_times: Literal["report", "all"] = "report"


def method_seed(seed: int, label: str) -> np.random.SeedSequence:
    """The SeedSequence of one method entry: the run's seed and a stable hash of the label, so
    that adding or reordering methods in a config does not change another method's numbers."""
    return np.random.SeedSequence([seed, zlib.crc32(label.encode())])


def unit_samples(d: int, n: int, sampling: str, chunk_size: int,
                 seed: np.random.SeedSequence) -> np.ndarray:
    """Points ``(n, d)`` in the open unit cube, drawn chunk by chunk from children of ``seed``."""
    n_chunks = -(-n // chunk_size)
    children = seed.spawn(n_chunks)
    parts = []
    for i, child in enumerate(children):
        m = min(chunk_size, n - i * chunk_size)
        rng = np.random.default_rng(child)
        if sampling == "random":
            u = rng.random((m, d))
        elif sampling == "lhs":
            u = qmc.LatinHypercube(d=d, seed=rng).random(m)
        else:
            # Draw the next power of two and keep the first m: a prefix of a scrambled Sobol'
            # sequence, which avoids scipy's balance warning for non-powers of two.
            p = int(np.ceil(np.log2(max(m, 1))))
            u = qmc.Sobol(d=d, scramble=True, seed=rng).random_base2(p)[:m]
        parts.append(u)
    return np.clip(np.concatenate(parts) if parts else np.empty((0, d)), _U_EPS, 1 - _U_EPS)


class MonteCarlo(Method):
    """Monte Carlo sampling with sample-moment statistics and bootstrap intervals."""

    name = "monte_carlo"
    summary = "Monte Carlo: random, Latin hypercube or scrambled Sobol' samples; sample moments"
    Settings = MonteCarloSettings
    settings: MonteCarloSettings

    def design(self, space: InputSpace, seed: int) -> Design:
        s = self.settings
        ss = method_seed(seed, self.label)
        u = unit_samples(space.dim, s.n_samples, s.sampling, s.chunk_size, ss)
        x = space.from_unit(u) if space.dim else np.empty((s.n_samples, 0))
        # The bootstrap stream is a fixed function of the same root, kept apart from the design.
        boot_seed = int(np.random.SeedSequence([seed, zlib.crc32(self.label.encode()), 1])
                        .generate_state(1)[0])
        return Design(x=x, data={"boot_seed": boot_seed})

    def _ci_index(self, time_grid: np.ndarray) -> np.ndarray | None:
        if self.settings.bootstrap_times == "all" or time_grid.size == 0:
            return None
        times = list(self.report_times or [])
        idx = [int(np.argmin(np.abs(time_grid - t))) for t in times]
        idx.append(time_grid.size - 1)
        return np.unique(idx)

    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        t0 = time.perf_counter()
        ok = ~outputs.failed
        n_failed = int(outputs.failed.sum())
        if n_failed:
            log.warning("%s: %d of %d runs failed; statistics use the other %d",
                        self.label, n_failed, outputs.n, outputs.n - n_failed)
        B, seed = self.settings.bootstrap, design.data.get("boot_seed", 0)
        ci_index = self._ci_index(outputs.time)
        stats = {}
        for name, y in outputs.series.items():
            stats[name] = sample_statistics(y[ok], bootstrap=B, seed=seed, ci_index=ci_index)
        for name, y in outputs.scalars.items():
            stats[name] = sample_statistics(y[ok], bootstrap=B, seed=seed)
        names, stacked = _stack_scalars(outputs, ok)
        reasons = Counter(r for r in outputs.reasons[outputs.failed])
        diagnostics = {
            "n_runs": outputs.n,
            "n_failed": n_failed,
            "failure_reasons": "; ".join(f"{r} ({c})" for r, c in reasons.most_common()),
            "sampling": self.settings.sampling,
            "bootstrap": B,
            "fit_seconds": time.perf_counter() - t0,
        }
        return Estimate(
            method=self.name, label=self.label, stats=stats, diagnostics=diagnostics,
            scalar_names=names,
            scalar_mean=stacked.mean(axis=0) if stacked.size else None,
            scalar_cov=covariance(stacked) if stacked.size else None,
        )


def _stack_scalars(outputs: ModelOutput, ok: np.ndarray) -> tuple[list[str], np.ndarray]:
    """All scalar outputs of the good runs side by side ``(n_ok, m)`` with their names."""
    names: list[str] = []
    cols = []
    for name, y in outputs.scalars.items():
        k = y.shape[1]
        names += [name] if k == 1 else [f"{name}[{j}]" for j in range(k)]
        cols.append(y[ok])
    if not cols:
        return names, np.empty((int(ok.sum()), 0))
    return names, np.concatenate(cols, axis=1)
