"""Parameters of a model that names files relative to its config's folder (``command``,
``fmu``): ``config_dir`` is filled in at validation, so that the config runs the same from
any working folder."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, NoReturn

from pydantic import ValidationError, ValidationInfo, model_validator
from pydantic_core import InitErrorDetails, PydanticCustomError

from .base import ModelParams


class ConfigDirParams(ModelParams):
    """A model's parameters with a ``config_dir`` field (each subclass declares it, with its own
    description): unless the config sets it, the folder of the config file (the validation
    context's ``config_dir``), else the current folder, as an absolute path."""

    @model_validator(mode="before")
    @classmethod
    def _locate(cls, data: Any, info: ValidationInfo) -> Any:
        if isinstance(data, Mapping) and data.get("config_dir") is None:
            where = (info.context or {}).get("config_dir") or os.getcwd()
            data = {**data, "config_dir": str(Path(where).resolve())}
        return data

    def _refuse(self, field: str, message: str, given: Any = None) -> NoReturn:
        # A check across fields, reported at the field it is about (a plain ValueError here
        # would be reported at "model", naming no field). A mapping as the input makes the
        # message stand alone (no "(got ...)" after it): those messages name the value.
        raise ValidationError.from_exception_data(type(self).__name__, [InitErrorDetails(
            type=PydanticCustomError("value_error", "{message}", {"message": message}),
            loc=(field,), input=getattr(self, field, None) if given is None else given)])
