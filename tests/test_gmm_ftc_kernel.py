"""The compiled GMM-FTC closed loop against the NumPy reference (tests/oracles/gmm_ftc.py).

Same inputs (per-sample spin rates, thrust factors, keyed per-period noise, a controller with
the nominal spin or the printed model, sub-steps, a thrust limit): the two must agree to
rounding. Only the order of floating-point sums differs, so states agree to ~1e-15 relative
after 300 steps of this contracting loop; the tolerance 1e-10 leaves margin for the 1e4
amplification of the reaching law's sig^0.6 near s2 = 0. Runs that cross a 3 mm GMM sheet are
chaotic (a kick of 1e3 m/s^2 or more depends on where a sample lands inside the sheet), so for
those only the collision verdict is compared.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.oracles import substituted
from uqguide.models.gmm_ftc import GMMFTC

NAMES = ["dx0", "dy0", "dvz0", "dw_x", "dw_z", "thrust_scale_x", "thrust_scale"]
X = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0],
    [0.6, 0.4, 0.01, 0.002, -0.004, 1.04, 0.98],
    [-0.8, 0.7, -0.02, -0.001, 0.003, 0.96, 1.01],
])


@pytest.mark.parametrize("variant", [
    {},
    {"controller_spin": "nominal", "n_sub": 2, "u_max": 0.3},
    {"controller_model": "printed", "thrust_noise": 0.0, "variance_floor": 0.05},
])
def test_numba_kernel_matches_numpy_reference(variant):
    params = {"t_final": 30.0, "record_dt": 0.5, **variant}
    outs = [o.name for o in GMMFTC().outputs()]
    with substituted():
        ref = GMMFTC(params).evaluate(X, NAMES, outs)
    fast = GMMFTC(params).evaluate(X, NAMES, outs)
    np.testing.assert_array_equal(ref.time, fast.time)
    for k, a in ref.series.items():
        scale = max(np.abs(a).max(), 1e-300)
        np.testing.assert_allclose(fast.series[k], a, rtol=0, atol=1e-10 * scale, err_msg=k)
    for k, a in ref.scalars.items():
        np.testing.assert_allclose(fast.scalars[k], a, rtol=1e-10, atol=1e-14, err_msg=k)


@pytest.mark.slow
def test_numba_kernel_collision_verdict_on_a_chaotic_run():
    params = {"t_final": 80.0, "thrust_noise": 0.0}
    x = np.array([[-6.0], [0.0]])  # start (12, -3, 1): crosses the +x panel (spec 11)
    with substituted():
        ref = GMMFTC(params).evaluate(x, ["dy0"], ["collided"])
    fast = GMMFTC(params).evaluate(x, ["dy0"], ["collided"])
    np.testing.assert_array_equal(fast.scalars["collided"], ref.scalars["collided"])
    assert ref.scalars["collided"][:, 0].tolist() == [1.0, 0.0]


def test_numba_kernel_is_bitwise_independent_of_blocks_threads_and_batch():
    """The kernel advances blocks of 64 samples in lockstep on parallel threads: a sample's
    numbers must not depend on its block, its lane, the thread count, or whether the batch
    shares one spin rate (the attitude is then computed once for all lanes)."""
    import numba

    from uqguide.models.gmm_ftc.kernel_numba import BLOCK

    rng = np.random.default_rng(5)
    n = BLOCK + 6
    names = ["dx0", "dy0", "dvx0", "dw_z", "thrust_scale_x"]
    x = np.column_stack([rng.normal(0, 1, n), rng.normal(0, 1, n), rng.normal(0, 0.01, n),
                         rng.normal(0, 0.003, n), rng.uniform(0.95, 1.05, n)])
    model = GMMFTC({"t_final": 5.0, "record_dt": 0.5, "thrust_noise": 0.05})
    outs = [o.name for o in model.outputs()]
    full = model.evaluate(x, names, outs)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        tail = model.evaluate(x[5:], names, outs)  # every sample in another lane
    finally:
        numba.set_num_threads(before)
    alone = model.evaluate(x[-1:], names, outs)  # one sample: a common spin
    common = x.copy()
    common[:, 3] = x[-1, 3]
    shared = model.evaluate(common, names, outs)
    def same(got, ref, rows):
        for k, a in got.series.items():
            np.testing.assert_array_equal(a, ref.series[k][rows], err_msg=k)
        for k, a in got.scalars.items():
            np.testing.assert_array_equal(a, ref.scalars[k][rows], err_msg=k)

    same(tail, full, slice(5, None))
    same(alone, full, slice(n - 1, None))
    same(alone, shared, slice(n - 1, None))
