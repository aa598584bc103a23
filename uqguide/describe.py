"""Text descriptions for the CLI: models, method settings, and nominal-run reports."""

from __future__ import annotations

from pydantic import BaseModel

from .models.base import Model, ReportRow


def describe_settings(settings: type[BaseModel], indent: str = "  ") -> str:
    """One line per field: name, type, default, description."""
    lines = []
    for fname, f in settings.model_fields.items():
        default = "required" if f.is_required() else f"default {f.default!r}"
        ann = getattr(f.annotation, "__name__", None) or str(f.annotation).replace("typing.", "")
        desc = f" — {f.description}" if f.description else ""
        lines.append(f"{indent}{fname}: {ann}, {default}{desc}")
    return "\n".join(lines) if lines else f"{indent}(no settings)"


def describe_model(cls: type[Model]) -> str:
    """Name, summary, uncertain inputs, outputs and parameters of a model class."""
    model = cls()
    lines = [f"{cls.name}: {cls.summary}", " inputs (uncertain; nominal value when not listed):"]
    for i in model.inputs():
        lines.append(f"  {i.name} [{i.unit}] nominal {i.nominal:g} — {i.description}")
    lines.append(" outputs (* = reported by default):")
    for o in model.outputs():
        comps = f" ({', '.join(o.components)})" if o.k > 1 else ""
        star = "*" if o.default else " "
        lines.append(f" {star}{o.name} [{o.unit}] {o.kind}{comps} — {o.description}")
    lines.append(" parameters (model: section of a config):")
    lines.append(describe_settings(cls.Params))
    return "\n".join(lines)


def _cell(v: object) -> str:
    if v is None:
        return "—"
    if isinstance(v, float):
        a = abs(v)
        return f"{v:.4g}" if (a == 0 or 1e-3 <= a < 1e5) else f"{v:.3e}"
    return str(v)


def format_report(model_name: str, rows: list[ReportRow]) -> str:
    """The nominal run's figures beside the paper's, as an aligned text table."""
    header = ("quantity", "unit", "model", "paper", "tolerance", "check", "kind")
    body = [(r.quantity, r.unit, _cell(r.value), _cell(r.paper), r.tolerance,
             {True: "ok", False: "MISS", None: "—"}[r.ok], r.kind) for r in rows]
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h)
              for i, h in enumerate(header)]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    lines = [f"Nominal run of model '{model_name}' beside the paper", fmt.format(*header),
             fmt.format(*("-" * w for w in widths))]
    lines += [fmt.format(*b) for b in body]
    chaotic = [(r.quantity, r.statistic) for r in rows if r.statistic]
    if chaotic:
        lines.append("")
        lines.append("chaotic rows (they move by more than their tolerance when the inputs move "
                     "by round-off) show a robust statistic:")
        lines += [f"robust — {q}: {s}" for q, s in chaotic]
    notes = [(r.quantity, r.note) for r in rows if r.note]
    if notes:
        lines.append("")
        lines += [f"note — {q}: {n}" for q, n in notes]
    return "\n".join(lines)
