"""``uqguide simulate`` of a model without a paper scenario: one run at the study's centre
(each uncertain input at its distribution's mean, the others at the model's nominal values),
its scalars printed, each series summarised and plotted."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..config.run_config import RunConfig
from ..core.types import ModelOutput
from ..errors import UqguideError
from ..models.base import OutputInfo


def centre_run(cfg: RunConfig) -> tuple[dict[str, float], ModelOutput]:
    """Every input's value and the model's every output at the centre (module docstring);
    UqguideError with the model's reason when the run fails."""
    x = np.array([[m.moments()[0] for m in cfg.space.marginals]])
    model = cfg.model
    try:
        out = model.evaluate(x, list(cfg.space.names), [o.name for o in model.outputs()])
    except UqguideError:
        raise
    except Exception as exc:  # noqa: BLE001 - the model's own failure: one line, no traceback
        raise UqguideError(f"the nominal run failed: {type(exc).__name__}: {exc}") from None
    if out.failed[0]:
        raise UqguideError(f"the nominal run failed: {out.reasons[0]}")
    return model.full_values(x[0], cfg.space.names), out


def render(values: dict[str, float], out: ModelOutput, outputs: list[OutputInfo]) -> str:
    """The console report: the inputs, each scalar, each series' first, last, least and
    largest value per component (``outputs``: their units and component names)."""
    info = {o.name: o for o in outputs}

    def label(name: str, c: int) -> str:
        o = info[name]
        part = "" if o.k == 1 else f"[{o.components[c] or c}]"
        return f"{name}{part}" + (f" [{o.unit}]" if o.unit not in ("", "1") else "")

    lines = ["inputs (uncertain ones at their mean): "
             + ", ".join(f"{k} = {v:.6g}" for k, v in values.items())]
    for name, v in out.scalars.items():
        for c, value in enumerate(v[0]):
            lines.append(f"{label(name, c)} = {value:.10g}")
    if out.series:
        t = out.time
        lines.append(f"series over {t.size} steps, t = {t[0]:.6g} .. {t[-1]:.6g} s:")
        lines.append(f"  {'output':<20} {'first':>13} {'last':>13} {'min':>13} {'max':>13}")
        for name, y in out.series.items():
            for c in range(y.shape[2]):
                s = y[0, :, c]
                cells = " ".join(f"{v:>13.6g}" for v in (s[0], s[-1], s.min(), s.max()))
                lines.append(f"  {label(name, c):<20} {cells}")
    return "\n".join(lines)


def write_figures(out: ModelOutput, name: str, out_dir: Path) -> list[Path]:
    """The series against time (one panel per output) as ``<name>_nominal.png``; none when
    the model has no series."""
    from ..core import atomic
    from .replay import history_figure

    if not out.series:
        return []
    atomic.make_folder(out_dir)
    return [history_figure(out, f"{name}: nominal run", out_dir / f"{name}_nominal.png")]
