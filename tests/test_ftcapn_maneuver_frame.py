"""FTCAPN's two readings of the Table 4 target maneuver: along the nominal initial LOS frame
(fixed vector) or along each sample's current LOS frame (rotating)."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.models.ftcapn import FTCAPN
from uqguide.models.ftcapn.model import los_frames

NAMES = ["dx", "dy", "dz", "dvx", "dvy", "dvz", "at_theta", "at_r", "at_w"]


def _free_drift_reference(m: FTCAPN, x: np.ndarray, steps: int) -> np.ndarray:
    """Independent per-step loop of the rotating reading without control or gravity: the
    acceleration is the components along the LOS frame at the step's start, held over the
    step (exact quadratic motion). Returns r at grid times 0..steps, shape (steps+1, 3)."""
    r0, v0 = m.initial_state()
    r, v = r0 + x[0:3], v0 + x[3:6]
    dt = m.params.dt
    out = [r.copy()]
    for _ in range(steps):
        e_r = r / np.linalg.norm(r)
        vp = v - (v @ e_r) * e_r
        e_t = vp / np.linalg.norm(vp)
        e_w = np.cross(e_r, e_t)
        a = x[6] * e_t + x[7] * e_r + x[8] * e_w
        r, v = r + v * dt + 0.5 * a * dt * dt, v + a * dt
        out.append(r.copy())
    return np.array(out)


@pytest.mark.parametrize("kernel", ["numpy", "numba"])
def test_rotating_maneuver_follows_the_current_los_frame(kernel, request):
    """Free drift with a large transverse maneuver: the kernel's path (and its NumPy oracle's)
    is the independent per-step loop's (round-off only; 1e-9 of the range)."""
    if kernel == "numpy":
        request.getfixturevalue("oracle_kernels")
    m = FTCAPN({"control": False, "maneuver_frame": "rotating", "t_final": 40.0})
    x = np.array([3.0, -2.0, 1.0, 0.2, -0.1, 0.3, 0.4, -0.1, 0.2])
    out = m.evaluate(x[None], NAMES, ["r"])
    ref = _free_drift_reference(m, x, out.time.size - 1)
    assert np.max(np.abs(out.series["r"][0] - ref)) <= 1e-9 * np.linalg.norm(ref[0])


def test_both_readings_agree_on_the_first_step_and_part_later():
    """The nominal start's LOS frame is the initial frame: step 1 is the same in both
    readings; later the LOS turns and the rotating maneuver with it."""
    x = np.zeros((1, 9))
    x[0, 6] = 0.3
    runs = {f: FTCAPN({"maneuver_frame": f, "t_final": 60.0}).evaluate(x, NAMES, ["r"])
            for f in ("initial", "rotating")}
    a, b = runs["initial"].series["r"][0], runs["rotating"].series["r"][0]
    np.testing.assert_allclose(a[1], b[1], rtol=1e-13)
    assert np.max(np.abs(a[-1] - b[-1])) > 1.0  # metres apart after a minute


@pytest.mark.parametrize("frame", ["initial", "rotating"])
def test_derived_zem_map_gives_the_model_zem(frame):
    """The PCE's derived-output map applied to the model's own stop state returns the model's
    zem (the same drift maneuver in both places)."""
    m = FTCAPN({"maneuver_frame": frame, "t_final": 95.0})
    rng = np.random.default_rng(5)
    x = rng.normal(size=(50, 9)) * [15, 15, 15, 3, 3, 3, 0.1, 0.1, 0.1]
    out = m.evaluate(x, NAMES, ["zem", "r_at_stop", "v_at_stop"])
    dv = m.derived_outputs()["zem"]
    y = dv.function({"r_at_stop": out.scalars["r_at_stop"], "v_at_stop": out.scalars["v_at_stop"]},
                    {n: x[:, j] for j, n in enumerate(NAMES)})
    np.testing.assert_allclose(y, out.scalars["zem"], rtol=1e-12)


def test_los_frames_are_orthonormal_and_start_as_the_initial_frame():
    rng = np.random.default_rng(1)
    F = los_frames(rng.normal(size=(20, 3)), rng.normal(size=(20, 3)))
    np.testing.assert_allclose(np.einsum("nij,nkj->nik", F, F),
                               np.broadcast_to(np.eye(3), F.shape), atol=1e-12)
    # rows e_theta, e_r, e_w: (e_r, e_theta, e_w) is right-handed
    np.testing.assert_allclose(np.linalg.det(F[:, [1, 0, 2]]), 1.0, rtol=1e-12)
    m = FTCAPN()
    r0, v0 = m.initial_state()
    np.testing.assert_allclose(los_frames(r0[None], v0[None])[0], m.initial_los_frame(),
                               atol=1e-15)
