"""Subset simulation (Au & Beck 2001) for the probability of one rare event.

The event ``F = {g(x) > 0}`` (``g`` the event's severity) is reached through nested events
``F_i = {g > b_i}`` of conditional probability ``p0``, each level's samples drawn by
component-wise Metropolis chains in standard normal space; every step of a level's chains is
one batch through the executors (:meth:`SubsetSimulation.refine`). The algorithm, its interval,
cost and measured coverage: ``docs/performance.md#rare-events``.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from ..errors import ConfigError, MethodError
from ..core.events import EventEstimate, EventSpec, component_index
from ..core.inputs import InputSpace
from ..core.types import Estimate, ModelOutput
from .base import Design, Method, MethodSettings
from .monte_carlo import U_EPS, method_seed

log = logging.getLogger(__name__)

class SubsetSimulationSettings(MethodSettings):
    """Settings of ``subset_simulation``."""

    event: str = Field(min_length=1, description="name of one of the config's events")
    n_per_level: int = Field(default=1000, ge=10, le=10_000_000,
                             description="samples per level N")
    p0: float = Field(default=0.1, gt=0.0, le=0.5,
                      description="conditional probability of each intermediate level (p0 N "
                                  "and 1 / p0 integers)")
    proposal_std: float = Field(default=1.0, gt=0.0, le=10.0,
                                description="standard deviation of each coordinate's proposal "
                                            "in standard normal space")
    max_levels: int = Field(default=10, ge=1, le=10,
                            description="MCMC levels before the method stops (the estimate is "
                                        "then an upper bound, flagged)")

    @model_validator(mode="after")
    def _integers(self) -> SubsetSimulationSettings:
        nc = self.p0 * self.n_per_level
        chain = 1.0 / self.p0
        if abs(nc - round(nc)) > 1e-9 or abs(chain - round(chain)) > 1e-9:
            raise ValueError(f"p0 * n_per_level and 1 / p0 must be integers (got p0 = "
                             f"{self.p0}, n_per_level = {self.n_per_level})")
        return self


class SubsetSimulation(Method):
    """Subset simulation: the probability of one of the config's events, with its CoV."""

    name = "subset_simulation"
    own_design = "it draws each level's samples by MCMC from the level before"
    summary = "Subset simulation (Au & Beck 2001): a rare event's probability, CoV and interval"
    Settings = SubsetSimulationSettings
    settings: SubsetSimulationSettings
    example_settings = {"event": "tail", "n_per_level": 500}

    def check(self, index: int) -> None:
        """ConfigError unless the method's event is one of the config's events."""
        names = [e.name for e in self.context.events]
        if self.settings.event not in names:
            raise ConfigError(
                f"methods[{index}].event: {self.settings.event!r} is not one of the config's "
                f"events; allowed: {', '.join(names) or 'none declared (add an events list)'}",
                field=f"methods[{index}].event")

    @property
    def spec(self) -> EventSpec:
        return next(e for e in self.context.events if e.name == self.settings.event)

    @property
    def n_seeds(self) -> int:
        return int(round(self.settings.p0 * self.settings.n_per_level))

    @property
    def chain_length(self) -> int:
        return int(round(1.0 / self.settings.p0))

    def _rng(self, seed: int, level: int, step: int) -> np.random.Generator:
        return np.random.default_rng(method_seed(seed, self.label, level, step))

    @staticmethod
    def _to_x(space: InputSpace, z: np.ndarray) -> np.ndarray:
        from scipy import special

        return space.from_unit(np.clip(special.ndtr(z), U_EPS, 1 - U_EPS))

    def design(self, space: InputSpace, seed: int) -> Design:
        z = self._rng(seed, 0, 0).standard_normal((self.settings.n_per_level, space.dim))
        return Design(x=self._to_x(space, z), data={
            "seed": int(seed), "z": z, "level": 0, "step": 0,
            # rows of the current level's samples (level 0: all N) and their chains' states
            "level_rows": np.arange(z.shape[0]), "chain_rows": None, "chains": [],
            "thresholds": [], "cond_probs": [], "gammas": [], "accepted": 0, "proposed": 0,
            "done": False,
        })

    def _severity(self, outputs: ModelOutput) -> np.ndarray:
        """g of every run so far (-inf for failed runs: never in any level)."""
        spec = self.spec
        y = outputs.scalars[spec.output][:, component_index(spec, self.context.components.get(
            spec.output, ("",)))]
        g = spec.severity(np.asarray(y, dtype=float))
        return np.where(outputs.failed | ~np.isfinite(g), -np.inf, g)

    def refine(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Design | None:
        """Accept or reject the last candidates; at the end of a level set the next threshold
        (or stop); then propose the next candidate of every chain. Only the chains that moved
        are run (a chain that stays keeps its known value)."""
        if design.data["done"]:
            return None
        d = dict(design.data)
        g = self._severity(outputs)
        nc, L = self.n_seeds, self.chain_length
        if d["step"] > 0:
            # the last rows are the candidates of the chains that moved at proposal `step`
            moved = d["moved"]
            cand = np.arange(design.x.shape[0] - moved.size, design.x.shape[0])
            ok = g[cand] > d["thresholds"][-1]
            d["accepted"] += int(ok.sum())
            current = d["current"].copy()
            current[moved[ok]] = cand[ok]
            d["current"] = current
            d["chain_rows"] = d["chain_rows"].copy()
            d["chain_rows"][:, d["step"]] = current
        while True:
            if d["chain_rows"] is None or d["step"] == L - 1:
                if self._end_level(d, g):
                    design.data.update(d)  # the driver estimates from the design it holds
                    return None
            rng = self._rng(d["seed"], d["level"], d["step"] + 1)
            z_cur = d["z"][d["current"]]
            prop = z_cur + self.settings.proposal_std * rng.standard_normal(z_cur.shape)
            keep = rng.random(z_cur.shape) < np.exp(0.5 * (z_cur ** 2 - prop ** 2))
            moved = np.flatnonzero(keep.any(axis=1))
            d["proposed"] += nc
            d["step"] += 1
            if moved.size:
                z_new = np.where(keep, prop, z_cur)[moved]
                d["z"] = np.vstack([d["z"], z_new])
                d["moved"] = moved
                return Design(x=np.vstack([design.x, self._to_x(space, z_new)]), data=d)
            # no chain moved: this step's states are the current ones, and nothing to run
            d["chain_rows"] = d["chain_rows"].copy()
            d["chain_rows"][:, d["step"]] = d["current"]

    def _end_level(self, d: dict[str, Any], g: np.ndarray) -> bool:
        """Close a level in ``d``: the next threshold and the chains' seeds; True at the end
        (the event level reached, or ``max_levels``)."""
        N, nc, L = self.settings.n_per_level, self.n_seeds, self.chain_length
        rows = np.arange(N) if d["chain_rows"] is None else d["chain_rows"].ravel()
        gl = g[rows]
        n_f = int(np.count_nonzero(gl > 0))
        order = np.argsort(-gl, kind="stable")
        final = n_f >= nc or d["level"] >= self.settings.max_levels
        # Equal values at the threshold rank are a plateau only when they come from different
        # inputs: a chain that stays repeats its own point and value.
        a, b_ = rows[order[nc - 1]], rows[order[nc]]
        if not final and gl[order[nc - 1]] == gl[order[nc]] \
                and not np.array_equal(d["z"][a], d["z"][b_]):
            raise MethodError(
                f"{self.label}: the {nc}th and {nc + 1}th largest values of "
                f"{self.spec.output} at level {d['level']} are equal ({gl[order[nc]]:g}) for "
                f"two different inputs: no intermediate threshold separates them; subset "
                f"simulation needs an output that grades the approach to the event (a "
                f"distance or a margin, not a 0/1 flag or a saturated value)")
        b = 0.0 if final else 0.5 * (gl[order[nc - 1]] + gl[order[nc]])
        if not np.isfinite(b):
            raise MethodError(f"{self.label}: level {d['level']} has fewer than {nc + 1} "
                              f"runs with a value; cannot set an intermediate threshold")
        if d["chain_rows"] is not None:
            d["gammas"] = d["gammas"] + [_gamma(g, d["chain_rows"], b)]
        if final:
            if n_f < nc:
                log.warning("%s: stopped at max_levels = %d with %d of %d samples in the "
                            "event", self.label, self.settings.max_levels, n_f, N)
            d.update(final_count=n_f, done=True)
            return True
        seeds = rows[order[:nc]]
        d["thresholds"] = d["thresholds"] + [float(b)]
        d["cond_probs"] = d["cond_probs"] + [nc / N]
        d["level"] += 1
        d["step"] = 0
        d["chain_rows"] = np.full((nc, L), -1, dtype=np.int64)
        d["chain_rows"][:, 0] = seeds
        d["current"] = seeds
        return False

    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        t0 = time.perf_counter()
        d = design.data
        N = self.settings.n_per_level
        if not d.get("done"):
            raise MethodError(f"{self.label}: subset simulation did not finish")
        m = len(d["thresholds"])
        n_f = int(d["final_count"])
        p_last = n_f / N
        p = float(np.prod(d["cond_probs"]) * p_last) if m else p_last
        # level CoVs: intermediate levels at p0, the last at n_F / N
        probs = list(d["cond_probs"]) + [p_last]
        gammas = [0.0] + list(d["gammas"])
        deltas = [np.sqrt((1 - pi) / (N * pi) * (1 + gi)) if pi > 0 else np.inf
                  for pi, gi in zip(probs, gammas)]
        cov = float(np.sqrt(np.sum(np.square(deltas))))
        cov_upper = float(np.sum(deltas))
        if p > 0 and np.isfinite(cov_upper):
            s = np.sqrt(np.log1p(cov_upper * cov_upper))
            ci = (p * float(np.exp(-1.96 * s)), p * float(np.exp(1.96 * s)))
        else:
            ci = (0.0, float(np.prod(d["cond_probs"])) if m else 1.0)
        spec = self.spec
        ev = EventEstimate(spec.name, spec.describe(), p, ci, n_f, N, "subset", cov)
        n_failed = int(outputs.failed.sum())
        diagnostics: dict[str, Any] = {
            "n_runs": outputs.n, "n_failed": n_failed, "event": spec.name,
            "probability": p, "cov": cov, "cov_upper": cov_upper, "levels": m,
            "thresholds": [float(b) for b in d["thresholds"]],
            "final_in_event": n_f, "gammas": [float(x) for x in d["gammas"]],
            "acceptance": d["accepted"] / d["proposed"] if d["proposed"] else float("nan"),
            "n_per_level": N, "p0": self.settings.p0,
            "reached_event": n_f >= self.n_seeds,
            "fit_seconds": time.perf_counter() - t0,
        }
        return Estimate(method=self.name, label=self.label, stats={}, diagnostics=diagnostics,
                        events={spec.name: ev})


def _gamma(g: np.ndarray, chain_rows: np.ndarray, b: float) -> float:
    """Au & Beck's gamma of one level: the correlation factor of the indicators
    ``I(g > b)`` along the chains (``chain_rows (N_c, L)``)."""
    ind = (g[chain_rows] > b).astype(float)
    nc, L = ind.shape
    p = ind.mean()
    if p <= 0.0 or p >= 1.0:
        return 0.0
    r0 = p * (1 - p)
    gamma = 0.0
    for k in range(1, L):
        rk = np.mean(ind[:, : L - k] * ind[:, k:]) - p * p
        gamma += 2 * (1 - k / L) * rk / r0
    return float(gamma)
