"""The FT-AS closed loop's equations in NumPy, batched over samples (ft-as-controller.md 3-9).

Each function maps one equation of the spec to arrays of leading length ``n``. This is the
readable reference: the spec's unit tests (the ``h``/``M``/``d`` split, the ``s_dot``
identity, the observer) run on it, and the compiled kernel
(``uqguide/models/ft_as/kernel_numba.py``) is tested against :func:`rk4_step` step by step.

Notation: ``e1 = [r_e; sigma_e]``, ``e2 = [v_e; G(sigma_e) omega_e]``,
``e2_dot = h + M u + d`` (paper eq 11).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uqguide.models.dynamics import mrp
from uqguide.models.ft_as import scenario
from uqguide.models.ft_as.setup import (
    CASE1, CASE2, CHI1, CHI2, OMEGA, PSI1, PSI2, R_E, SIGMA_E, V_E, Batch, Gains, Plant,
)


def sig(x: np.ndarray, p: float) -> np.ndarray:
    """``sig^p(x) = |x|^p sign(x)`` per component (``sign(0) = 0``)."""
    return np.abs(x) ** p * np.sign(x)


def saturate(u: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """Smooth saturation ``u_bar tanh(u / u_bar)`` per axis (paper eq 14), (n, 6)."""
    return limits * np.tanh(u / limits)


def _mv(A: np.ndarray, x: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", A, x)


def reference_orbit(plant: Plant, t: float) -> np.ndarray:
    """Reference position ``r_t(t)`` [m], ECI, (3,)."""
    return plant.reference.state(t)[0]


def differential_gravity(r_t: np.ndarray, r_e: np.ndarray, mu: float) -> np.ndarray:
    """``-mu r/|r|^3 + mu r_t/|r_t|^3`` with ``r = r_t + r_e`` [m/s^2], (n, 3).

    Written as ``-mu/|r_t|^3 [k r_e + (k - 1) r_t]`` with ``k = (|r_t|/|r|)^3`` and ``k - 1``
    from ``expm1``/``log1p``: the direct difference of two 8 m/s^2 terms would lose the
    1e-12 m/s^2 level that sub-millimetre tracking needs.
    """
    rt2 = float(r_t @ r_t)
    q = (2.0 * r_e @ r_t + np.sum(r_e * r_e, axis=-1)) / rt2
    km1 = np.expm1(-1.5 * np.log1p(q))
    return -mu / rt2**1.5 * ((1.0 + km1)[:, None] * r_e + km1[:, None] * r_t)


@dataclass
class Tracking:
    """The tracking-error model at one state (section 5), arrays (n, ...)."""

    e1: np.ndarray  # (n, 6)
    e2: np.ndarray  # (n, 6)
    h: np.ndarray  # (n, 6)
    G: np.ndarray  # (n, 3, 3) kinematics matrix of sigma_e
    G_inv: np.ndarray  # (n, 3, 3)
    C: np.ndarray  # (n, 3, 3) C(sigma_e) = C_{B/R}
    omega_e: np.ndarray  # (n, 3) [rad/s]


def tracking(t: float, x: np.ndarray, plant: Plant) -> Tracking:
    """``e1``, ``e2``, ``h`` and ``M``'s ingredients from the plant state (section 5).

    Parameters
    ----------
    t : float
        Time [s].
    x : ndarray, shape (n, >= 12)
        ``(r_e, v_e, sigma_e, omega)``; further columns are ignored.
    plant : Plant
    """
    sigma, omega = x[:, SIGMA_E], x[:, OMEGA]
    G, C = mrp.kinematics_matrix(sigma), mrp.dcm(sigma)
    w_t = _mv(C, plant.omega_t)  # omega_t in B
    omega_e = omega - w_t
    sigma_dot = _mv(G, omega_e)
    J0, J0i = plant.J0, plant.J0_inv
    h_sigma = _mv(mrp.kinematics_matrix_dot(sigma, sigma_dot), omega_e) + _mv(
        G, -(np.cross(omega, omega @ J0.T) @ J0i.T) + np.cross(omega_e, w_t)
    )
    mu = plant.reference.mu
    h_r = differential_gravity(reference_orbit(plant, t), x[:, R_E], mu)
    return Tracking(
        e1=np.concatenate([x[:, R_E], sigma], axis=1),
        e2=np.concatenate([x[:, V_E], sigma_dot], axis=1),
        h=np.concatenate([h_r, h_sigma], axis=1),
        G=G,
        G_inv=mrp.kinematics_matrix_inv(sigma),
        C=C,
        omega_e=omega_e,
    )


def apply_M(u: np.ndarray, G: np.ndarray, plant: Plant) -> np.ndarray:
    """``M u = [u_f / m0 ; G J0^-1 u_tau]`` [m/s^2, 1/s^2], (n, 6)."""
    return np.concatenate([u[:, :3] / plant.m0, _mv(G, u[:, 3:] @ plant.J0_inv.T)], axis=1)


def apply_M_inv(v: np.ndarray, G_inv: np.ndarray, plant: Plant) -> np.ndarray:
    """``M^-1 v = [m0 v_r ; J0 G^-1 v_sigma]`` [N, N m], (n, 6)."""
    return np.concatenate([plant.m0 * v[:, :3], _mv(G_inv, v[:, 3:]) @ plant.J0.T], axis=1)


def true_inertia(t: float, batch: Batch, plant: Plant) -> np.ndarray:
    """``J(t) = J0 (1 + inertia_scale_error) + Delta J(t)`` [kg m^2], (n, 3, 3)."""
    return (1.0 + batch.inertia_scale_error)[:, None, None] * plant.J0 + np.diag(
        scenario.inertia_delta_diag(t)
    )


def plant_rhs(t: float, x: np.ndarray, u: np.ndarray, batch: Batch, plant: Plant) -> np.ndarray:
    """Truth dynamics in error coordinates (section 3.2), ``d(r_e, v_e, sigma_e, omega)/dt``.

    Parameters
    ----------
    t : float
        Time [s].
    x : ndarray, shape (n, >= 12)
    u : ndarray, shape (n, 6)
        Applied force (ECI) [N] and torque (body) [N m].

    Returns
    -------
    ndarray, shape (n, 12)
    """
    mu = plant.reference.mu
    m = scenario.mass_true(t, plant.m0, batch.mass_offset)
    J = true_inertia(t, batch, plant)
    d_f = scenario.force_disturbance(t, batch.force_amp)
    d_tau = scenario.torque_disturbance(t, batch.torque_amp)
    r_dd = differential_gravity(reference_orbit(plant, t), x[:, R_E], mu) + (
        u[:, :3] + d_f
    ) / m[:, None]
    sigma, omega = x[:, SIGMA_E], x[:, OMEGA]
    omega_e = omega - _mv(mrp.dcm(sigma), plant.omega_t)
    sigma_dot = _mv(mrp.kinematics_matrix(sigma), omega_e)
    omega_dot = np.linalg.solve(J, (-np.cross(omega, _mv(J, omega)) + u[:, 3:] + d_tau)[..., None])
    return np.concatenate([x[:, V_E], r_dd, sigma_dot, omega_dot[..., 0]], axis=1)


def true_disturbance(
    t: float, x: np.ndarray, u: np.ndarray, batch: Batch, plant: Plant
) -> np.ndarray:
    """Lumped disturbance ``d`` in closed form (section 5) for the applied input ``u``, (n, 6).

    ``d_r = (1/m - 1/m0) f + d_f/m``,
    ``d_sigma = G [J^-1 (-w x J w + tau + d_tau) - J0^-1 (-w x J0 w + tau)]``.
    """
    m = scenario.mass_true(t, plant.m0, batch.mass_offset)[:, None]
    J = true_inertia(t, batch, plant)
    d_f = scenario.force_disturbance(t, batch.force_amp)
    d_tau = scenario.torque_disturbance(t, batch.torque_amp)
    f, tau, w = u[:, :3], u[:, 3:], x[:, OMEGA]
    d_r = (1.0 / m - 1.0 / plant.m0) * f + d_f / m
    true_acc = np.linalg.solve(J, (-np.cross(w, _mv(J, w)) + tau + d_tau)[..., None])[..., 0]
    nom_acc = (-np.cross(w, w @ plant.J0.T) + tau) @ plant.J0_inv.T
    G = mrp.kinematics_matrix(x[:, SIGMA_E])
    return np.concatenate([d_r, _mv(G, true_acc - nom_acc)], axis=1)


def sliding_variable(e1: np.ndarray, e2: np.ndarray, gains: Gains) -> np.ndarray:
    """``s = e1 + sig^a(kappa e2)``, ``kappa = 1/(nu1 |e1|^b + eta1)`` (eq 26-27), (n, 6)."""
    kappa = 1.0 / (gains.nu1 * np.abs(e1) ** gains.b + gains.eta1)
    return e1 + sig(kappa * e2, gains.a)


def singularity_weight(e2: np.ndarray, gains: Gains) -> np.ndarray:
    """``g = phi / f`` with ``f = |e2|^(a-1)``, ``phi = sin(pi f / (2 eps))`` for ``f < eps``
    else 1, and ``g = 1`` where ``e2 = 0`` (eq 30, 40; [A9]), (n, 6)."""
    f = np.abs(e2) ** (gains.a - 1.0)
    phi = np.where(f < gains.eps, np.sin(np.pi * f / (2.0 * gains.eps)), 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(e2 == 0.0, 1.0, phi / f)


def switching(s: np.ndarray, gains: Gains) -> np.ndarray:
    """``sign(s)``, or ``tanh(s / boundary)`` when a boundary layer is set, (n, 6)."""
    if gains.boundary > 0.0:
        return np.tanh(s / gains.boundary)
    return np.sign(s)


def control_law(
    e1: np.ndarray,
    e2: np.ndarray,
    h: np.ndarray,
    d_hat: np.ndarray,
    G_inv: np.ndarray,
    switch_input: np.ndarray,
    gains: Gains,
    plant: Plant,
) -> tuple[np.ndarray, np.ndarray]:
    """FT-NTSM command ``u_c`` (eq 29; Case 1/2: eq 42) and the sliding variable.

    Parameters
    ----------
    e1, e2 : ndarray, shape (n, 6)
        Tracking errors (Case 2: the compensated errors ``z1, z2``).
    h : ndarray, shape (n, 6)
        Known dynamics (Case 2: ``h + k1 chi1 + k2 chi2``).
    d_hat : ndarray, shape (n, 6)
        Disturbance estimate ``psi2``.
    G_inv : ndarray, shape (n, 3, 3)
        Inverse kinematics matrix of ``sigma_e``.
    switch_input : ndarray of bool, shape (n,)
        [A10] units of ``gamma``.

    Returns
    -------
    u_c : ndarray, shape (n, 6)
        Command [N, N m].
    s : ndarray, shape (n, 6)
    """
    a, b, c = gains.a, gains.b, gains.c
    kappa = 1.0 / (gains.nu1 * np.abs(e1) ** b + gains.eta1)
    s = e1 + sig(kappa * e2, a)
    reach = gains.nu2 * sig(s, gains.m2n2) + gains.eta2 * sig(s, gains.p2q2)
    k_a = kappa ** (-a)
    v = (
        gains.nu1 * b * kappa * sig(e1, b - 1.0) * e2**2
        - c * k_a * sig(e2, 2.0 - a)
        - c * k_a * singularity_weight(e2, gains) * reach
        - h
        - d_hat
    )
    w = gains.gamma * switching(s, gains)
    accel = ~np.asarray(switch_input, dtype=bool)
    v = v - np.where(accel[:, None], w, 0.0)
    u = apply_M_inv(v, G_inv, plant) - np.where(accel[:, None], 0.0, w)
    return u, s


def observer_unit(eps1: np.ndarray, per_channel: bool) -> tuple[np.ndarray, np.ndarray]:
    """Unit vector of ``eps1`` and its norm, over R^6 or per 3-D channel ([A12]).

    Returns
    -------
    unit : ndarray, shape (n, 6)
        ``eps1 / |eps1|`` (0 where the norm is 0).
    norm : ndarray, shape (n, 6)
        The norm, repeated over the components it belongs to.
    """
    if per_channel:
        nrm = np.linalg.norm(eps1.reshape(-1, 2, 3), axis=2)
        nrm = np.repeat(nrm, 3, axis=1)
    else:
        nrm = np.repeat(np.linalg.norm(eps1, axis=1, keepdims=True), 6, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = np.where(nrm > 0.0, eps1 / nrm, 0.0)
    return unit, nrm


def observer_rhs(
    psi1: np.ndarray,
    psi2: np.ndarray,
    e2: np.ndarray,
    h: np.ndarray,
    M_u_obs: np.ndarray,
    gains: Gains,
) -> tuple[np.ndarray, np.ndarray]:
    """FT-DO (eq 18-20): ``d psi1/dt`` and ``d psi2/dt``, each (n, 6).

    ``psi1' = -lam1 unit |eps1|^(1/2) - lam2 unit |eps1|^p + psi2 + h + M u_obs``,
    ``psi2' = -lam3 unit``, ``eps1 = psi1 - e2``.
    """
    unit, nrm = observer_unit(psi1 - e2, gains.obs_per_channel)
    d1 = (
        -gains.lam1 * unit * np.sqrt(nrm)
        - gains.lam2 * unit * nrm**gains.obs_p
        + psi2
        + h
        + M_u_obs
    )
    return d1, -gains.lam3 * unit


@dataclass
class HeldInputs:
    """Inputs held over one step (zero-order hold, section 9), each (n, 6)."""

    applied: np.ndarray  # sat(u_c) or u_c (Case 1)
    observed: np.ndarray  # u_obs
    deficit: np.ndarray  # Case 2: sat(u_T) - u_T, else 0
    command: np.ndarray  # u_c or u_T
    s: np.ndarray  # sliding variable used by the law


def controller(t: float, X: np.ndarray, batch: Batch, gains: Gains, plant: Plant) -> HeldInputs:
    """Evaluate each sample's controller at the start of a step (sections 7-8).

    Parameters
    ----------
    X : ndarray, shape (n, 36)
    """
    tr = tracking(t, X, plant)
    case2 = (batch.controller == CASE2)[:, None]
    k1 = batch.omega_chi[:, None] ** 2
    k2 = 2.0 * batch.omega_chi[:, None]
    chi1 = np.where(case2, X[:, CHI1], 0.0)
    chi2 = np.where(case2, X[:, CHI2], 0.0)
    u_c, s = control_law(
        tr.e1 - chi1,
        tr.e2 - chi2,
        tr.h + k1 * chi1 + k2 * chi2,
        X[:, PSI2],
        tr.G_inv,
        batch.switch_input,
        gains,
        plant,
    )
    unconstrained = (batch.controller == CASE1)[:, None]
    applied = np.where(unconstrained, u_c, saturate(u_c, plant.limits))
    sees_applied = (batch.observer_on_applied[:, None] | case2) & ~unconstrained
    observed = np.where(sees_applied, applied, u_c)
    deficit = np.where(case2, applied - u_c, 0.0)
    return HeldInputs(applied, observed, deficit, u_c, s)


def closed_loop_rhs(
    t: float, X: np.ndarray, held: HeldInputs, batch: Batch, gains: Gains, plant: Plant
) -> np.ndarray:
    """``dX/dt`` of the 36-element state with the held inputs (section 9 step 3), (n, 36)."""
    tr = tracking(t, X, plant)
    dX = np.empty_like(X)
    dX[:, :12] = plant_rhs(t, X, held.applied, batch, plant)
    dX[:, PSI1], dX[:, PSI2] = observer_rhs(
        X[:, PSI1], X[:, PSI2], tr.e2, tr.h, apply_M(held.observed, tr.G, plant), gains
    )
    k1 = batch.omega_chi[:, None] ** 2
    k2 = 2.0 * batch.omega_chi[:, None]
    dX[:, CHI1] = X[:, CHI2]
    dX[:, CHI2] = -k1 * X[:, CHI1] - k2 * X[:, CHI2] + apply_M(held.deficit, tr.G, plant)
    return dX


def rk4_advance(
    t: float, X: np.ndarray, dt: float, held: HeldInputs, batch: Batch, gains: Gains, plant: Plant
) -> np.ndarray:
    """Classical RK4 over one step with the held inputs, then the MRP shadow guard and the
    optional ``psi2`` box (section 9 steps 3-4), (n, 36)."""
    k1 = closed_loop_rhs(t, X, held, batch, gains, plant)
    k2 = closed_loop_rhs(t + dt / 2, X + dt / 2 * k1, held, batch, gains, plant)
    k3 = closed_loop_rhs(t + dt / 2, X + dt / 2 * k2, held, batch, gains, plant)
    k4 = closed_loop_rhs(t + dt, X + dt * k3, held, batch, gains, plant)
    Xn = X + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    Xn[:, SIGMA_E] = mrp.shadow(Xn[:, SIGMA_E])
    bound = batch.psi2_bound[:, None]
    Xn[:, PSI2] = np.clip(Xn[:, PSI2], -bound, bound)
    return Xn


def rk4_step(
    t: float, X: np.ndarray, dt: float, batch: Batch, gains: Gains, plant: Plant
) -> tuple[np.ndarray, HeldInputs]:
    """One sampled-data step: controller at ``t``, then :func:`rk4_advance` (section 9).

    Returns
    -------
    X_next : ndarray, shape (n, 36)
    held : HeldInputs
        The inputs applied over the step.
    """
    held = controller(t, X, batch, gains, plant)
    return rk4_advance(t, X, dt, held, batch, gains, plant), held
