"""An FMU file: FMPy, its model description, its variables and its unzipped files.

FMPy is an optional dependency: :func:`fmpy` imports it or raises one line saying how to
install it. The description is parsed once per file version (path, size, modification time).

The archive is checked member by member before anything is unzipped (:func:`check_archive`:
no absolute or climbing path, no link or special file, the declared sizes and compression
ratios within bounds) and unzipped once, by the process that validates the config, into a
temporary folder marked as uqguide's; the processes that evaluate it (guards, pool workers)
find it through the environment and unzip nothing. The folder is removed when its process
exits, whether the run finished, failed or was interrupted; a folder whose process was
killed is removed by the next one that unzips or exits. The limits and the ratios they come
from: docs/your-simulator.md#the-archive.
"""

from __future__ import annotations

import json
import os
import shutil
import stat
import tempfile
import threading
import zipfile
from multiprocessing import util as mp_util
from pathlib import Path
from types import ModuleType
from typing import Any

from ...core import temp_folders

INSTALL_HINT = "the fmu model needs FMPy, which is not installed: pip install 'uqguide[fmu]'"

#: FMI types a real-valued uqguide input can set (FMI 1.0/2.0 ``Real``, FMI 3.0 floats).
REAL_TYPES = frozenset({"Real", "Float64", "Float32"})
#: FMI types an output can be read from and converted to a float (strings cannot).
NUMERIC_TYPES = REAL_TYPES | {"Integer", "Boolean", "Enumeration", "Int8", "UInt8", "Int16",
                              "UInt16", "Int32", "UInt32", "Int64", "UInt64"}

#: Largest total of an FMU's unzipped files [bytes] (an FMU's binaries and resources are
#: megabytes; a larger one can be unzipped by hand and its folder given as the path).
MAX_UNZIPPED_BYTES = 2 * 2**30
#: Largest compression ratio of a member over :data:`RATIO_FLOOR` bytes: deflate's limit is
#: 1029 to 1 (zeros, the stuff of zip bombs); binaries and text measured 5 to 21 to 1.
MAX_RATIO = 100
RATIO_FLOOR = 2**20
#: Most members an FMU may have.
MAX_MEMBERS = 10_000

#: The unzipped folders' name prefix and the mark file in each (:mod:`uqguide.core.temp_folders`)
#: and the environment variable that tells child processes where they are.
PREFIX, MARK, ENV = temp_folders.FMU.prefix, temp_folders.FMU.mark, "UQGUIDE_FMU_UNZIPPED"
_COPY_CHUNK = 2**20
_READABLE = {zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED, zipfile.ZIP_BZIP2, zipfile.ZIP_LZMA}

_lock = threading.Lock()
_descriptions: dict[tuple[str, int, int], Any] = {}
_unzipped: dict[tuple[str, int, int], str] = {}
_exit_sweep: list[int] = []  # the processes whose exit sweeps the temporary folder


class FmuUnavailable(ImportError):
    """FMPy is not installed (its message says how to install it)."""


def fmpy() -> ModuleType:
    """The ``fmpy`` module; FmuUnavailable (with the ``pip install`` command) without it."""
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
    """The parsed ``modelDescription.xml`` (an FMPy ModelDescription) of the ``.fmu`` file or
    unzipped folder at ``path``. Raises FmuUnavailable without FMPy, OSError when the file
    cannot be read, ValueError (saying why) when it is not an FMU FMPy can read."""
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


def _member_problem(info: zipfile.ZipInfo) -> str | None:
    """Why a member is not unzipped, or None."""
    name = info.filename
    parts = name.split("/")
    mode = info.external_attr >> 16 if info.create_system == 3 else 0  # Unix's mode bits
    if not name or "\0" in name:
        return "an empty name"
    if "\\" in name or ":" in name:
        return "a path with a backslash or a drive letter (FMI paths use '/')"
    if name.startswith("/"):
        return "an absolute path"
    if ".." in parts:
        return "a path out of the FMU's folder ('..')"
    kind = stat.S_IFMT(mode)  # 0: no type recorded (zipfile's writestr), a plain file
    if kind == stat.S_IFLNK:
        return "a symbolic link"
    if kind not in (0, stat.S_IFREG, stat.S_IFDIR):
        return "a special file (a device, FIFO or socket)"
    if info.flag_bits & 0x1:
        return "encrypted"
    if info.compress_type not in _READABLE:
        return f"compressed by method {info.compress_type}, which zipfile cannot read"
    ratio = info.file_size / max(info.compress_size, 1)
    if info.file_size > RATIO_FLOOR and ratio > MAX_RATIO:
        return (f"{info.file_size:,} bytes compressed {ratio:.0f} to 1 (a zip bomb's ratio); "
                f"allowed at most {MAX_RATIO} to 1 for a member over "
                f"{RATIO_FLOOR // 2**20} MiB")
    return None


def check_archive(path: Path) -> list[zipfile.ZipInfo]:
    """The members of the ``.fmu`` file ``path``, each checked before anything is unzipped
    (module docstring); ValueError naming a refused member and why, or a total over its limit."""
    try:
        with zipfile.ZipFile(path) as z:
            infos = z.infolist()
    except (zipfile.BadZipFile, zipfile.LargeZipFile, ValueError) as exc:
        raise ValueError(f"is not an FMU FMPy can read ({type(exc).__name__}: {exc})") from None
    if len(infos) > MAX_MEMBERS:
        raise ValueError(f"has {len(infos):,} members; an FMU may have at most "
                         f"{MAX_MEMBERS:,}")
    seen: set[str] = set()
    for info in infos:
        problem = _member_problem(info)
        if problem is None and info.filename.rstrip("/") in seen:
            problem = "a second member of that name"
        if problem is not None:
            raise ValueError(f"holds a member uqguide does not unzip: {info.filename!r} is "
                             f"{problem}")
        seen.add(info.filename.rstrip("/"))
    total = sum(i.file_size for i in infos)
    if total > MAX_UNZIPPED_BYTES:
        raise ValueError(f"unzips to {total:,} bytes, more than the {MAX_UNZIPPED_BYTES:,} "
                         f"uqguide unzips; unzip it yourself and give its folder as the path")
    free = shutil.disk_usage(tempfile.gettempdir()).free
    if total > free:
        raise ValueError(f"unzips to {total:,} bytes; the temporary folder "
                         f"{tempfile.gettempdir()} has {free:,} free (set TMPDIR to a "
                         f"folder with room)")
    return infos


def _copy_members(path: Path, folder: Path, infos: list[zipfile.ZipInfo]) -> None:
    """Unzip the checked members into ``folder``, counting the bytes written: a member that
    inflates past its declared size (the sizes can lie) is refused at that byte."""
    with zipfile.ZipFile(path) as z:
        for info in infos:
            target = folder.joinpath(*[p for p in info.filename.split("/") if p])
            if info.is_dir():
                target.mkdir(parents=True, exist_ok=True)
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            written = 0
            fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
            with os.fdopen(fd, "wb") as out, z.open(info) as src:
                while chunk := src.read(_COPY_CHUNK):
                    written += len(chunk)
                    if written > info.file_size:
                        raise ValueError(f"member {info.filename!r} unzips to more than the "
                                         f"{info.file_size:,} bytes it declares")
                    out.write(chunk)


def _exported() -> dict[str, str]:
    """The folders this process and its parents unzipped, by FMU version (:data:`ENV`)."""
    try:
        known = json.loads(os.environ.get(ENV, "{}"))
    except ValueError:
        return {}
    return known if isinstance(known, dict) else {}


def _inherited(key: tuple[str, int, int]) -> str | None:
    """The folder a parent process unzipped this FMU version into (module docstring)."""
    folder = _exported().get(json.dumps(key))
    if not isinstance(folder, str):
        return None
    mark = temp_folders.mark_of(Path(folder), temp_folders.FMU)
    return folder if mark is not None and mark.get("key") == list(key) else None


def _sweep_at_exit() -> None:
    # after multiprocessing has ended this process's daemonic children (their own folders'
    # processes are then gone): a negative priority runs after that
    if os.getpid() not in _exit_sweep:
        _exit_sweep.append(os.getpid())
        mp_util.Finalize(None, temp_folders.sweep, args=((temp_folders.FMU,),),
                         exitpriority=-10)


def unzipped(path: Path) -> str:
    """The folder holding the files of the ``.fmu`` at ``path`` (a folder is used as it is):
    this process's, a parent's, or unzipped now (removed when the process that unzipped it
    exits). ValueError when the archive is refused (:func:`check_archive`) or cannot be
    unzipped."""
    if path.is_dir():
        return str(path)
    key = _key(path)
    with _lock:
        found = _unzipped.get(key) or _inherited(key)
        if found is not None and temp_folders.mark_of(Path(found), temp_folders.FMU) is not None:
            _unzipped[key] = found
            return found
        infos = check_archive(path)
        _sweep_at_exit()
        temp_folders.sweep((temp_folders.FMU,))
        try:
            folder = temp_folders.make(temp_folders.FMU, key=list(key))
        except OSError as exc:
            raise ValueError(f"cannot be unzipped ({type(exc).__name__}: {exc})") from None
        # removed at exit, after this process's children (Finalize runs in multiprocessing's
        # children too, where atexit does not)
        mp_util.Finalize(None, temp_folders.remove, args=(str(folder), os.getpid()),
                         exitpriority=-5)
        try:
            _copy_members(path, folder, infos)
        except (OSError, EOFError, RuntimeError, NotImplementedError, zipfile.BadZipFile,
                ValueError) as exc:
            shutil.rmtree(folder, ignore_errors=True)
            text = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
            raise ValueError(f"cannot be unzipped ({text})") from None
        _unzipped[key] = str(folder)
        known = _exported()
        known[json.dumps(key)] = str(folder)
        os.environ[ENV] = json.dumps(known)
        return str(folder)


def platform_problem(path: Path) -> str | None:
    """Why this machine cannot run the FMU's binary, or None when it can."""
    module = fmpy()
    found = module.supported_platforms(str(path))
    if module.platform in found or module.platform_tuple in found:
        return None
    return (f"has no binary for this platform ({module.platform}); it has: "
            f"{', '.join(sorted(found)) or 'none'}")


def variables(md: Any) -> dict[str, Any]:
    """The FMU's variables (FMPy ScalarVariable) of the ModelDescription ``md``, by name."""
    return {v.name: v for v in md.modelVariables}


def settable(variable: Any) -> bool:
    """Whether a simulation can start from a value set for ``variable`` (a parameter, an
    input, or a variable with an exact or approximate start value), as FMPy sets them."""
    from fmpy.simulation import settable_in_initialization_mode, settable_in_instantiated

    return bool(settable_in_instantiated(variable) or settable_in_initialization_mode(variable))


def listing(names: list[str], limit: int = 30) -> str:
    """``names`` joined by commas, the first ``limit`` of them and how many more."""
    shown = ", ".join(names[:limit]) or "none"
    return shown if len(names) <= limit else f"{shown}, ... ({len(names)} in all)"
