"""Hostile data files and FMUs: each built in a sandbox and given to uqguide; the table says how
uqguide ended (exit code, traceback or not), its peak memory against ``max_memory`` where that
is the point, and the unzipped FMU folders left in the temporary folder.

The cases (:func:`cases` yields them):

- data files: a CSV with a byte-order mark (read), one in the middle of a name, a repeated,
  unprintable or too long column name, a series step index of 10^11, a cell over its limit, a
  line of 64 MiB, a 2 GB sparse CSV (``max_memory: 4 GB``), HDF5 datasets claiming 156 TB, an
  ``.npz`` header claiming 8 TB, a pickled ``.npz`` member, an ``.npz`` zip bomb, a dense CSV
  that is read (its peak against the estimate), a one-row file (its std "needs 2 runs"), a
  DataFrame with a repeated column given to ``uqguide.fit``;
- FMUs: members with an absolute, a climbing or a backslash path, a symbolic link, a FIFO, a
  device, a repeated name, a 1 GiB zip bomb, a member whose declared size lies, 10,001
  members; a run of an FMU that crashes on 1 sample in 6 (a fresh guard per crash), a run
  stopped by Ctrl-C, and a killed run followed by a ``validate``.

A case runs in this process (click's CliRunner) where only the exit and the message matter,
and as a subprocess where its peak RSS is measured (``wait4``'s ``ru_maxrss`` of the child: the
driver, not its guard processes) or a signal is sent; ``TMPDIR`` then points into the sandbox,
so the unzipped folders left behind are counted. A subprocess is capped at ``--cap-gb`` of
address space (``RLIMIT_AS``), so a checkout that reads everything fails there, not the machine.

Usage::

    python benchmarks/containment_data.py                  # every case (2 GB CSV, 1 GiB bomb)
    python benchmarks/containment_data.py --quick          # 200 MB and 64 MiB stand-ins
    python benchmarks/containment_data.py --tree /work/main --only csv_sparse  # another checkout
"""

from __future__ import annotations

import argparse
import io
import os
import resource
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import time
import traceback
import zipfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # the test FMU's builder lives in tests/
    sys.path.insert(0, str(ROOT))

from click.testing import CliRunner  # noqa: E402

from uqguide.cli import main as cli  # noqa: E402

INPUTS = [{"name": "a", "dist": "uniform", "low": 0.0, "high": 1.0},
          {"name": "b", "dist": "uniform", "low": 0.0, "high": 1.0}]
MC = [{"name": "monte_carlo", "label": "mc"}]
FMU_PREFIX = "uqguide-fmu-"


@dataclass(frozen=True)
class Case:
    """One hostile input and what uqguide must do with it.

    Attributes
    ----------
    name : str
    kind : {"data", "fmu"}
    build : callable
        Sandbox folder -> the config to give uqguide (the input is written beside it).
    args : tuple of str
        The command (the config's path appended): ``("validate",)``, ``("run", "-q")``...
    expect : int
        The exit code uqguide must end with.
    text : str
        What its output must hold (empty: anything).
    subprocess : bool
        Run as a subprocess (peak RSS measured, TMPDIR in the sandbox).
    signal : int
        A signal sent once the run has written a chunk (0: none); ``SIGKILL`` is followed by a
        ``validate`` of the same config, which must sweep the killed run's folder.
    api : callable or None
        In place of a command: called with the sandbox; a ConfigError is exit 2.
    """

    name: str
    kind: str
    build: Callable[[Path], Path]
    args: tuple[str, ...] = ("validate",)
    expect: int = 2
    text: str = ""
    subprocess: bool = False
    signal: int = 0
    api: Callable[[Path], object] | None = None


@dataclass
class Outcome:
    case: Case
    exit_code: int
    traceback: bool
    message: str
    rss: float = float("nan")  # peak RSS of the driver [bytes]
    max_memory: float = float("nan")
    estimate: float = float("nan")  # uqguide's estimate of reading a data file [bytes]
    left: int = 0  # unzipped folders left in the temporary folder
    seconds: float = 0.0
    notes: list[str] = field(default_factory=list)

    @property
    def verdict(self) -> str:
        if self.traceback:
            return "TRACEBACK"
        if self.exit_code != self.case.expect:
            return f"EXIT {self.exit_code} (want {self.case.expect})"
        if self.case.text and self.case.text not in self.message:
            return "MESSAGE"
        if self.rss > self.max_memory:
            return "OVER max_memory"
        if self.left:
            return "LEFT FOLDERS"
        return "ok"


# ---------------------------------------------------------------------------- builders
def _config(folder: Path, data: str, **more: object) -> Path:
    cfg = {"data": data, "inputs": INPUTS, "methods": MC, **more}
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


def _stream_csv(folder: Path, header: str, line: bytes, total: int, dense: bool = False,
                **more: object) -> Path:
    """A CSV of ``total`` bytes of ``line`` after its header (written a chunk at a time)."""
    path = folder / "runs.csv"
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
    return _config(folder, "runs.csv", **more)


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


def _fit_repeated(folder: Path) -> object:
    import pandas as pd

    import uqguide

    r = _rows(40)
    return uqguide.fit(pd.DataFrame(r[:, [0, 1, 0]], columns=["a", "b", "a"]), r[:, 2],
                       inputs=INPUTS, method="monte_carlo")


# ---------------------------------------------------------------------------- FMU builders
_FMU: dict[str, Path] = {}


def decay_fmu(crashing: bool = False) -> Path:
    """The test FMU (tests/fmu_decay.py), built once (needs FMPy and a C compiler)."""
    from tests.fmu_decay import CRASHING, SOURCE, build

    key = "crash" if crashing else "decay"
    if key not in _FMU:
        folder = Path(tempfile.mkdtemp(prefix="containment-fmu-"))
        _FMU[key] = build(folder, source=CRASHING if crashing else SOURCE)
    return _FMU[key]


def _fmu_config(folder: Path, fmu: Path, n: int = 100, **more: object) -> Path:
    cfg = {"model": {"name": "fmu", "path": fmu.name, "inputs": {"x0": "x0", "rate": "k"},
                     "outputs": ["x"], "stop_time": 2.0, "output_interval": 0.5},
           "inputs": [{"name": "x0", "dist": "normal", "mean": 1.0, "std": 0.2},
                      {"name": "rate", "dist": "uniform", "low": 0.2, "high": 0.8}],
           "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": n}], **more}
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
def cases(quick: bool = False) -> Iterator[Case]:
    """Every case (module docstring); ``quick``: the 2 GB CSV and the 1 GiB bomb as 200 MB and
    64 MiB stand-ins."""
    big = 2 * 10**8 if quick else 2 * 10**9
    bomb = 1 / 16 if quick else 1.0
    yield Case("csv_bom", "data", lambda f: _csv(f, "a,b,y", prefix=b"\xef\xbb\xbf"), expect=0,
               text="OK")
    yield Case("csv_bom_in_a_name", "data", lambda f: _csv(f, "a,\ufeffb,y"),
               text="holds a byte-order mark U+FEFF")
    yield Case("csv_repeated_name", "data", lambda f: _csv(f, "a,b,a"), text="appears twice")
    yield Case("csv_control_in_name", "data", lambda f: _csv(f, "a,b,y\x07"),
               text="holds a control character U+0007")
    yield Case("csv_nul_in_name", "data", lambda f: _csv(f, "a,b,y\x00"),
               text="holds a control character U+0000")
    yield Case("csv_long_name", "data", lambda f: _csv(f, "a,b," + "y" * 300),
               text="allowed at most 200")
    yield Case("csv_non_plain_output_name", "data", lambda f: _csv(f, "a,b,T (K)"),
               text="cannot name an output")
    yield Case("csv_step_index_1e11", "data", lambda f: _csv(f, "a,b,y[99999999999]"),
               text="column y[0] is missing", subprocess=True)
    yield Case("csv_cell_65_chars", "data", lambda f: _csv(
        f, "a,b,y", edit=lambda L: L.__setitem__(3, L[3].rsplit(",", 1)[0] + "," + "1" * 65)),
        text="a cell of 65 characters; allowed at most 64")
    yield Case("csv_line_64MiB", "data", _huge_line, text="is longer than", subprocess=True)
    # the case: read whole, a 2 GB sparse CSV took uqguide past 4 GB
    yield Case(f"csv_sparse_{big / 1e9:g}GB", "data",
               lambda f: _stream_csv(f, "a,b,y", b",,\n", big, max_memory="4 GB"),
               text="more than max_memory", subprocess=True)
    yield Case("csv_dense_read", "data",
               lambda f: _stream_csv(f, "a,b,y", b"", 3 * 10**7, dense=True), expect=0,
               text="OK", subprocess=True)
    yield Case("h5_156TB_claimed", "data", _h5_terabytes, text="more than max_memory",
               subprocess=True)
    yield Case("npz_header_lies", "data", _npz_lying, text="its header claims shape "
               "(1000000000000,) float64", subprocess=True)
    yield Case("npz_pickled_member", "data", _npz_pickled, text="Python objects (pickled)")
    yield Case(f"npz_zip_bomb_{bomb:g}GiB", "data", _npz_bomb(bomb), text="more than max_memory",
               subprocess=True)
    yield Case("one_row_std", "data", lambda f: _csv(f, "a,b,y", n=1), args=("run", "--out"),
               expect=0, text="needs 2 runs")
    yield Case("fit_repeated_column", "data", lambda f: f, api=_fit_repeated,
               text="appears twice")
    for name, member, mode, text in (
            ("absolute", "/tmp/evil.so", 0, "an absolute path"),
            ("climbing", "resources/../../evil.so", 0, "a path out of the FMU's folder"),
            ("backslash", "resources\\evil.so", 0, "a path with a backslash"),
            ("symlink", "resources/passwd", stat.S_IFLNK | 0o777, "a symbolic link"),
            ("fifo", "resources/pipe", stat.S_IFIFO | 0o644, "a special file"),
            ("device", "resources/disk", stat.S_IFBLK | 0o644, "a special file"),
            ("duplicate", "sources/decay.c", 0, "a second member of that name")):
        yield Case(f"fmu_member_{name}", "fmu", _bad_fmu(_member(member, mode)), text=text)
    yield Case(f"fmu_zip_bomb_{bomb:g}GiB", "fmu", _bad_fmu(_bomb(bomb)),
               text="a zip bomb's ratio", subprocess=True)
    yield Case("fmu_size_lies", "fmu", _lying_fmu, text="cannot be unzipped")
    yield Case("fmu_10001_members", "fmu", _bad_fmu(_many), text="an FMU may have at most")
    yield Case("fmu_run", "fmu", _good_fmu, args=("run", "-q", "--out"), expect=0,
               subprocess=True)
    yield Case("fmu_crashing_run", "fmu", _crashing, args=("run", "-q", "--out"), expect=0,
               subprocess=True)
    yield Case("fmu_ctrl_c", "fmu", _long_fmu_run, args=("run", "-q", "--out"), expect=130,
               subprocess=True, signal=signal.SIGINT)
    yield Case("fmu_killed_then_validate", "fmu", _long_fmu_run, args=("run", "-q", "--out"),
               expect=0, subprocess=True, signal=signal.SIGKILL)


# ---------------------------------------------------------------------------- running
def _fmu_folders(tmpdir: Path) -> int:
    return sum(1 for p in tmpdir.iterdir() if p.name.startswith(FMU_PREFIX))


def _max_memory(cfg: Path) -> float:
    from uqguide.config.limits import memory_limit

    try:
        return float(memory_limit(yaml.safe_load(cfg.read_text()).get("max_memory")))
    except (OSError, ValueError, AttributeError):
        return float("nan")


def _command(case: Case, cfg: Path, box: Path) -> list[str]:
    args = list(case.args)
    if args[-1] == "--out":
        args.append(str(box / "out"))
    return [*args, str(cfg)]


def _in_process(case: Case, cfg: Path, box: Path) -> Outcome:
    if case.api is not None:
        from uqguide.errors import ConfigError

        try:
            case.api(box)
        except ConfigError as exc:
            return Outcome(case, 2, False, str(exc))
        except Exception:  # noqa: BLE001 - what the table reports
            return Outcome(case, 1, True, traceback.format_exc(limit=1))
        return Outcome(case, 0, False, "")
    tmpdir = box / "tmp"
    tmpdir.mkdir()
    old = tempfile.tempdir
    tempfile.tempdir = str(tmpdir)
    try:
        res = CliRunner().invoke(cli, _command(case, cfg, box))
    finally:
        tempfile.tempdir = old
    tb = res.exception is not None and not isinstance(res.exception, SystemExit)
    # a refusal unzips nothing; an accepted FMU stays unzipped until this process exits
    left = _fmu_folders(tmpdir) if case.expect else 0
    return Outcome(case, res.exit_code, tb, res.output, left=left)


def _spawn(command: list[str], box: Path, tree: Path, cap: float) -> subprocess.Popen:
    env = {**os.environ, "TMPDIR": str(box / "tmp"), "PYTHONPATH": str(tree)}
    env.pop("UQGUIDE_FMU_UNZIPPED", None)

    def child() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)  # a background job's SIGINT is ignored
        resource.setrlimit(resource.RLIMIT_AS, (int(cap), int(cap)))

    with (box / "output.txt").open("ab") as out:
        return subprocess.Popen([sys.executable, "-m", "uqguide.cli", *command], env=env,
                                stdout=out, stderr=subprocess.STDOUT, preexec_fn=child)


def _reap(proc: subprocess.Popen, box: Path, timeout: float) -> tuple[int, float, str]:
    """Exit code, peak RSS [bytes] and output of a child (killed after ``timeout`` s)."""
    deadline = time.monotonic() + timeout
    while True:
        pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
        if pid:
            proc.returncode = os.waitstatus_to_exitcode(status)
            text = (box / "output.txt").read_bytes()[-2**20:].decode(errors="replace")
            (box / "output.txt").unlink()
            return proc.returncode, usage.ru_maxrss * 1024.0, text
        if time.monotonic() > deadline:
            proc.kill()
            deadline = float("inf")
        time.sleep(0.02)


def _estimate(cfg: Path) -> float:
    """What uqguide estimates reading a data config's file takes [bytes] (NaN otherwise)."""
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


def _as_subprocess(case: Case, cfg: Path, box: Path, tree: Path, cap: float) -> Outcome:
    (box / "tmp").mkdir()
    proc = _spawn(_command(case, cfg, box), box, tree, cap)
    notes = []
    if case.signal:
        deadline = time.monotonic() + 120
        while not list((box / "out").glob("*.run/*.npz")) and time.monotonic() < deadline \
                and proc.poll() is None:
            time.sleep(0.05)
        proc.send_signal(case.signal)
    code, rss, text = _reap(proc, box, 1800)
    if case.signal == signal.SIGKILL:
        notes.append(f"killed: {_fmu_folders(box / 'tmp')} folder(s) left, then validate")
        code, _, text = _reap(_spawn(["validate", str(cfg)], box, tree, cap), box, 600)
    return Outcome(case, code, "Traceback (most recent call last)" in text, text, rss,
                   _max_memory(cfg), left=_fmu_folders(box / "tmp"), notes=notes,
                   estimate=_estimate(cfg) if case.kind == "data" else float("nan"))


def run_case(case: Case, box: Path, tree: Path = ROOT, cap: float = 8 * 2**30) -> Outcome:
    """Build ``case`` in the empty folder ``box`` and give it to uqguide."""
    t0 = time.monotonic()
    cfg = case.build(box)
    built = time.monotonic()
    o = _as_subprocess(case, cfg, box, tree, cap) if case.subprocess else \
        _in_process(case, cfg, box)
    o.seconds = time.monotonic() - built
    o.notes.append(f"built in {built - t0:.1f} s")
    return o


def _mb(v: float) -> str:
    return "" if v != v else f"{v / 1e6:,.0f} MB"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="200 MB and 64 MiB stand-ins")
    ap.add_argument("--only", default="", help="cases whose name contains one of these "
                                                "(comma-separated)")
    ap.add_argument("--tree", type=Path, default=ROOT, help="checkout the subprocesses run")
    ap.add_argument("--cap-gb", type=float, default=8.0, help="RLIMIT_AS of a subprocess")
    args = ap.parse_args(argv)
    outcomes = []
    wanted = [w for w in args.only.split(",") if w] or [""]
    for case in cases(args.quick):
        if not any(w in case.name for w in wanted):
            continue
        box = Path(tempfile.mkdtemp(prefix="containment-data-"))
        try:
            o = run_case(case, box, args.tree, args.cap_gb * 2**30)
        except Exception as exc:  # noqa: BLE001 - a case that cannot be built (no cc)
            print(f"  {case.name}: not run ({type(exc).__name__}: {exc})")
            continue
        finally:
            # a killed run's guard may still be ending: give it a moment before the removal
            for _ in range(50):
                shutil.rmtree(box, ignore_errors=True)
                if not box.exists():
                    break
                time.sleep(0.1)
        outcomes.append(o)
        first = next((ln for ln in o.message.splitlines() if ln.startswith("error:")), "")
        print(f"  {case.name}: {o.verdict}, exit {o.exit_code}, {o.seconds:.1f} s "
              f"{first[:150]}", flush=True)
    print("\n| case | exit | traceback | peak RSS | read estimate | max_memory | folders left "
          "| verdict |")
    print("|---|---|---|---|---|---|---|---|")
    for o in outcomes:
        print(f"| {o.case.name} | {o.exit_code} | {'yes' if o.traceback else 'no'} | "
              f"{_mb(o.rss)} | {_mb(o.estimate)} | {_mb(o.max_memory)} | {o.left} | "
              f"{o.verdict} |")
    bad = [o for o in outcomes if o.verdict != "ok"]
    print(f"\n{len(outcomes)} cases: {sum(o.traceback for o in outcomes)} tracebacks, "
          f"{sum(o.rss > o.max_memory for o in outcomes)} over max_memory, "
          f"{sum(o.left for o in outcomes)} unzipped folders left, "
          f"{sum(o.exit_code != o.case.expect for o in outcomes)} unexpected exits")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
