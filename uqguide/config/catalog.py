"""The shipped studies: the paper configs that come inside the package.

The configs of ``configs/`` in the repository are package data (``uqguide/config/studies/``, a link
to that folder in a checkout, a copy in a wheel), so an installed uqguide can run its own studies
from any folder: ``uqguide run ftcapn_table3``. A config argument is a path when such a file
exists, and otherwise the name of a shipped study; a file always wins, so a user's edited copy
of a study (``uqguide configs --copy NAME DIR``) is never shadowed.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import yaml

from ..errors import ConfigError
from .registry import did_you_mean

_FOLDER = "studies"


@dataclass(frozen=True)
class Study:
    """A shipped config: its name (the file's stem), path and what it reproduces."""

    name: str
    path: Path
    description: str


def _folder() -> Path:
    return Path(str(resources.files("uqguide.config").joinpath(_FOLDER)))


def studies() -> list[Study]:
    """Every shipped study (name, path, description), sorted by name."""
    out = []
    for path in sorted(_folder().glob("*.yaml")):
        with path.open(encoding="utf-8") as f:
            data = yaml.safe_load(f) or {}
        out.append(Study(path.stem, path, str(data.get("description") or "")))
    return out


def study_path(name: str, field: str = "CONFIG") -> Path:
    """The shipped config called ``name`` (with or without ``.yaml``); ConfigError listing the
    near names when there is none (``field`` names the argument)."""
    stem = name[:-5] if name.endswith(".yaml") else name
    names = [s.name for s in studies()]
    if stem not in names:
        raise ConfigError(
            f"{field}: {name!r} is neither a config file nor a shipped study"
            f"{did_you_mean(stem, names)}; `uqguide configs` lists the shipped studies",
            field=field)
    return _folder() / f"{stem}.yaml"


def resolve(config: str | Path, field: str = "CONFIG") -> Path:
    """A config argument as an existing path: the file if it exists, else the shipped study so
    named; ConfigError otherwise.

    Only a bare name (no folder, no ``.yaml``) is looked up among the studies; a missing path
    is an error that names the study to run instead when its stem is one.
    """
    path = Path(config)
    if path.is_file():
        return path
    if path.exists():
        raise ConfigError(f"{field}: {str(config)!r} is not a file", field=field)
    if path.parent == Path(".") and path.suffix not in (".yaml", ".yml"):
        return study_path(str(config), field)
    hint = ""
    if path.stem in {s.name for s in studies()}:
        hint = f" (a shipped study has that name: `uqguide run {path.stem}`)"
    raise ConfigError(f"{config}: config file not found{hint}", field=field)


def copy_study(name: str, folder: Path) -> Path:
    """Copy the shipped study ``name`` into ``folder`` (created) and return the copy; refuses to
    overwrite."""
    src = study_path(name, "NAME")
    folder.mkdir(parents=True, exist_ok=True)
    dst = folder / src.name
    if dst.exists():
        raise ConfigError(f"DIR: {dst} exists already; remove it or copy elsewhere", field="DIR")
    shutil.copyfile(src, dst)
    return dst
