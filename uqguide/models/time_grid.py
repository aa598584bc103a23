"""Fixed-step time grids: a span must hold a whole number of steps.

Every time-stepping simulator checks that its horizon (and its recording interval) is a whole
number of integration steps, so that the last step lands on the final time and the recorded
grid is the same for every sample; this is that one check, with one message.
"""

from __future__ import annotations

__all__ = ["recording_stride", "whole_steps"]


def whole_steps(span: float, step: float, what: str, step_name: str = "dt",
                rtol: float = 1e-9) -> int:
    """The number of steps ``span / step``, when it is a positive whole number.

    Parameters
    ----------
    span : float
        The duration to cover [s], e.g. the final time.
    step : float
        The step [s], > 0.
    what, step_name : str
        The parameters' names, for the message (``"t_final"``, ``"dt"``).
    rtol : float
        Relative tolerance on ``span / step`` being whole (round-off of decimal steps).

    Returns
    -------
    int
        ``round(span / step)``, at least 1.

    Raises
    ------
    ValueError
        ``span`` is not a positive whole number of steps.
    """
    ratio = span / step
    n = round(ratio)
    if n < 1 or abs(ratio - n) > rtol * ratio:
        raise ValueError(f"{what} = {span:g} s must be a multiple of {step_name} = {step:g} s "
                         "(a whole number of steps)")
    return int(n)


def recording_stride(interval: float, step: float, n_steps: int, what: str,
                     step_name: str = "dt", span_name: str = "t_final") -> int:
    """Steps between two recorded points, when ``interval`` is whole steps dividing the run.

    Parameters
    ----------
    interval : float
        Spacing of the recorded grid [s].
    step : float
        The integration step [s].
    n_steps : int
        Steps of the whole run (:func:`whole_steps` of the final time).
    what, step_name, span_name : str
        The parameters' names, for the message.

    Returns
    -------
    int
        ``interval / step``, which divides ``n_steps``.

    Raises
    ------
    ValueError
        ``interval`` is not whole steps, or does not divide the run.
    """
    every = whole_steps(interval, step, what, step_name)
    if n_steps % every:
        raise ValueError(f"{what} = {interval:g} s must divide {span_name} = {n_steps * step:g} s "
                         f"into whole records ({n_steps} steps of {step_name} = {step:g} s)")
    return every
