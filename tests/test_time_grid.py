"""The shared whole-step check of every time-stepping simulator (uqguide.models.time_grid)."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from uqguide.models.ft_as.params import FTASParams
from uqguide.models.gmm.model import GMMProximityParams
from uqguide.models.gmm_ftc.loop import LoopSettings
from uqguide.models.gmm_ftc.model import GMMFTCParams
from uqguide.models.time_grid import recording_stride, whole_steps


def test_decimal_steps_count_whole_despite_round_off():
    # 3000 / 0.01 = 299999.99999999994 and 0.3 / 0.1 = 2.9999999999999996 in binary
    assert whole_steps(3000.0, 0.01, "duration") == 300_000
    assert whole_steps(0.3, 0.1, "t_final") == 3
    assert recording_stride(10.0, 0.1, 3000, "record_dt") == 100


@pytest.mark.parametrize("span, step", [(800.5, 1.0), (0.05, 0.1), (0.0, 0.1)])
def test_a_partial_or_empty_step_is_refused_with_the_names(span, step):
    with pytest.raises(ValueError, match=r"^t_f = .* must be a multiple of dt = "):
        whole_steps(span, step, "t_f")


def test_a_stride_must_divide_the_run():
    with pytest.raises(ValueError, match="record_dt = 30 s must divide t_final = 100 s"):
        recording_stride(30.0, 1.0, 100, "record_dt")


@pytest.mark.parametrize("params, field", [
    (lambda: GMMProximityParams(t_f=800.5), "t_f"),
    (lambda: GMMProximityParams(record_interval=30.0), "record_interval"),
    (lambda: GMMFTCParams(t_final=300.05), "t_final"),
    (lambda: GMMFTCParams(record_dt=0.7), "record_dt"),
    (lambda: FTASParams(duration=3000.005), "duration"),
    (lambda: LoopSettings(t_final=300.05), "t_final"),
])
def test_every_simulator_refuses_through_the_same_check(params, field):
    with pytest.raises((ValidationError, ValueError), match=rf"{field} = \S+ s must "):
        params()


def test_the_closed_loop_settings_need_whole_records():
    with pytest.raises(ValueError, match=r"record_every \* dt = 0.7 s must divide"):
        LoopSettings(dt=0.1, t_final=300.0, record_every=7)
