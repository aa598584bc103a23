"""Booleans are not numbers: ``n_samples: true`` is a mistake, not one sample.

pydantic (lax mode) reads ``true`` as 1 for an ``int`` or ``float`` field. :func:`no_bool_numbers`
is a ``mode="before"`` model validator that refuses a boolean given to a field that does not
accept booleans, naming the field.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Callable
from typing import Any

from pydantic import BaseModel, ConfigDict, model_validator


def _any_leaf(annotation: Any, leaf: Callable[[Any], bool]) -> bool:
    """Whether ``leaf`` holds for ``annotation`` or, through ``Annotated`` and unions, for one of
    the types inside it."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _any_leaf(typing.get_args(annotation)[0], leaf)
    if origin in (typing.Union, types.UnionType):
        return any(_any_leaf(a, leaf) for a in typing.get_args(annotation))
    return leaf(annotation)


def _is_bool(annotation: Any) -> bool:
    if typing.get_origin(annotation) is typing.Literal:
        return any(isinstance(a, bool) for a in typing.get_args(annotation))
    return annotation is bool or annotation is Any


def no_bool_numbers(cls: Any, data: Any) -> Any:
    if not isinstance(data, dict):
        return data
    for name, field in cls.model_fields.items():
        v = data.get(field.alias or name, data.get(name))
        if isinstance(v, bool) and _any_leaf(field.annotation, lambda a: a in (int, float)) \
                and not _any_leaf(field.annotation, _is_bool):
            raise ValueError(f"{name} must be a number, not a boolean (got {v!r})")
    return data


class StrictModel(BaseModel):
    """A pydantic model of config settings: frozen, unknown keys refused, and plain-number
    fields refuse booleans (YAML's ``yes`` is not 1)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    @model_validator(mode="before")
    @classmethod
    def _no_bool_numbers(cls, data: Any) -> Any:
        return no_bool_numbers(cls, data)
