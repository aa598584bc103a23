"""Name -> class for the models and methods uqguide can run, from the package entry points.

Entry-point groups ``uqguide.models`` and ``uqguide.methods`` (``name = "module:Class"``):
uqguide's own in its ``pyproject.toml``, a third party's in its own package
(docs/architecture.md#a-plugin-package). Entries are imported on first use; a third-party
name that shadows a built-in one is ignored with a warning.
"""

from __future__ import annotations

import difflib
import importlib
import logging
from collections.abc import Iterator, Mapping
from importlib.metadata import entry_points
from typing import TYPE_CHECKING

from ..errors import ConfigError

if TYPE_CHECKING:
    from ..methods.base import Method
    from ..models.base import Model

log = logging.getLogger(__name__)


class Registry(Mapping[str, str]):
    """Name -> ``"module:Class"`` of one entry-point group (``uqguide.models`` or
    ``uqguide.methods``), read on first use."""

    def __init__(self, group: str) -> None:
        self.group = group
        self._table: dict[str, str] | None = None

    def _entries(self) -> dict[str, str]:
        if self._table is None:
            eps = list(entry_points(group=self.group))
            own = {ep.name: ep.value for ep in eps if _is_builtin(ep.value)}
            if not own:
                raise ConfigError(
                    f"uqguide's own entry points ({self.group}) are not installed: install the "
                    f"package (pip install -e . in a checkout) rather than putting it on "
                    f"PYTHONPATH alone", field=self.group)
            table = dict(own)
            for ep in eps:
                if ep.name in own and ep.value != own[ep.name]:
                    log.warning("%s: '%s' of %s is ignored: the name is uqguide's own",
                                self.group, ep.name, ep.value)
                elif ep.name not in table:
                    table[ep.name] = ep.value
            self._table = table
        return self._table

    def reload(self) -> None:
        """Read the entry points again (after a package was installed in this process)."""
        self._table = None

    def __getitem__(self, name: str) -> str:
        return self._entries()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries())

    def __len__(self) -> int:
        return len(self._entries())


def _is_builtin(target: str) -> bool:
    return target.split(":", 1)[0].split(".", 1)[0] == "uqguide"


MODELS = Registry("uqguide.models")
METHODS = Registry("uqguide.methods")


def _load(target: str) -> type:
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)


def did_you_mean(name: str, choices: list[str]) -> str:
    """A hint naming the closest of ``choices`` to a misspelt ``name``:
    ``" (did you mean 'x'?)"``, or ``""`` when nothing is close."""
    close = difflib.get_close_matches(name, choices, n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def _lookup(kind: str, table: Mapping[str, str], name: object, field: str) -> type:
    if not isinstance(name, str) or name not in table:
        hint = did_you_mean(name, list(table)) if isinstance(name, str) else ""
        raise ConfigError(
            f"{field}: unknown {kind} {name!r}{hint}; allowed: {', '.join(sorted(table))}",
            field=field,
        )
    try:
        return _load(table[name])
    except (ImportError, AttributeError) as exc:
        raise ConfigError(
            f"{field}: the {kind} {name!r} is registered as {table[name]!r} but cannot be "
            f"loaded ({type(exc).__name__}: {exc}); reinstall the package that provides it",
            field=field) from None


def model_class(name: object, field: str = "model.name") -> type[Model]:
    """The model class registered as ``name``; ConfigError naming ``field`` otherwise."""
    return _lookup("model", MODELS, name, field)


def method_class(name: object, field: str = "methods.name") -> type[Method]:
    """The method class registered as ``name``; ConfigError naming ``field`` otherwise."""
    return _lookup("method", METHODS, name, field)
