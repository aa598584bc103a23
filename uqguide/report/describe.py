"""Text descriptions for the CLI: models, method settings, and nominal-run reports."""

from __future__ import annotations

import inspect
import re
from types import UnionType
from typing import Annotated, Any, Literal, Union, get_args, get_origin

from pydantic import BaseModel, ValidationError

from ..models.base import Model


_SPEC_REF = re.compile(
    r"\s*\((?:\[W\][^)]*|\[W \d+\]|spec [^)]*|App\. [^)]*|A\d+[^)]*)\)"  # ([W] 3, A2) ...
    r"|\s*\[W\s*\d*\]"                                                     # [W 23]
    r"|;?\s*spec choice")
_UNIT = re.compile(r"\[([^\]]*[A-Za-z][^\]]*)\]")
_ROLE = re.compile(r"\s*\(:\w+:`[^`]*`\)|:\w+:`~?([^`]*)`")


def _docstring_attributes(cls: type) -> dict[str, str]:
    """The first sentence of each entry of the numpydoc ``Attributes`` / ``Parameters``
    sections of ``cls`` and its bases (the settings' meanings where a field has none)."""
    found: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        lines = (inspect.getdoc(klass) or "").splitlines()
        section = ""
        # (names, text lines) per entry; a section opens with a nameless one, so text before
        # its first entry belongs to none
        entries: list[tuple[list[str], list[str]]] = []
        for line, after in zip(lines, lines[1:] + [""]):
            if set(after.strip()) == {"-"}:  # a section's title, underlined
                section = line.strip()
                entries.append(([], []))
            elif section not in ("Attributes", "Parameters") or set(line.strip()) == {"-"}:
                continue
            elif line and not line.startswith(" "):
                names = [n.strip() for n in line.split(" : ")[0].split(",")]
                entries.append(([n for n in names if n.isidentifier()], []))
            elif line.strip():
                entries[-1][1].append(line.strip())
        for names, text in entries:
            if text:
                sentence = re.split(r"(?<=\.)\s", " ".join(text), maxsplit=1)[0]
                found.update((n, sentence.replace("``", "")) for n in names)
    return found


def _num(v: float) -> str:
    if float(v).is_integer() and abs(v) >= 1e5:
        return f"{v:.0e}".replace("e+0", "e").replace("e+", "e")
    return f"{v:g}"


def _allowed(annotation: Any, metadata: list[Any]) -> str:
    """The values a field accepts, in the config's words."""
    args = [a for a in get_args(annotation) if a is not type(None)]
    optional = type(None) in get_args(annotation)
    if get_origin(annotation) is Annotated:  # (a tagged union's branch, or the union)
        return _allowed(get_args(annotation)[0], metadata)
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return "{" + ", ".join(annotation.model_fields) + "}"
    if get_origin(annotation) is Literal:
        return "one of " + " | ".join(str(a) for a in get_args(annotation))
    if args and get_origin(annotation) in (Union, UnionType) and len(args) == 1:
        inner = _allowed(args[0], metadata)
        return f"{inner}, or null" if optional else inner
    if args and get_origin(annotation) in (Union, UnionType) and any(
            get_origin(a) is Annotated for a in args):  # a tagged union: each branch's values
        inner = " | ".join(_allowed(a, metadata) for a in args)
        return f"{inner}, or null" if optional else inner
    if annotation is bool:
        return "true | false"
    if annotation in (int, float):
        kind = "integer" if annotation is int else "number"
        bounds = [f"{op} {_num(v)}" for m in metadata
                  for attr, op in (("ge", ">="), ("gt", ">"), ("le", "<="), ("lt", "<"))
                  if (v := getattr(m, attr, None)) is not None]
        return f"{kind} {', '.join(bounds)}" if bounds else kind
    if annotation is str:
        return "text"
    origin = get_origin(annotation)
    if origin in (list, tuple):
        members = [a for a in get_args(annotation) if a is not Ellipsis]
        if origin is tuple and members and len(members) > 1 and len(set(members)) == 1:
            return f"list of {len(members)} {_allowed(members[0], []).split()[0]}s"
        return "list"
    return getattr(annotation, "__name__", None) or str(annotation).replace("typing.", "")


def describe_settings(settings: type[BaseModel], indent: str = "  ") -> str:
    """One line per field of a model's ``Params`` or a method's settings class: name, allowed
    values, default, unit, one-line meaning."""
    from_doc = _docstring_attributes(settings)
    lines = []
    for fname, f in settings.model_fields.items():
        default = "required" if f.is_required() else \
            f"default {_value(f.get_default(call_default_factory=True))}"
        meaning = _clean(f.description or from_doc.get(fname, ""))
        unit = _UNIT.search(meaning)
        unit_text = f", unit {unit.group(1)}" if unit else ""
        lines.append(f"{indent}{fname}: {_allowed(f.annotation, f.metadata)}; {default}"
                     f"{unit_text}" + (f" — {meaning}" if meaning else ""))
    return "\n".join(lines) if lines else f"{indent}(no settings)"


#: Input counts of the table of default run counts (``uqguide methods NAME``).
DEFAULT_DIMS = (1, 2, 3, 5, 10, 20, 50)


def describe_defaults(cls: Any) -> str:
    """The defaults of a method class that are rules, each with its reason, and the run counts
    they give for a few input counts (computed by the method itself); empty without such."""
    if not cls.default_rules:
        return ""
    lines = [" defaults that are rules (d inputs):"]
    lines += [f"  {name}: {rule}" for name, rule in cls.default_rules]
    sizes = {d: cls.default_sizes(d) for d in DEFAULT_DIMS}
    keys = list(next(iter(sizes.values())))
    if keys:
        lines.append(" the defaults' run counts:")
        lines.append("  " + f"{'d':>4}" + "".join(f"{k:>12}" for k in keys))
        for d, row in sizes.items():
            lines.append("  " + f"{d:>4}" + "".join(f"{row[k]:>12}" for k in keys))
    return "\n".join(lines)


def _clean(text: str) -> str:
    """A description for users: without internal spec references and Sphinx roles."""
    return _ROLE.sub(lambda m: m.group(1) or "", _SPEC_REF.sub("", text)).strip()


def _value(v: Any) -> str:
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.10g}"
    if isinstance(v, tuple):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return str(v)


def describe_model(cls: type[Model]) -> str:
    """Name, summary, uncertain inputs, outputs and parameters of a model class, for
    ``uqguide models NAME``."""
    model: Model | None
    try:
        model = cls()
    except ValidationError:
        # a model with required parameters (the command model's program) shows its example;
        # one whose example needs a file (an FMU) its parameters only
        try:
            model = cls(cls.example_params) if cls.example_params else None
        except ValidationError:
            model = None
    lines = [f"{cls.name}: {cls.summary}"]
    if model is None:
        lines.append(" inputs and outputs: those the config's model section declares")
    else:
        lines.append(" inputs (uncertain; nominal value when not listed):")
        for i in model.inputs():
            lines.append(f"  {i.name} [{i.unit}] nominal {i.nominal:g} — "
                         f"{_clean(i.description)}")
        lines.append(" outputs (* = reported by default):")
        for o in model.outputs():
            comps = f" ({', '.join(o.components)})" if o.k > 1 else ""
            star = "*" if o.default else " "
            lines.append(f" {star}{o.name} [{o.unit}] {o.kind}{comps} — "
                         f"{_clean(o.description)}")
    lines.append(" parameters (model: section of a config):")
    lines.append(describe_settings(cls.Params))
    return "\n".join(lines)
