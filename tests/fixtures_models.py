"""Small user functions for the callable-model tests."""

import numpy as np


def sqrt_of_x(x):
    with np.errstate(invalid="ignore"):
        return np.sqrt(x[:, 0])


def raise_if_large(x):
    if (x[:, 0] > 0.999).any():
        raise ValueError("value above 0.999 in this chunk")
    return 2 * x[:, 0]


def series_and_scalar(x):
    t = np.linspace(0.0, 1.0, 5)
    return {"time": t, "path": x[:, :1] * t[None, :], "total": x.sum(axis=1)}


def indicator(x):
    """A 0/1 output: no gradation for subset simulation's intermediate levels."""
    return (x[:, 0] > 2.0).astype(float)


def rare_flag(x):
    """1 where a > 3.5 (probability 2.3e-4 for a standard normal), else 0: an event 60 runs
    almost never see."""
    return (x[:, 0] > 3.5).astype(float)


def even_cosine(x):
    """cos(a) on a symmetric interval: even, so a degree-1 PCE of it is a constant."""
    return np.cos(x[:, 0])


#: The time grid of :func:`decaying_cosine` [s]: 401 steps over 10 s.
OSCILLATOR_TIME = np.linspace(0.0, 10.0, 401)


def decaying_cosine(x):
    """x(t) = exp(-zeta omega t) cos(omega_d t), omega_d = omega sqrt(1 - zeta^2): a damped
    oscillator released at rest-free unit displacement, with uncertain natural frequency
    ``omega`` [rad/s] and damping ratio ``zeta`` (issue 27's 2-input, 401-step series; its
    phase spreads with time, so late steps are far from polynomial in the inputs)."""
    omega, zeta = x[:, 0, None], x[:, 1, None]
    t = OSCILLATOR_TIME[None, :]
    omega_d = omega * np.sqrt(1.0 - zeta**2)
    return {"time": OSCILLATOR_TIME,
            "x": np.exp(-zeta * omega * t) * np.cos(omega_d * t)}


def decaying_cosine_at_7s(x):
    """:func:`decaying_cosine` at t = 7 s only, a scalar (a cheap case of the same fit)."""
    omega, zeta = x[:, 0], x[:, 1]
    return np.exp(-zeta * omega * 7.0) * np.cos(omega * np.sqrt(1.0 - zeta**2) * 7.0)


#: The exponent of :func:`sum_of_exponentials`.
EXP_RATE = 0.5


def sum_of_exponentials(x):
    """``y = sum_i exp(0.5 x_i) / sqrt(i)``: smooth, not a polynomial, with closed-form moments
    for independent standard normal ``x_i`` (each term lognormal)."""
    w = 1.0 / np.sqrt(np.arange(1, x.shape[1] + 1))
    return {"y": (w * np.exp(EXP_RATE * x)).sum(axis=1)}


#: CPU seconds :func:`burn_cpu` spends per row
BURN_S = 2e-3


def burn_cpu(x):
    """``y = x1``, after spending ``BURN_S`` CPU seconds per row in this process."""
    import time

    until = time.process_time() + BURN_S * x.shape[0]
    while time.process_time() < until:
        pass
    return x[:, 0]


def no_cpu(x):
    """``y = x1`` at once (the guard's own costs, beside :func:`burn_cpu`)."""
    return x[:, 0]
