"""Booleans are not numbers: ``n_samples: true`` is a mistake, not one sample.

pydantic (lax mode) reads ``true`` as 1 for an ``int`` or ``float`` field. :class:`StrictModel`
refuses a boolean given to a field that does not accept booleans, with an error located at
that field (as pydantic's own are). :func:`leaves` is the one walker through
``Annotated`` and unions, which the config's error messages also use.
"""

from __future__ import annotations

import types
import typing
from collections.abc import Callable
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator
from pydantic_core import InitErrorDetails, PydanticCustomError


def leaves(annotation: Any) -> list[Any]:
    """The types ``annotation`` allows, through ``Annotated`` and unions (``None`` left out):
    ``Annotated[int | list[float] | None, ...]`` -> ``[int, list[float]]``."""
    origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        return leaves(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return [x for a in typing.get_args(annotation) for x in leaves(a)]
    return [] if annotation is type(None) else [annotation]


def _any_leaf(annotation: Any, leaf: Callable[[Any], bool]) -> bool:
    """Whether ``leaf`` holds for one of the types ``annotation`` allows (:func:`leaves`)."""
    return any(leaf(a) for a in leaves(annotation))


def _is_bool(annotation: Any) -> bool:
    if typing.get_origin(annotation) is typing.Literal:
        return any(isinstance(a, bool) for a in typing.get_args(annotation))
    return annotation is bool or annotation is Any


def _refuses_bool(annotation: Any) -> bool:
    """Whether a field of this type takes numbers but not booleans."""
    return (_any_leaf(annotation, lambda a: a in (int, float))
            and not _any_leaf(annotation, _is_bool))


class StrictModel(BaseModel):
    """A pydantic model of config settings: frozen, unknown keys refused, and plain-number
    fields refuse booleans (YAML's ``yes`` is not 1)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    # A model validator, not one per field: pydantic refuses a "before" validator on a
    # discriminated union's tag field. Raised as a ValidationError, pydantic places its errors at
    # the fields named (inside the enclosing model's location).
    @model_validator(mode="before")
    @classmethod
    def _no_bool_numbers(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        bad = [InitErrorDetails(type=PydanticCustomError("bool_number",
                                                         "must be a number, not a boolean"),
                                loc=(key,), input=data[key])
               for name, f in cls.model_fields.items()
               for key in dict.fromkeys((f.alias or name, name)) if key in data
               if isinstance(data[key], bool) and _refuses_bool(f.annotation)]
        if bad:
            raise ValidationError.from_exception_data(cls.__name__, bad)
        return data
