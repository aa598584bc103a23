"""Hostile data files and FMUs for the containment fuzz (``benchmarks/fuzz_containment.py``):
each case builds its input in the sandbox, runs one uqguide command on it and is judged there
(nothing of the user's touched, nothing written outside ``--out``: an unzipped FMU folder left
in ``$TMPDIR`` is such a write, no traceback, nothing past 60 s, peak RSS under
``max_memory``); :func:`main` prints this module's table besides (exit, traceback, peak RSS
against uqguide's own read estimate and ``max_memory``, folders left).

The cases (:func:`cases`, in fuzz_containment's :class:`Case` form):

- data files: a CSV with a byte-order mark (read), one in the middle of a name, a repeated,
  unprintable or too long column name, a name no output can have, a series step index of
  10^11, a cell over its limit, a line of 64 MiB, a 2 GB sparse CSV, HDF5 datasets claiming
  156 TB, an ``.npz`` header claiming 8 TB, a pickled ``.npz`` member, an ``.npz`` zip bomb, a
  dense CSV that is read (its peak against the estimate), a one-row file (its std "needs 2
  runs");
- FMUs: members with an absolute, a climbing or a backslash path, a symbolic link, a FIFO, a
  device, a repeated name, a 1 GiB zip bomb, a member whose declared size lies, 10,001
  members; a run, a run of an FMU that crashes on 1 sample in 6 (a fresh guard per crash), a
  run stopped by Ctrl-C, and a killed run followed by a ``validate`` that sweeps its folder.

A case runs in this process (click's CliRunner) where only the exit and the message matter,
and as a child where its peak RSS is measured (``wait4``) or an FMU is unzipped (a folder
lives as long as its process). The FMU cases need FMPy and a C compiler (the test FMU of
``tests/fmu_decay.py``); without them they are not yielded.

Usage::

    python benchmarks/containment_data.py            # every case (2 GB CSV, 1 GiB bombs)
    python benchmarks/containment_data.py --quick    # 200 MB and 64 MiB stand-ins
    python benchmarks/containment_data.py --only fmu_member,csv_bom
"""

from __future__ import annotations

import argparse
import atexit
import io
import os
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT, ROOT / "benchmarks"):  # the test FMU's builder lives in tests/
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

INPUTS = [{"name": "a", "dist": "uniform", "low": 0.0, "high": 1.0},
          {"name": "b", "dist": "uniform", "low": 0.0, "high": 1.0}]
MC = [{"name": "monte_carlo", "label": "mc"}]
FMU_PREFIX = "uqguide-fmu-"
#: The configs' max_memory (fuzz_containment's), unless a case sets its own.
MAX_MEMORY = "2 GB"


@dataclass(frozen=True)
class Hostile:
    """One hostile input and what uqguide must do with it.

    Attributes
    ----------
    name : str
    build : callable
        Folder -> the config to give uqguide (its input written beside it).
    args : tuple of str
        The command before the config's path; ``--out`` is followed by the sandbox's.
    expect : int
        The exit code uqguide must end with.
    text : str
        What its output must hold (empty: anything).
    child : bool
        Run as a child process (peak RSS measured; an unzipped FMU lives as long as it).
    signal : int
        Sent to a run of the config once it has written a chunk (0: none), before the
        command: SIGINT must leave nothing; after SIGKILL, the command (``validate``) must
        sweep the killed run's folder.
    """

    name: str
    build: Callable[[Path], Path]
    args: tuple[str, ...] = ("validate",)
    expect: int = 2
    text: str = ""
    child: bool = False
    signal: int = 0


# ---------------------------------------------------------------------------- builders
def _config(folder: Path, data: str, **more: object) -> Path:
    cfg = {"data": data, "inputs": INPUTS, "methods": MC, "max_memory": MAX_MEMORY, **more}
    path = folder / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def _rows(n: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 1.0, (n, 2))
    return np.column_stack([x, np.sin(3 * x[:, 0]) + x[:, 1] ** 2])


def _csv(folder: Path, header: str, n: int = 40, edit: Callable[[list[str]], None] | None = None,
         prefix: bytes = b"") -> Path:
    lines = [",".join(repr(v) for v in r) for r in _rows(n).tolist()]
    if edit is not None:
        edit(lines)
    (folder / "runs.csv").write_bytes(prefix + (header + "\n" + "\n".join(lines) + "\n")
                                      .encode())
    return _config(folder, "runs.csv")


#: Where inputs of more than :data:`BIG_BYTES` are written: outside the case's box, whose
#: snapshots read each file whole (a 2 GB input would be 2 GB of the fuzz's own memory).
BIG_BYTES = 10**8
_big: list[Path] = []


def _big_folder() -> Path:
    if not _big:
        _big.append(Path(tempfile.mkdtemp(prefix="containment-data-big-")))
        atexit.register(shutil.rmtree, _big[0], True)
    return _big[0]


def _stream_csv(folder: Path, header: str, line: bytes, total: int, dense: bool = False,
                **more: object) -> Path:
    """A CSV of ``total`` bytes of ``line`` after its header (written a chunk at a time)."""
    where = _big_folder() if total > BIG_BYTES else folder
    path = where / f"runs-{total}-{dense}.csv"
    if not path.exists():  # a big one is written once per process
        with path.open("wb") as f:
            f.write(header.encode() + b"\n")
            if dense:
                rows = max(1, total // 60)
                for start in range(0, rows, 100_000):
                    block = _rows(min(100_000, rows - start), seed=start)
                    f.write(("\n".join(",".join(repr(v) for v in r) for r in block.tolist())
                             + "\n").encode())
            else:
                chunk = line * (2**22 // len(line))
                for _ in range(max(1, total // len(chunk))):
                    f.write(chunk)
    return _config(folder, str(path) if where != folder else path.name, **more)


def _huge_line(folder: Path) -> Path:
    def edit(lines: list[str]) -> None:
        lines[3] = lines[3].rsplit(",", 1)[0] + "," + "1" * 2**26
    return _csv(folder, "a,b,y", edit=edit)


def _h5_terabytes(folder: Path) -> Path:
    import h5py

    with h5py.File(folder / "runs.h5", "w") as f:
        for name in ("a", "b", "y"):
            f.create_dataset(name, shape=(10**12,), dtype="f8", chunks=(2**16,))
    return _config(folder, "runs.h5")


def _npz_lying(folder: Path) -> Path:
    r = _rows(40)
    np.savez(folder / "runs.npz", a=r[:, 0], b=r[:, 1], y=r[:, 2])
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False,
                                                "shape": (10**12,)})
    with zipfile.ZipFile(folder / "runs.npz", "a") as z:
        z.writestr("big.npy", head.getvalue() + r[:, 2].tobytes())
    return _config(folder, "runs.npz")


def _npz_pickled(folder: Path) -> Path:
    buf = io.BytesIO()
    np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
    with zipfile.ZipFile(folder / "runs.npz", "w") as z:
        z.writestr("a.npy", buf.getvalue())
    return _config(folder, "runs.npz")


def _npz_bomb(gib: float) -> Callable[[Path], Path]:
    """An ``.npz`` whose member holds ``gib`` GiB of zeros deflated: a true claim, over the
    ``max_memory`` of 1 GB the config sets."""
    def build(folder: Path) -> Path:
        n = int(gib * 2**30) // 8
        head = io.BytesIO()
        np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False,
                                                    "shape": (n,)})
        with zipfile.ZipFile(folder / "runs.npz", "w", zipfile.ZIP_DEFLATED) as z:
            for name in ("a", "b", "y"):
                with z.open(f"{name}.npy", "w", force_zip64=True) as out:
                    out.write(head.getvalue())
                    zeros = bytes(2**24)
                    for _ in range(n * 8 // len(zeros)):
                        out.write(zeros)
        return _config(folder, "runs.npz", max_memory="1 GB")
    return build


# ---------------------------------------------------------------------------- FMU builders
_FMU: dict[str, Path] = {}


def decay_fmu(crashing: bool = False) -> Path:
    """The test FMU (tests/fmu_decay.py), built once (needs FMPy and a C compiler)."""
    from tests.fmu_decay import CRASHING, SOURCE, build

    key = "crash" if crashing else "decay"
    if key not in _FMU:
        folder = Path(tempfile.mkdtemp(prefix="containment-fmu-"))
        atexit.register(shutil.rmtree, folder, True)
        _FMU[key] = build(folder, source=CRASHING if crashing else SOURCE)
    return _FMU[key]


def _fmu_config(folder: Path, fmu: Path, n: int = 100, **more: object) -> Path:
    cfg = {"model": {"name": "fmu", "path": fmu.name, "inputs": {"x0": "x0", "rate": "k"},
                     "outputs": ["x"], "stop_time": 2.0, "output_interval": 0.5},
           "inputs": [{"name": "x0", "dist": "normal", "mean": 1.0, "std": 0.2},
                      {"name": "rate", "dist": "uniform", "low": 0.2, "high": 0.8}],
           "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": n}],
           "max_memory": MAX_MEMORY, **more}
    path = folder / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    return path


def _bad_fmu(extra: Callable[[zipfile.ZipFile], None]) -> Callable[[Path], Path]:
    def build(folder: Path) -> Path:
        import warnings

        bad = folder / "bad.fmu"
        with zipfile.ZipFile(decay_fmu()) as z, zipfile.ZipFile(bad, "w") as out, \
                warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a duplicate name is the point of one case
            for info in z.infolist():
                out.writestr(info, z.read(info))
            extra(out)
        return _fmu_config(folder, bad)
    return build


def _member(name: str, mode: int = 0, data: bytes = b"/etc/passwd"
            ) -> Callable[[zipfile.ZipFile], None]:
    def add(z: zipfile.ZipFile) -> None:
        info = zipfile.ZipInfo(name)
        if mode:
            info.create_system, info.external_attr = 3, mode << 16
        z.writestr(info, data)
    return add


def _bomb(gib: float) -> Callable[[zipfile.ZipFile], None]:
    def add(z: zipfile.ZipFile) -> None:
        info = zipfile.ZipInfo("resources/zeros.bin")
        info.compress_type = zipfile.ZIP_DEFLATED
        zeros = bytes(2**24)
        with z.open(info, "w", force_zip64=True) as out:
            for _ in range(int(gib * 2**30) // len(zeros)):
                out.write(zeros)
    return add


def _many(z: zipfile.ZipFile) -> None:
    for i in range(10_001):
        z.writestr(f"resources/f{i}.txt", b"")


def _lying_fmu(folder: Path) -> Path:
    """A member of 4 MiB of zeros whose headers (local and central) declare 1000 bytes."""
    bad = folder / "bad.fmu"
    with zipfile.ZipFile(decay_fmu()) as z, zipfile.ZipFile(bad, "w") as out:
        for info in z.infolist():
            out.writestr(info, z.read(info))
        info = zipfile.ZipInfo("resources/table.bin")
        info.compress_type = zipfile.ZIP_DEFLATED
        out.writestr(info, bytes(4 * 2**20))
    raw = bytearray(bad.read_bytes())
    with zipfile.ZipFile(bad) as z:
        m = z.getinfo("resources/table.bin")
    for at in (m.header_offset + 22,
               raw.rindex(b"PK\x01\x02", 0, raw.rindex(b"resources/table.bin")) + 24):
        raw[at:at + 4] = (1000).to_bytes(4, "little")
    bad.write_bytes(bytes(raw))
    return _fmu_config(folder, bad)


def _crashing(folder: Path) -> Path:
    fmu = folder / "crash.fmu"
    fmu.write_bytes(decay_fmu(crashing=True).read_bytes())
    cfg = _fmu_config(folder, fmu, max_failed_fraction=1.0, batch_size=50)
    data = yaml.safe_load(cfg.read_text())
    data["model"]["start_values"] = {"x_max": 1.2}
    cfg.write_text(yaml.safe_dump(data))
    return cfg


def _long_fmu_run(folder: Path) -> Path:
    fmu = folder / "decay.fmu"
    fmu.write_bytes(decay_fmu().read_bytes())
    return _fmu_config(folder, fmu, n=200_000)


def _good_fmu(folder: Path) -> Path:
    fmu = folder / "decay.fmu"
    fmu.write_bytes(decay_fmu().read_bytes())
    return _fmu_config(folder, fmu)


# ---------------------------------------------------------------------------- the cases
def hostile(quick: bool = False) -> Iterator[Hostile]:
    """The inputs (module docstring); ``quick``: the 2 GB CSV and the 1 GiB bombs as 200 MB
    and 64 MiB stand-ins."""
    big = 2 * 10**8 if quick else 2 * 10**9
    bomb = 1 / 16 if quick else 1.0
    yield Hostile("csv_bom", lambda f: _csv(f, "a,b,y", prefix=b"\xef\xbb\xbf"), expect=0,
                  text="OK")
    yield Hostile("csv_bom_in_a_name", lambda f: _csv(f, "a,\ufeffb,y"),
                  text="holds a byte-order mark U+FEFF")
    yield Hostile("csv_repeated_name", lambda f: _csv(f, "a,b,a"), text="appears twice")
    yield Hostile("csv_control_in_name", lambda f: _csv(f, "a,b,y\x07"),
                  text="holds a control character U+0007")
    yield Hostile("csv_nul_in_name", lambda f: _csv(f, "a,b,y\x00"),
                  text="holds a control character U+0000")
    yield Hostile("csv_long_name", lambda f: _csv(f, "a,b," + "y" * 300),
                  text="allowed at most 200")
    yield Hostile("csv_non_plain_output_name", lambda f: _csv(f, "a,b,T (K)"),
                  text="cannot name an output")
    # an index this large once built range(10^11): 4.8 GB and a traceback
    yield Hostile("csv_step_index_1e11", lambda f: _csv(f, "a,b,y[99999999999]"),
                  text="column y[0] is missing", child=True)
    yield Hostile("csv_cell_65_chars", lambda f: _csv(
        f, "a,b,y", edit=lambda L: L.__setitem__(3, L[3].rsplit(",", 1)[0] + "," + "1" * 65)),
        text="a cell of 65 characters; allowed at most 64")
    yield Hostile("csv_line_64MiB", _huge_line, text="is longer than", child=True)
    # the case: read whole, a 2 GB sparse CSV took uqguide past 4 GB
    yield Hostile(f"csv_sparse_{big / 1e9:g}GB",
                  lambda f: _stream_csv(f, "a,b,y", b",,\n", big),
                  text="more than max_memory", child=True)
    yield Hostile("csv_dense_read",
                  lambda f: _stream_csv(f, "a,b,y", b"", 3 * 10**7, dense=True), expect=0,
                  text="OK", child=True)
    yield Hostile("h5_156TB_claimed", _h5_terabytes, text="more than max_memory", child=True)
    yield Hostile("npz_header_lies", _npz_lying, text="its header claims shape "
                  "(1000000000000,) float64", child=True)
    yield Hostile("npz_pickled_member", _npz_pickled, text="Python objects (pickled)")
    yield Hostile(f"npz_zip_bomb_{bomb:g}GiB", _npz_bomb(bomb), text="more than max_memory",
                  child=True)
    yield Hostile("one_row_std", lambda f: _csv(f, "a,b,y", n=1), args=("run", "--out"),
                  expect=0, text="needs 2 runs")
    try:
        decay_fmu()
    except Exception as exc:  # noqa: BLE001 - no FMPy, no C compiler
        print(f"containment_data: no FMU cases ({type(exc).__name__}: {exc})", file=sys.stderr)
        return
    for name, member, mode, text in (
            ("absolute", "/tmp/evil.so", 0, "an absolute path"),
            ("climbing", "resources/../../evil.so", 0, "a path out of the FMU's folder"),
            ("backslash", "resources\\evil.so", 0, "a path with a backslash"),
            ("symlink", "resources/passwd", stat.S_IFLNK | 0o777, "a symbolic link"),
            ("fifo", "resources/pipe", stat.S_IFIFO | 0o644, "a special file"),
            ("device", "resources/disk", stat.S_IFBLK | 0o644, "a special file"),
            ("duplicate", "sources/decay.c", 0, "a second member of that name")):
        yield Hostile(f"fmu_member_{name}", _bad_fmu(_member(member, mode)), text=text)
    yield Hostile(f"fmu_zip_bomb_{bomb:g}GiB", _bad_fmu(_bomb(bomb)),
                  text="a zip bomb's ratio", child=True)
    yield Hostile("fmu_size_lies", _lying_fmu, text="cannot be unzipped")
    yield Hostile("fmu_10001_members", _bad_fmu(_many), text="an FMU may have at most")
    yield Hostile("fmu_run", _good_fmu, args=("run", "-q", "--out"), expect=0, child=True)
    # a fresh guard per crash, each of which left its unzipped copy (51 in this run)
    yield Hostile("fmu_crashing_run", _crashing, args=("run", "-q", "--out"), expect=0,
                  child=True)
    yield Hostile("fmu_ctrl_c", _long_fmu_run, expect=0, child=True, signal=signal.SIGINT)
    yield Hostile("fmu_killed_then_validate", _long_fmu_run, expect=0, child=True,
                  signal=signal.SIGKILL)


#: What the preparation of a case measured, by case name: uqguide's read estimate [bytes],
#: and for a signalled run its exit and the folders it left.
MEASURED: dict[str, dict[str, Any]] = {}


def _read_estimate(cfg: Path) -> float:
    """uqguide's estimate of reading a data config's file [bytes] (NaN when it is refused
    before one is made, or not a data config)."""
    from uqguide.config.data_source import read_bytes
    from uqguide.errors import ConfigError
    from uqguide.models.data_rows.files import CLAIMS, SUFFIXES

    data = yaml.safe_load(cfg.read_text()).get("data")
    if not isinstance(data, str):
        return float("nan")
    path = cfg.parent / data
    try:
        claim = CLAIMS[SUFFIXES[path.suffix]](path, data)
    except ConfigError:
        return float("nan")
    return read_bytes(claim, len(INPUTS))


def _fmu_folders(tmp: Path) -> int:
    return sum(1 for p in tmp.iterdir() if p.name.startswith(FMU_PREFIX)) if tmp.is_dir() else 0


def _child(args: Sequence[str | Path], box: Any) -> subprocess.Popen:
    from uqguide.models.fmu.archive import ENV

    env = {**os.environ, "TMPDIR": str(box.tmp), "PYTHONPATH": str(ROOT)}
    env.pop(ENV, None)
    return subprocess.Popen(
        [sys.executable, "-m", "uqguide.cli", *map(str, args)], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        # a background job's SIGINT is ignored, and Python keeps that: the default, as on a
        # terminal
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _signalled(h: Hostile, cfg: Path, box: Any) -> None:
    """A run of ``cfg`` sent ``h.signal`` once it has written a chunk: its exit and the
    unzipped folders left right after, and after SIGKILL those left once a ``validate`` has
    run, in :data:`MEASURED`. (The sweep happens here, before the case's snapshot: a folder
    of uqguide's removed from ``$TMPDIR`` would count as a write outside ``--out``.)"""
    out = Path(box.root) / "signalled"
    proc = _child(["run", "-q", "--out", out, cfg], box)
    deadline = time.monotonic() + 120
    while not list(out.glob("*.run/*.npz")) and proc.poll() is None and \
            time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(h.signal)
    code = proc.wait(120)
    time.sleep(1.0)  # a killed driver's guard ends on its parent's death (PR_SET_PDEATHSIG)
    m = MEASURED.setdefault(h.name, {})
    m.update(signalled_exit=code, left_after_signal=_fmu_folders(box.tmp))
    if h.signal == signal.SIGKILL:
        _child(["validate", cfg], box).wait(300)
        m["left_after_validate"] = _fmu_folders(box.tmp)


def _prepare(h: Hostile) -> Callable[[Any], list[str | Path]]:
    def prepare(box: Any) -> list[str | Path]:
        cfg = h.build(Path(box.inputs))
        MEASURED[h.name] = {"estimate": _read_estimate(cfg)} if "data" in \
            yaml.safe_load(cfg.read_text()) else {}
        if h.signal:
            _signalled(h, cfg, box)
        args: list[str | Path] = list(h.args)
        if args and args[-1] == "--out":
            args.append(box.out)
        return [*args, cfg]
    return prepare


def _check(h: Hostile) -> Callable[[Any, Any], list[str]]:
    def check(box: Any, run: Any) -> list[str]:
        problems = []
        said = f"{run.stdout}\n{run.stderr}"
        if h.text and h.text not in said:
            problems.append(f"the output does not say {h.text!r}")
        if h.expect == 2:
            lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
            if len(lines) != 1 or not lines[0].startswith("error: "):
                problems.append(f"not one error line: {lines[-3:]}")
        m = MEASURED.get(h.name, {})
        if h.signal == signal.SIGINT and (m.get("signalled_exit") != 130 or
                                          m.get("left_after_signal")):
            problems.append(f"Ctrl-C: exit {m.get('signalled_exit')}, "
                            f"{m.get('left_after_signal')} folders left")
        if h.signal == signal.SIGKILL and (m.get("signalled_exit") != -signal.SIGKILL or
                                           not m.get("left_after_signal") or
                                           m.get("left_after_validate")):
            problems.append(f"killed: exit {m.get('signalled_exit')}, "
                            f"{m.get('left_after_signal')} folders left, "
                            f"{m.get('left_after_validate')} after a validate")
        return problems
    return check


def cases(quick: bool = False) -> Iterator[dict[str, Any]]:
    """The cases in fuzz_containment's :class:`Case` form (its fields, as a dict)."""
    from uqguide.config.limits import parse_bytes

    for h in hostile(quick):
        group = "data file" if not h.name.startswith("fmu") else "fmu archive"
        memory = parse_bytes("1 GB") if h.name.startswith("npz_zip_bomb") else \
            parse_bytes(MAX_MEMORY)
        yield {"name": f"{group}: {h.name}", "prepare": _prepare(h), "expect": (h.expect,),
               "child": h.child, "max_memory": memory, "check": _check(h)}


# ---------------------------------------------------------------------------- the table
def _mb(v: float) -> str:
    return "" if v != v else f"{v / 1e6:,.0f} MB"


def main(argv: list[str] | None = None) -> int:
    import fuzz_containment as fc

    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="200 MB and 64 MiB stand-ins")
    ap.add_argument("--only", default="", help="cases whose name contains one of these "
                                                "(comma-separated)")
    args = ap.parse_args(argv)
    wanted = [w for w in args.only.split(",") if w] or [""]
    outcomes = []
    left: dict[str, int] = {}
    with tempfile.TemporaryDirectory(prefix="containment-data-") as t:
        for case in cases(args.quick):
            if not any(w in case["name"] for w in wanted):
                continue
            o = fc.try_case(fc._as_case(case), Path(t), {})
            outcomes.append(o)
            left[o.case] = _fmu_folders(Path(t) / "box" / "tmp")
            print(f"  {o.case}: {'ok' if o.ok else 'BAD'}, exit {o.run.exit_code}, "
                  f"{o.run.seconds:.1f} s{'; ' + '; '.join(o.problems) if o.problems else ''}"
                  f"{'; outside ' + str(o.outside[:3]) if o.outside else ''}", flush=True)
    print("\n| case | exit | traceback | peak RSS | read estimate | max_memory | folders left "
          "| verdict |\n|---|---|---|---|---|---|---|---|")
    for o in outcomes:
        name = o.case.split(": ", 1)[1]
        m = MEASURED.get(name, {})
        print(f"| {name} | {o.run.exit_code} | {'yes' if o.run.traceback else 'no'} | "
              f"{_mb(o.run.peak_rss)} | {_mb(m.get('estimate', float('nan')))} | "
              f"{_mb(o.max_memory)} | {left[o.case]} | {'ok' if o.ok else 'BAD'} |")
    for name, m in MEASURED.items():
        if "signalled_exit" in m:
            print(f"{name}: the signalled run ended with {m['signalled_exit']} and left "
                  f"{m['left_after_signal']} unzipped folders"
                  + (f", {m['left_after_validate']} after a validate"
                     if "left_after_validate" in m else ""))
    print(f"\n{len(outcomes)} cases: {fc.summary_line(outcomes)}")
    return 0 if all(o.ok for o in outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
