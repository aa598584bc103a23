"""What a batch of FT-AS runs records: the channel groups and the quantities whose settling is
tracked, shared by the compiled kernel, its NumPy test oracle and the runner (which must not
import numba to know them)."""

from __future__ import annotations

# Recorded channel groups: name -> width. The caller asks for a subset through offsets.
RECORD_GROUPS: dict[str, int] = {
    "r_e": 3,
    "v_e": 3,
    "sigma_e": 3,
    "omega_e": 3,
    "s": 6,  # sliding variable on the true errors
    "u_command": 6,  # u_c (Case 2: u_T) at the grid instant
    "u_applied_min": 6,  # envelope of the applied input over the output interval
    "u_applied_max": 6,
    "eps1": 6,  # psi1 - e2
    "eps2": 6,  # psi2 - d_obs (true)
    "d_hat": 6,
    "d_obs": 6,
    "chi1": 6,
}
GROUP_INDEX = {name: i for i, name in enumerate(RECORD_GROUPS)}
# Order of the norms whose settling times are tracked (section 10) and of their tolerance rows.
SETTLE_QUANTITIES = ("r_e", "v_e", "sigma_e", "omega_e", "eps1", "s_trans", "s_rot")
