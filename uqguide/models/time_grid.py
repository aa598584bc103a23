"""Fixed-step time grids: a span must hold a whole number of steps.

Every time-stepping simulator checks that its horizon (and its recording interval) is a whole
number of integration steps, so that the last step lands on the final time and the recorded
grid is the same for every sample; this is that one check, with one message.
"""

from __future__ import annotations

__all__ = ["recording_stride", "whole_steps"]


def whole_steps(span: float, step: float, what: str, step_name: str = "dt",
                rtol: float = 1e-9) -> int:
    """``round(span / step)`` (at least 1) for a ``span`` and ``step`` > 0 [s], when ``span``
    is a positive whole number of steps up to ``rtol`` (round-off of decimal steps); ValueError
    naming the parameters ``what`` and ``step_name`` otherwise."""
    ratio = span / step
    n = round(ratio)
    if n < 1 or abs(ratio - n) > rtol * ratio:
        raise ValueError(f"{what} = {span:g} s must be a multiple of {step_name} = {step:g} s "
                         "(a whole number of steps)")
    return int(n)


def recording_stride(interval: float, step: float, n_steps: int, what: str,
                     step_name: str = "dt", span_name: str = "t_final") -> int:
    """Steps between two recorded points, ``interval / step``, when ``interval`` [s] is whole
    steps that divide the run of ``n_steps`` (:func:`whole_steps` of the final time); ValueError
    naming the parameters otherwise."""
    every = whole_steps(interval, step, what, step_name)
    if n_steps % every:
        raise ValueError(f"{what} = {interval:g} s must divide {span_name} = {n_steps * step:g} s "
                         f"into whole records ({n_steps} steps of {step_name} = {step:g} s)")
    return every
