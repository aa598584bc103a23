"""``uqguide replay``: one sample of a result run again, with its full time histories.

The sample's inputs are read from the result and the model is rebuilt from its resolved config.
Each scalar is judged ``equal`` (bit for bit), ``round-off`` (at most :data:`ROUNDOFF` relative)
or ``DIFFER`` (the code or a dependency changed). Why a replay may move the last bits, and when
it runs code a result file names: ``docs/guide.md#replaying-one-run``.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

import numpy as np

from ..core import atomic
from ..config.registry import model_class
from ..config.run_config import RunConfig, validate_config
from ..errors import ConfigError, UqguideError
from ..core.events import component_index
from ..core.types import ModelOutput
from ..results.result import MethodRun, Result
from .run_and_write import canonical_config


#: The largest relative difference of a replayed scalar that is round-off, not a change: the
#: shipped models amplify one operation's 1e-16 by at most 1e3-1e5 (the largest seen between
#: two CPUs is 6e-12), and a change that matters (a gain, a step) moves them by 1e-6 and more.
ROUNDOFF = 1e-9


@dataclass
class Replay:
    """A replayed sample: its index, inputs, stored and replayed scalars, every output."""

    label: str
    index: int
    why: str
    inputs: dict[str, float]
    stored: dict[str, np.ndarray]
    replayed: ModelOutput
    stored_failed: bool

    def differences(self) -> dict[str, float]:
        """The largest relative difference ``|a - b| / max(|a|, |b|)`` of each scalar output's
        replayed value from its stored one: 0 where they agree bit for bit (NaN equals NaN),
        ``inf`` where one is NaN and the other not."""
        out = {}
        for name, v in self.stored.items():
            a = np.ascontiguousarray(v, dtype=float)
            b = np.ascontiguousarray(self.replayed.scalars[name][0], dtype=float)
            same = (a.view(np.uint64) == b.view(np.uint64)) | (np.isnan(a) & np.isnan(b))
            with np.errstate(invalid="ignore", divide="ignore"):
                rel = np.abs(a - b) / np.maximum(np.abs(a), np.abs(b))
            rel = np.where(same, 0.0, np.where(np.isnan(rel), np.inf, rel))
            out[name] = float(rel.max(initial=0.0))
        return out

    def mismatches(self, rtol: float = 0.0) -> list[str]:
        """Scalar outputs whose replayed value differs from the stored one by more than
        ``rtol`` relative (0: any bit)."""
        return [name for name, d in self.differences().items() if d > rtol]


def _model_sections(config: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The model sections a stored config would build: its model's, and one per level of a
    multi-fidelity method that changes its parameters (another function of a callable)."""
    model = config.get("model")
    if not isinstance(model, Mapping):
        return []  # a data file's result: no model runs
    sections = [dict(model)]
    for method in config.get("methods") or []:
        levels = method.get("fidelities") if isinstance(method, Mapping) else None
        for level in levels if isinstance(levels, list) else []:
            if isinstance(level, Mapping) and "surrogate" not in level:
                sections.append({**model, **level})
    return sections


def named_code(config: Mapping[str, Any]) -> list[str]:
    """What a stored config's model runs beyond uqguide's own code, one line each (empty for a
    built-in simulator or a data file); ConfigError for a model name uqguide does not know."""
    found: list[str] = []
    for section in _model_sections(config):
        text = model_class(section.get("name"), "model.name").named_code(section)
        if text and text not in found:
            found.append(text)
    return found


def _difference(theirs: Mapping[str, Any], yours: Mapping[str, Any]) -> str:
    """Where the model sections of two configs differ, for a message."""
    a, b = (json.loads(canonical_config({"model": dict(c.get("model") or {})}))["model"]
            for c in (theirs, yours))
    for key in sorted(set(a) | set(b)):
        if a.get(key) != b.get(key):
            return f"model.{key} is {b.get(key)!r}, the file's {a.get(key)!r}"
    return "the methods' fidelities differ"


def allowed_code(result: Result, *, run_code: bool = False, own: RunConfig | None = None,
                 source: str | None = None) -> list[str]:
    """The code a replay of ``result`` runs beyond uqguide's own, once it is allowed (one line
    each; empty: uqguide's code only).

    A ``callable``, ``command`` or ``fmu`` model is code that a result file from someone else
    can name. It runs only with ``run_code`` (``--run-code``), or when every model section the
    file's config builds is one of ``own``'s (the user's ``--config``; compared resolved, without
    ``isolate``; the files' content is not compared). Otherwise ConfigError naming the code and
    the flag; ``source``: the result's file for the message.
    """
    code = named_code(result.config)
    if not code or run_code:
        return code
    why = ""
    if own is not None:
        theirs = {canonical_config({"model": s}) for s in _model_sections(result.config)}
        yours = {canonical_config({"model": s}) for s in _model_sections(own.resolved())}
        if theirs <= yours:
            return code
        why = f" ({own.source} is not the same model: {_difference(result.config, own.resolved())})"
    raise ConfigError(f"{source or result.name}: its replay would run {'; '.join(code)}, as "
                      f"the file names it{why}; a result file can name any code: pass "
                      f"--run-code to run it, or --config with your own config of this model",
                      field="run_code")


def choose_sample(result: Result, cfg: RunConfig, run: MethodRun, *, sample: int | None,
                  worst: str | None, lowest: bool, event: str | None,
                  component: str | int | None = None) -> tuple[int, str]:
    """The sample index of ``run`` and a sentence saying why it was chosen: by number
    (``sample``), the largest (``lowest``: smallest) good value of ``worst``'s ``component``, or
    the first good sample in ``event``; ConfigError unless exactly one of the three is given."""
    given = [k for k, v in (("--sample", sample), ("--worst", worst), ("--event", event))
             if v is not None]
    if len(given) != 1:
        raise ConfigError(f"give exactly one of --sample, --worst, --event (got "
                          f"{', '.join(given) or 'none'})", field="sample")
    n = run.x.shape[0]
    ok = ~np.asarray(run.failed, dtype=bool)
    if sample is not None:
        if not 0 <= sample < n:
            raise ConfigError(f"--sample: {sample} is out of range; method '{run.label}' has "
                              f"samples 0..{n - 1}", field="sample")
        return sample, f"sample {sample}"
    if worst is not None:
        if worst not in run.scalars:
            raise ConfigError(f"--worst: {worst!r} is not a stored scalar output of "
                              f"'{run.label}'; allowed: {', '.join(run.scalars)}",
                              field="worst")
        info = result.output(worst)
        c = _component(worst, component, tuple(info.components))
        y = np.where(ok, run.scalars[worst][:, c], np.nan)
        if not np.isfinite(y).any():
            raise UqguideError(f"--worst {worst}: no sample of '{run.label}' has a value")
        i = int(np.nanargmin(y) if lowest else np.nanargmax(y))
        return i, f"{'smallest' if lowest else 'largest'} {worst} ({y[i]:.6g}) of {ok.sum()} " \
                  f"good samples"
    names = [e.name for e in cfg.raw.events]
    if event not in names:
        raise ConfigError(f"--event: {event!r} is not an event of this result's config; "
                          f"allowed: {', '.join(names) or 'none declared'}", field="event")
    spec = cfg.raw.events[names.index(event)]
    y = run.scalars[spec.output][:, component_index(spec, tuple(
        result.output(spec.output).components))]
    hit = np.flatnonzero(ok & spec.indicator(np.where(ok, y, np.nan)))
    if hit.size == 0:
        raise UqguideError(f"--event {event}: no sample of '{run.label}' is in the event "
                           f"({spec.describe()}; 0 of {ok.sum()} good samples)")
    return int(hit[0]), f"first of the {hit.size} samples in event {event} ({spec.describe()})"


def _component(output: str, component: str | int | None, comps: tuple[str, ...]) -> int:
    if component is None:
        return 0
    if isinstance(component, str) and component.isdigit():
        component = int(component)
    if isinstance(component, int) and 0 <= component < len(comps):
        return component
    if component in comps:
        return comps.index(component)
    raise ConfigError(f"--component: {component!r} is not a component of {output}; allowed: "
                      f"{', '.join(comps)}", field="component")


def replay(result: Result, label: str, *, run_code: bool = False,
           **choice: Any) -> tuple[Replay, RunConfig]:
    """Rerun one sample of method ``label`` with every output of the model; returns the replayed
    sample beside its stored values, and the result's config. Without ``run_code`` a model that
    is code is refused (:func:`allowed_code`); ``choice``: as :func:`choose_sample`.
    """
    if not run_code:
        allowed_code(result)
    cfg = validate_config(result.config, f"{result.name} (stored config)")
    run = result.run(label)
    i, why = choose_sample(result, cfg, run, **choice)
    model = cfg.model
    every = [o.name for o in model.outputs()]
    try:
        out = model.evaluate(run.x[i:i + 1], list(cfg.space.names), every)
    except UqguideError:
        raise
    except Exception as exc:  # noqa: BLE001 - the model's own failure: one line, no traceback
        before = f"; in the run it failed too: {run.reasons[i]}" if run.failed[i] else ""
        raise UqguideError(f"sample {i} of '{label}' could not be run again: "
                           f"{type(exc).__name__}: {exc}{before}") from None
    return Replay(label, i, why, model.full_values(run.x[i], cfg.space.names),
                  {k: v[i] for k, v in run.scalars.items()}, out,
                  bool(run.failed[i])), cfg


def write_histories(rep: Replay, path: Path) -> Path:
    """Each series of the replayed sample as a CSV column (time first), whole or not at all."""
    out = rep.replayed
    cols = {"time": out.time}
    for name, y in out.series.items():
        k = y.shape[2]
        for c in range(k):
            cols[name if k == 1 else f"{name}[{c}]"] = y[0, :, c]

    def write(f: IO[str]) -> None:
        w = csv.writer(f)
        w.writerow(list(cols))
        for j in range(out.time.size):
            w.writerow([repr(float(v[j])) for v in cols.values()])

    return atomic.write_with(path, write)


def history_figure(out: ModelOutput, title: str, path: Path) -> Path:
    """One panel per series output of the one sample ``out`` (every component) against time,
    as a PNG written whole or not at all."""
    from ..report.figures import new_figure, save

    series = out.series
    n = max(len(series), 1)
    cols = 3 if n > 4 else 2 if n > 1 else 1
    rows = -(-n // cols)
    fig = new_figure((4.2 * cols, 2.8 * rows + 0.8), layout="constrained")
    t = out.time
    for k, (name, y) in enumerate(series.items()):
        ax = fig.add_subplot(rows, cols, k + 1)
        for c in range(y.shape[2]):
            ax.plot(t, y[0, :, c], lw=1.2, label=f"[{c}]" if y.shape[2] > 1 else None)
        ax.set_title(name, fontsize=9)
        ax.grid(True, alpha=0.3)
        if y.shape[2] > 1:
            ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return save(fig, path, dpi=100)


def write_replay(rep: Replay, cfg: RunConfig, result_name: str, out_dir: Path) -> list[Path]:
    """Histories (CSV), the generic history figure and the paper scenario's trajectory figures,
    in ``out_dir`` (created when missing); returns the files written."""
    from ..papers import sample_figures

    atomic.make_folder(out_dir)
    stem = f"{result_name}_{rep.label}_{rep.index}"
    paths = [write_histories(rep, out_dir / f"{stem}_history.csv")]
    if rep.replayed.series:
        paths.append(history_figure(
            rep.replayed, f"{result_name}: {rep.label} sample {rep.index} ({rep.why})",
            out_dir / f"{stem}_history.png"))
    paths += sample_figures(cfg.model, rep.replayed, rep.inputs, out_dir, stem)
    return paths


def render(rep: Replay) -> str:
    """The console summary: which sample, its inputs, stored vs replayed scalars."""
    lines = [f"{rep.label} sample {rep.index}: {rep.why}"
             + (" (stored as FAILED)" if rep.stored_failed else "")]
    lines.append("inputs: " + ", ".join(f"{k} = {v:.17g}" for k, v in rep.inputs.items()))
    diff = rep.differences()
    lines.append(f"{'output':<16} {'stored':>26} {'replayed':>26}  bits")
    for name, v in rep.stored.items():
        new = rep.replayed.scalars[name][0]
        verdict = ("equal" if diff[name] == 0 else
                   f"round-off ({diff[name]:.1e})" if diff[name] <= ROUNDOFF else
                   f"DIFFER ({diff[name]:.1e})")
        for c in range(v.shape[0]):
            nm = name if v.shape[0] == 1 else f"{name}[{c}]"
            lines.append(f"{nm:<16} {v[c]:>26.17g} {new[c]:>26.17g}  {verdict}")
    return "\n".join(lines)
