"""NumPy oracle of the FT-AS batch: the loop and metrics of the compiled kernel
(``uqguide/models/ft_as/kernel_numba.py``).

Vectorised over the batch with one Python iteration per time step (about 2-3 ms per step
whatever the batch size), so a 3000 s run at h = 0.1 s takes about a minute. It exists to check
the compiled kernel's metric bookkeeping (settling times, final windows, peaks, impulses,
recording and failure handling) with independently written code (:mod:`.ft_as_equations`).
"""

from __future__ import annotations

import numpy as np

from tests.oracles import ft_as_equations as cl
from uqguide.models.ft_as.layout import GROUP_INDEX, RECORD_GROUPS
from uqguide.models.ft_as.setup import CASE2, PSI1, PSI2, Batch, Gains, Plant


def simulate(
    batch: Batch,
    plant: Plant,
    gains: Gains,
    dt: float,
    n_steps: int,
    rec_every: int,
    final_start: int,
    late_start: int,
    tols: np.ndarray,
    rec: np.ndarray,
    offsets: np.ndarray,
    settle: np.ndarray,
    final_max: np.ndarray,
    peak_app: np.ndarray,
    peak_cmd: np.ndarray,
    peak_late: np.ndarray,
    impulse: np.ndarray,
    failed: np.ndarray,
) -> None:
    """Fill the output arrays exactly as ``kernel_numba.simulate`` does (see its docstring)."""
    # a diverging sample produces inf/nan on purpose: it is flagged by the finiteness mask
    with np.errstate(all="ignore"):
        _simulate(batch, plant, gains, dt, n_steps, rec_every, final_start, late_start, tols,
                  rec, offsets, settle, final_max, peak_app, peak_cmd, peak_late, impulse,
                  failed)  # fmt: skip


def _simulate(batch, plant, gains, dt, n_steps, rec_every, final_start, late_start, tols, rec,
              offsets, settle, final_max, peak_app, peak_cmd, peak_late, impulse,
              failed) -> None:  # fmt: skip
    X = batch.x0.astype(float).copy()
    n = X.shape[0]
    alive = np.ones(n, dtype=bool)
    case2 = batch.controller == CASE2
    env_lo = np.full((n, 6), np.inf)
    env_hi = np.full((n, 6), -np.inf)
    j = 0
    last_row = np.zeros((n,), dtype=int)
    for ks in range(n_steps + 1):
        t = ks * dt
        held = cl.controller(t, X, batch, gains, plant)
        tr = cl.tracking(t, X, plant)
        s_true = np.where(case2[:, None], cl.sliding_variable(tr.e1, tr.e2, gains), held.s)
        eps1 = X[:, PSI1] - tr.e2
        norms = np.column_stack([
            np.linalg.norm(X[:, 0:3], axis=1), np.linalg.norm(X[:, 3:6], axis=1),
            np.linalg.norm(X[:, 6:9], axis=1), np.linalg.norm(tr.omega_e, axis=1),
            np.linalg.norm(eps1, axis=1), np.linalg.norm(s_true[:, :3], axis=1),
            np.linalg.norm(s_true[:, 3:], axis=1),
        ])  # fmt: skip
        above = (norms[:, :, None] > tols[None]) & (tols[None] > 0.0) & alive[:, None, None]
        settle[above] = t
        if ks >= final_start:
            cur = np.stack([np.abs(X[:, 0:3]), np.abs(X[:, 3:6]), np.abs(X[:, 6:9]),
                            np.abs(tr.omega_e)], axis=1)  # fmt: skip
            final_max[alive] = np.maximum(final_max[alive], cur[alive])
        u = held.applied
        if ks < n_steps:
            peak_app[alive] = np.maximum(peak_app[alive], np.abs(u[alive]))
            peak_cmd[alive] = np.maximum(peak_cmd[alive], np.abs(held.command[alive]))
            if ks >= late_start:
                peak_late[alive] = np.maximum(peak_late[alive], np.abs(u[alive]))
            impulse[alive] += np.abs(u[alive]) * dt
        env_lo = np.minimum(env_lo, u)
        env_hi = np.maximum(env_hi, u)
        if ks % rec_every == 0 and j < rec.shape[1]:
            d_obs = cl.true_disturbance(t, X, u, batch, plant) + cl.apply_M(
                u - held.observed, tr.G, plant
            )
            values = {
                "r_e": X[:, 0:3], "v_e": X[:, 3:6], "sigma_e": X[:, 6:9], "omega_e": tr.omega_e,
                "s": s_true, "u_command": held.command, "u_applied_min": env_lo,
                "u_applied_max": env_hi, "eps1": eps1, "eps2": X[:, PSI2] - d_obs,
                "d_hat": X[:, PSI2], "d_obs": d_obs, "chi1": X[:, 24:30],
            }  # fmt: skip
            for name, width in RECORD_GROUPS.items():
                o = offsets[GROUP_INDEX[name]]
                if o >= 0:
                    rec[alive, j, o : o + width] = values[name][alive]
            last_row[alive] = j
            j += 1
            env_lo = np.full((n, 6), np.inf)
            env_hi = np.full((n, 6), -np.inf)
        if ks == n_steps:
            break
        Xn = cl.rk4_advance(t, X, dt, held, batch, gains, plant)
        bad = alive & ~np.all(np.isfinite(Xn), axis=1)
        failed[bad] = True
        alive &= ~bad
        X = np.where(alive[:, None], Xn, X)
    # a sample that stopped early keeps its last recorded values on the rest of the grid
    for i in np.flatnonzero(failed):
        rec[i, last_row[i] + 1 :] = rec[i, last_row[i]]
