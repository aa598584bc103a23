"""Nominal runs shared by a scenario's report and its figures, cached per model instance.

``uqguide simulate --figures`` asks for the report and then the figures of the same runs; the
cache keeps them for as long as the model object lives (weak keys: nothing outlives the model,
and the model itself carries no presentation state).
"""

from __future__ import annotations

import functools
import weakref
from collections.abc import Callable
from typing import Any, TypeVar

from ..models.base import Model

R = TypeVar("R")


def per_model(fn: Callable[[Any], R]) -> Callable[[Any], R]:
    """Decorate ``fn(model)`` so that it runs once per model instance."""
    memo: weakref.WeakKeyDictionary[Model, R] = weakref.WeakKeyDictionary()

    @functools.wraps(fn)
    def cached(model: Any) -> R:
        if model not in memo:
            memo[model] = fn(model)
        return memo[model]

    return cached
