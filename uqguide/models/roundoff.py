"""Round-off perturbations of a model's inputs: is a figure reproducible, or chaotic?

A closed loop that chatters amplifies the last bit of its inputs, so two CPUs give different
final-window maxima from the same inputs: such a figure is chaotic. A paper report runs its
nominal scenario under a few perturbations of relative size :data:`ROUNDOFF` (:func:`perturb` with
``member = 1, 2, ...``) and reports a chaotic row as the ensemble's median with its range
(:class:`Spread`); ``UQGUIDE_PERTURB=1e-12`` perturbs every model evaluation of the process
(:func:`perturbation_from_env`, :func:`apply_env`), so that the golden baselines and paper checks
can be rerun under round-off. A value moves by a fixed pseudo-random function of its bits, the
input's name and the member; an exact zero stays zero.

What is reproducible and what is chaotic: docs/papers.md#reproducible-and-chaotic-figures.
"""

from __future__ import annotations

import os
import zlib
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

PERTURB_ENV = "UQGUIDE_PERTURB"
"""Environment variable: relative size of the perturbation applied to every evaluation."""

MEMBER_ENV = "UQGUIDE_PERTURB_MEMBER"
"""Environment variable: which perturbation ``UQGUIDE_PERTURB`` applies (an int, default 0)."""

ROUNDOFF = 1e-12
"""Relative size of the perturbations of :func:`ensemble` (about 1e4 ulps of a double)."""


def perturbation_from_env() -> float:
    """The relative perturbation in ``[0, 1e-6]`` asked for by ``UQGUIDE_PERTURB`` (0.0 when
    unset); ConfigError for anything else: it is meant for round-off."""
    raw = os.environ.get(PERTURB_ENV, "").strip()
    if not raw:
        return 0.0
    try:
        rel = float(raw)
    except ValueError:
        rel = float("nan")
    if not (0.0 <= rel <= 1e-6):
        from ..errors import ConfigError

        raise ConfigError(f"environment variable {PERTURB_ENV} must be a number in [0, 1e-6] "
                          f"(a round-off size such as 1e-12); got {raw!r}", field=PERTURB_ENV)
    return rel


def _unit_hash(v: np.ndarray, key: int) -> np.ndarray:
    """A number in [-1, 1) that is a fixed pseudo-random function of the bits of each ``v``
    and of ``key`` (splitmix64's finaliser): the same value always moves the same way."""
    with np.errstate(over="ignore"):
        h = v.view(np.uint64) ^ np.uint64(key)
        h = (h ^ (h >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        h = (h ^ (h >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        h = h ^ (h >> np.uint64(31))
    return (h >> np.uint64(11)).astype(float) * 2.0**-52 - 1.0


def perturb(values: Mapping[str, np.ndarray], rel: float, member: int = 0
            ) -> dict[str, np.ndarray]:
    """A copy of ``values`` (SI, each (n,)) with every array moved by a relative ``rel``
    (module docstring); ``rel = 0`` copies them unchanged.

    The move of each value is a fixed function of the value itself, the input's name and
    ``member``, so a sample moves the same way whatever batch it is evaluated in, and two
    equal samples stay equal; different members move the inputs in independent directions.
    """
    out: dict[str, np.ndarray] = {}
    for name, v in values.items():
        v = np.array(v, dtype=float)
        if rel != 0.0:
            key = (zlib.crc32(name.encode()) << 20) ^ (member * 0x9E3779B97F4A7C15 % 2**64)
            u = _unit_hash(np.ascontiguousarray(v), key % 2**64)
            v = v * (1.0 + rel * u)
        out[name] = v
    return out


def _member_from_env() -> int:
    raw = os.environ.get(MEMBER_ENV, "").strip() or "0"
    try:
        return int(raw)
    except ValueError:
        from ..errors import ConfigError

        raise ConfigError(f"environment variable {MEMBER_ENV} must be an integer; got {raw!r}",
                          field=MEMBER_ENV) from None


def apply_env(values: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``values`` perturbed as ``UQGUIDE_PERTURB`` (and ``UQGUIDE_PERTURB_MEMBER``) ask;
    unchanged when it is unset."""
    rel = perturbation_from_env()
    return perturb(values, rel, _member_from_env()) if rel else dict(values)


@dataclass(frozen=True)
class Spread:
    """A chaotic figure over a round-off ensemble: the elementwise ``median``, ``low`` (minimum)
    and ``high`` (maximum) over ``members`` runs, the unperturbed one included."""

    median: np.ndarray
    low: np.ndarray
    high: np.ndarray
    members: int

    @classmethod
    def of(cls, runs: np.ndarray) -> Spread:
        """The spread of ``runs`` (members, ...): member 0 unperturbed, member ``m > 0`` run with
        ``perturb(values, ROUNDOFF, member=m)``."""
        runs = np.asarray(runs, dtype=float)
        return cls(np.median(runs, axis=0), runs.min(axis=0), runs.max(axis=0), runs.shape[0])

    def describe(self, index: tuple[int, ...] | int = ()) -> str:
        """``"median of 5 runs under 1e-12 input perturbations; range [a, b]"`` of the element
        ``index`` (``()`` for a scalar figure)."""
        lo, hi = float(self.low[index]), float(self.high[index])
        return (f"median of {self.members} runs under {ROUNDOFF:g} input perturbations; "
                f"range [{lo:.3g}, {hi:.3g}]")
