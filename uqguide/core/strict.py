"""Booleans are not numbers: ``n_samples: true`` is a mistake, not one sample.

pydantic (lax mode) reads ``true`` as 1 for an ``int`` or ``float`` field. :func:`no_bool_numbers`
is a ``mode="before"`` model validator that refuses a boolean given to a field that does not
accept booleans, naming the field.
"""

from __future__ import annotations

import types
import typing
from typing import Any

from pydantic import BaseModel, model_validator


def _accepts_bool(annotation: Any) -> bool:
    if annotation is bool or annotation is Any:
        return True
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _accepts_bool(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return any(_accepts_bool(a) for a in typing.get_args(annotation))
    if origin is typing.Literal:
        return any(isinstance(a, bool) for a in typing.get_args(annotation))
    return False


def _scalar_number(annotation: Any) -> bool:
    """Whether the field takes a plain number (int or float, possibly optional)."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return _scalar_number(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return any(_scalar_number(a) for a in typing.get_args(annotation))
    return annotation in (int, float)


def no_bool_numbers(cls: Any, data: Any) -> Any:
    if not isinstance(data, dict):
        return data
    for name, field in cls.model_fields.items():
        v = data.get(field.alias or name, data.get(name))
        if isinstance(v, bool) and _scalar_number(field.annotation) and \
                not _accepts_bool(field.annotation):
            raise ValueError(f"{name} must be a number, not a boolean (got {v!r})")
    return data


class StrictModel(BaseModel):
    """A pydantic model whose plain-number fields refuse booleans (YAML's ``yes`` is not 1)."""

    @model_validator(mode="before")
    @classmethod
    def _no_bool_numbers(cls, data: Any) -> Any:
        return no_bool_numbers(cls, data)
