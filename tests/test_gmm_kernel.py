"""The compiled gmm_proximity closed loop (models/gmm/kernel_numba.py) against the NumPy reference
(tests/oracles/gmm.py), and its invariance to the batch split and the thread count.

Both run the same arithmetic; they differ by round-off (the libm against NumPy's vector ``pow``
and ``exp``, and the kernel's algebraic forms of the fractional powers). Round-off grows along a
sliding-mode run that chatters at the 1 s sampling: in GMM-TSMC a 1e-12 move of the start moves
the path by up to 20 % in some samples, in GMM-NTSMC by 1e-6 in a few. So a sample is compared
only where the reference itself reproduces under round-off: its outputs move by less than 1e-9
of their scale when the initial position moves by 1e-12 (relative). On those samples kernel and
reference must agree to 1e-9 of the scale (many decades above the round-off of a run that does
not chatter, ~1e-14, and as many below a change of the arithmetic: a wrong term moves outputs
by 1e-3 or more), allowing 1 in 20 that chaos reaches through the kernel's different round-off
but not through the perturbation.
"""

from __future__ import annotations

from collections.abc import Mapping

import numba
import numpy as np
import pytest

from tests.oracles import substituted
from uqguide.models.gmm.kernel_numba import BLOCK, block_size
from uqguide.models.gmm.loop import SampledRun
from uqguide.models.gmm.model import GMMProximity

E_START = {"r0": (-15.0, 16.0, 0.0)}
F2 = {**E_START, "gmm_sigma_floor": 0.3, "antenna_half_width": 0.3}

CASES = {
    "E_ntsmc_perturbed_gmm": (E_START, True),
    "F2_ntsmc": (F2, True),
    "literal_ntsmc_published_law": ({"ntsmc_eps": 0.0}, False),
    "E_gmm_tsmc": ({**E_START, "controller": "gmm_tsmc"}, True),
    "literal_apf_tsmc_shifted": ({"controller": "apf_tsmc"}, True),
    "E_per_axis_saturation": ({**E_START, "saturation": "per_axis"}, False),
    "F2_no_saturation_fitted": ({**F2, "saturation": "none", "gmm_source": "fitted"}, False),
}
N = 100  # one full block and a partial one


def _inputs(n: int, seed: int, gmm: bool) -> dict[str, np.ndarray]:
    """The dispersion of configs/gmm_dispersion.yaml (GMM errors optional)."""
    rng = np.random.default_rng(seed)
    vals = {k: rng.normal(0.0, 0.5, n) for k in ("dx0", "dy0", "dz0")}
    vals.update({k: rng.normal(0.0, 0.005, n) for k in ("dvx0", "dvy0", "dvz0")})
    vals["thrust_scale"] = rng.uniform(0.95, 1.05, n)
    zero, one = np.zeros(n), np.ones(n)
    shifts = {k: rng.normal(0.0, 0.05, n) if gmm else zero
              for k in ("gmm_shift_x", "gmm_shift_y", "gmm_shift_z")}
    vals.update(shifts)
    vals["gmm_mean_scale"] = rng.uniform(0.98, 1.02, n) if gmm else one
    vals["gmm_cov_scale"] = rng.uniform(0.9, 1.1, n) if gmm else one
    return vals


def _run(params: Mapping[str, object], kernel: str, vals: Mapping[str, np.ndarray],
         **kw: object) -> SampledRun:
    """A run of the compiled kernel (``numba``) or of its NumPy oracle (``numpy``)."""
    n = len(vals["dx0"])
    if kernel == "numpy":
        with substituted():
            return GMMProximity(params).run(vals, n, zem=True, **kw)
    return GMMProximity(params).run(vals, n, zem=True, **kw)


FIELDS = ("r", "v", "zem", "delta_v_history", "delta_v", "clearance", "penetration", "min_range")
EXACT = ("hits", "n_saturated", "n_nonfinite", "failed")


# Each case costs ~1 CPU-s (the NumPy reference steps in Python). The default suite keeps one
# case per controller family and saturation mode; the slow tests run the rest.
SLOW_CASES = {"F2_ntsmc", "literal_ntsmc_published_law", "E_gmm_tsmc", "F2_no_saturation_fitted"}


@pytest.mark.parametrize("case", [
    pytest.param(c, marks=[pytest.mark.slow] if c in SLOW_CASES else []) for c in sorted(CASES)])
def test_compiled_kernel_agrees_with_the_reference(case):
    params, gmm = CASES[case]
    vals = _inputs(N, seed=sorted(CASES).index(case), gmm=gmm)
    fast = _run(params, "numba", vals)
    ref = _run(params, "numpy", vals)
    moved = {**vals, **{k: vals[k] * (1 + 1e-12) + 1e-12 for k in ("dx0", "dy0", "dz0")}}
    ref_moved = _run(params, "numpy", moved)
    assert not ref.failed.any()
    stable = np.ones(N, dtype=bool)
    close = np.ones(N, dtype=bool)
    for name in FIELDS:
        a, b, c = getattr(ref, name), getattr(fast, name), getattr(ref_moved, name)
        tol = 1e-9 * float(np.max(np.abs(a)))
        stable &= np.abs(a - c).reshape(N, -1).max(axis=1) <= tol
        close &= np.abs(a - b).reshape(N, -1).max(axis=1) <= tol
    for name in EXACT:
        stable &= np.all((getattr(ref, name) == getattr(ref_moved, name)).reshape(N, -1), axis=1)
        close &= np.all((getattr(ref, name) == getattr(fast, name)).reshape(N, -1), axis=1)
    assert stable.sum() >= N // 2, f"only {stable.sum()} samples reproduce under round-off"
    agree = close[stable].mean()
    assert agree >= 0.95, f"{agree:.0%} of the {stable.sum()} reproducible samples agree"


def test_same_numbers_whatever_the_split_and_the_threads():
    vals = _inputs(150, seed=7, gmm=True)
    whole = _run({**E_START, "threads": 1}, "numba", vals)
    most = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
    threaded = _run({**E_START, "threads": most}, "numba", vals)
    for lo, hi in ((0, 1), (1, 70), (70, 150)):
        part = _run({**E_START, "threads": most}, "numba",
                    {k: v[lo:hi] for k, v in vals.items()})
        for name in FIELDS + EXACT:
            np.testing.assert_array_equal(getattr(part, name), getattr(whole, name)[lo:hi],
                                          err_msg=name)
    for name in FIELDS + EXACT:
        np.testing.assert_array_equal(getattr(threaded, name), getattr(whole, name),
                                      err_msg=name)


def test_an_empty_batch_gives_empty_outputs():
    out = GMMProximity(E_START).evaluate(np.zeros((0, 1)), ["dx0"], ["delta_v", "range"])
    assert out.scalars["delta_v"].shape == (0, 1)
    assert out.series["range"].shape == (0, 81, 1)


@pytest.mark.parametrize("threads", [1, 2, 3, 8])
def test_blocks_cover_the_batch_evenly(threads):
    assert block_size(0, threads) >= 1  # an empty batch runs no block
    for n in (1, 2, 63, 64, 65, 200, 1000, 12345):
        size = block_size(n, threads)
        blocks = -(-n // size)
        assert 1 <= size <= BLOCK
        assert (blocks - 1) * size < n  # none empty
        # the busiest thread has at most a sample per block more than an even share (blocks
        # of 64 would give one of 2 threads 128 of 200 samples)
        per_thread = -(-blocks // threads)
        assert per_thread * size <= -(-n // threads) + per_thread
