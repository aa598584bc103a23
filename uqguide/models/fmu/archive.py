"""An FMU file: FMPy, its model description, its variables and its unzipped files.

FMPy is an optional dependency: :func:`fmpy` imports it or raises one line saying how to
install it. The description is parsed once per file version (path, size, modification time)
and the archive unzipped once per process, into a temporary folder removed when the process
that made it exits: a batch, and a sample, pay for neither.
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
import threading
from pathlib import Path
from types import ModuleType
from typing import Any

INSTALL_HINT = "the fmu model needs FMPy, which is not installed: pip install 'uqguide[fmu]'"

#: FMI types a real-valued uqguide input can set (FMI 1.0/2.0 ``Real``, FMI 3.0 floats).
REAL_TYPES = frozenset({"Real", "Float64", "Float32"})
#: FMI types an output can be read from and converted to a float (strings cannot).
NUMERIC_TYPES = REAL_TYPES | {"Integer", "Boolean", "Enumeration", "Int8", "UInt8", "Int16",
                              "UInt16", "Int32", "UInt32", "Int64", "UInt64"}

_lock = threading.Lock()
_descriptions: dict[tuple[str, int, int], Any] = {}
_unzipped: dict[tuple[str, int, int, int], str] = {}


class FmuUnavailable(ImportError):
    """FMPy is not installed (its message says how to install it)."""


def fmpy() -> ModuleType:
    """The ``fmpy`` module.

    Returns
    -------
    module

    Raises
    ------
    FmuUnavailable
        FMPy is not installed; the message gives the ``pip install`` command.
    """
    try:
        import fmpy as module
    except ImportError:
        raise FmuUnavailable(INSTALL_HINT) from None
    return module


def _key(path: Path) -> tuple[str, int, int]:
    # a rebuilt FMU at the same path is another file: size and mtime tell them apart
    st = path.stat()
    return str(path.resolve()), st.st_size, st.st_mtime_ns


def description(path: Path) -> Any:
    """The parsed ``modelDescription.xml`` of the FMU at ``path``.

    Parameters
    ----------
    path : Path
        An ``.fmu`` file (or a folder holding an unzipped FMU).

    Returns
    -------
    fmpy.model_description.ModelDescription

    Raises
    ------
    FmuUnavailable
        FMPy is not installed.
    OSError
        The file cannot be read.
    ValueError
        The file is not an FMU FMPy can read (the message says why).
    """
    key = _key(path)
    with _lock:
        if key in _descriptions:
            return _descriptions[key]
    module = fmpy()
    try:
        md = module.read_model_description(str(path), validate=False)
    except Exception as exc:  # noqa: BLE001 - a zip, XML or schema error: all the file's fault
        raise ValueError(f"is not an FMU FMPy can read ({type(exc).__name__}: "
                         f"{str(exc).strip() or 'no detail'})") from None
    with _lock:
        _descriptions[key] = md
    return md


def unzipped(path: Path) -> str:
    """The folder holding the FMU's files, unzipped on this process's first call.

    Parameters
    ----------
    path : Path
        The ``.fmu`` file (a folder is used as it is).

    Returns
    -------
    str
        The folder (removed when this process exits).
    """
    if path.is_dir():
        return str(path)
    # keyed by process too: a forked worker inherits the parent's table, and the parent's
    # folder is the parent's to remove
    key = (*_key(path), os.getpid())
    with _lock:
        found = _unzipped.get(key)
        if found is not None:
            return found
        folder = tempfile.mkdtemp(prefix="uqguide-fmu-")
        fmpy().extract(str(path), unzipdir=folder)
        atexit.register(_remove, folder, os.getpid())
        _unzipped[key] = folder
        return folder


def _remove(folder: str, owner: int) -> None:
    if os.getpid() == owner:  # not in a forked child that inherited the exit handler
        shutil.rmtree(folder, ignore_errors=True)


def platform_problem(path: Path) -> str | None:
    """Why this machine cannot run the FMU's binary, or None when it can.

    Parameters
    ----------
    path : Path

    Returns
    -------
    str or None
    """
    module = fmpy()
    found = module.supported_platforms(str(path))
    if module.platform in found or module.platform_tuple in found:
        return None
    return (f"has no binary for this platform ({module.platform}); it has: "
            f"{', '.join(sorted(found)) or 'none'}")


def variables(md: Any) -> dict[str, Any]:
    """The FMU's variables by name.

    Parameters
    ----------
    md : ModelDescription

    Returns
    -------
    dict of str to fmpy ScalarVariable
    """
    return {v.name: v for v in md.modelVariables}


def settable(variable: Any) -> bool:
    """Whether a simulation can start from a value set for ``variable`` (a parameter, an
    input, or a variable with an exact or approximate start value), as FMPy sets them.

    Parameters
    ----------
    variable : fmpy ScalarVariable

    Returns
    -------
    bool
    """
    from fmpy.simulation import settable_in_initialization_mode, settable_in_instantiated

    return bool(settable_in_instantiated(variable) or settable_in_initialization_mode(variable))


def listing(names: list[str], limit: int = 30) -> str:
    """``names`` joined by commas, the first ``limit`` of them and how many more.

    Parameters
    ----------
    names : list of str
    limit : int

    Returns
    -------
    str
    """
    shown = ", ".join(names[:limit]) or "none"
    return shown if len(names) <= limit else f"{shown}, ... ({len(names)} in all)"
