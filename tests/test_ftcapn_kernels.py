"""The numba kernel against its NumPy oracle (tests/oracles/ftcapn.py): same numbers, every
output, both gravity modes.

The first numba call compiles the kernel (cached on disk by ``cache=True`` afterwards).
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.oracles import substituted
from uqguide.models.ftcapn import FTCAPN

pytest.importorskip("numba")

SIGMA_TABLE4_11 = [15, 15, 15, 3, 3, 3, 1e-5, 5, 0.1, 0.1, 0.1]


@pytest.mark.parametrize("gravity, frame", [("none", "initial"), ("hill", "initial"),
                                            ("none", "rotating"), ("hill", "rotating")])
def test_numba_equals_numpy(gravity, frame):
    rng = np.random.default_rng(11)
    x = rng.normal(size=(300, 11)) * SIGMA_TABLE4_11
    x[0] = 0.0  # the nominal run
    x[1, 6] = np.nan  # a non-finite failure
    res = {}
    params = {"gravity": gravity, "t_max": 120.0, "maneuver_frame": frame}
    names = [i.name for i in FTCAPN().inputs()]
    outputs = [o.name for o in FTCAPN().outputs()]
    with substituted():
        res["numpy"] = FTCAPN(params).evaluate(x, names, outputs)
    res["numba"] = FTCAPN(params).evaluate(x, names, outputs)
    a, b = res["numpy"], res["numba"]
    assert np.array_equal(a.failed, b.failed) and np.array_equal(a.reasons, b.reasons)
    assert a.failed[1] and not a.failed[0]
    assert np.array_equal(a.time, b.time)
    ok = ~a.failed
    # Same algorithm, different operation order and libm (SIMD vs scalar pow): differences are
    # round-off carried through a stable closed loop, ~1e-14; 1e-9 of each output's scale
    # leaves room and still catches any change of formula.
    for name in a.series:
        ya, yb = a.series[name][ok], b.series[name][ok]
        scale = np.abs(ya).max(axis=(0, 1)) + 1e-300
        assert np.all(np.abs(ya - yb) <= 1e-9 * scale), name
    for name in a.scalars:
        ya, yb = a.scalars[name][ok], b.scalars[name][ok]
        assert np.array_equal(np.isnan(ya), np.isnan(yb)), name
        fin = np.isfinite(ya)
        if not fin.any():  # e.g. t_los_settle: no sample settles under a target maneuver
            continue
        # t_zem is the argument of a flat minimum: a 1e-15 change of the distance moves it by
        # ~sqrt(1e-15) relative
        rtol = 1e-6 if name == "t_zem" else 1e-9
        scale = np.abs(ya[fin]).max() + 1e-300
        assert np.all(np.abs(ya[fin] - yb[fin]) <= rtol * scale), name


def test_numba_threads_give_the_same_numbers():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(200, 7)) * [1.5, 1.5, 1.5, 0.3, 0.3, 0.3, 1e-5]
    names = ["dx", "dy", "dz", "dvx", "dvy", "dvz", "b_w"]
    one = FTCAPN({"threads": 1}).evaluate(x, names)
    all_ = FTCAPN({"threads": 0}).evaluate(x, names)
    for k in one.series:
        assert np.array_equal(one.series[k], all_.series[k])
    for k in one.scalars:
        assert np.array_equal(one.scalars[k], all_.scalars[k], equal_nan=True)
