"""Hostile data files and FMUs, cases of benchmarks/fuzz_containment.py: each built in the
case's sandbox and given to uqguide, which must end with the exit code and message of the case;
fuzz_containment judges the rest (a traceback, peak RSS against the config's ``max_memory``,
unzipped FMU folders left in the sandbox's ``TMPDIR`` as writes outside ``--out``).

- data files: a CSV with a byte-order mark (read), one in the middle of a name, a repeated,
  unprintable or too long column name, a series step index of 10^11, a cell over its limit, a
  line of 64 MiB, a 2 GB sparse CSV (``max_memory: 4 GB``), HDF5 datasets claiming 156 TB, an
  ``.npz`` header claiming 8 TB, a pickled member, an ``.npz`` zip bomb, a dense CSV that is
  read, a one-row file (its std "needs 2 runs"), a repeated column given to ``uqguide.fit``;
- FMUs: members with an absolute, a climbing or a backslash path, a symbolic link, a FIFO, a
  device, a repeated name, a 1 GiB zip bomb, a lying size, 10,001 members; a run of an FMU
  crashing on 1 sample in 6, a run stopped by Ctrl-C, a killed run then a ``validate``.

    python benchmarks/containment_data.py      # = fuzz_containment.py --group data
"""

from __future__ import annotations

import functools
import importlib.util
import io
import shutil
import signal
import stat
import sys
import tempfile
import zipfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import numpy as np
import yaml
from fuzz_containment import Box, Case, Run, run_child
from fuzz_containment import main_ as fuzz_main

from uqguide.config.limits import memory_limit

INPUTS = [{"name": "a", "dist": "uniform", "low": 0.0, "high": 1.0},
          {"name": "b", "dist": "uniform", "low": 0.0, "high": 1.0}]
MC = [{"name": "monte_carlo", "label": "mc"}]
#: A child's address space (``RLIMIT_AS``): a checkout that reads everything fails there.
CAP = 8 * 2**30


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


NPZ_BOMB_MEMORY = "1 GB"


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
        return _config(folder, "runs.npz", max_memory=NPZ_BOMB_MEMORY)
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
    yield _case("csv_bom", "data", lambda f: _csv(f, "a,b,y", prefix=b"\xef\xbb\xbf"), expect=0,
                text="OK")
    yield _case("csv_bom_in_a_name", "data", lambda f: _csv(f, "a,\ufeffb,y"),
                text="holds a byte-order mark U+FEFF")
    yield _case("csv_repeated_name", "data", lambda f: _csv(f, "a,b,a"), text="appears twice")
    yield _case("csv_control_in_name", "data", lambda f: _csv(f, "a,b,y\x07"),
                text="holds a control character U+0007")
    yield _case("csv_nul_in_name", "data", lambda f: _csv(f, "a,b,y\x00"),
                text="holds a control character U+0000")
    yield _case("csv_long_name", "data", lambda f: _csv(f, "a,b," + "y" * 300),
                text="allowed at most 200")
    yield _case("csv_non_plain_output_name", "data", lambda f: _csv(f, "a,b,T (K)"),
                text="cannot name an output")
    yield _case("csv_step_index_1e11", "data", lambda f: _csv(f, "a,b,y[99999999999]"),
                text="column y[0] is missing", child=True)
    yield _case("csv_cell_65_chars", "data", lambda f: _csv(
        f, "a,b,y", edit=lambda L: L.__setitem__(3, L[3].rsplit(",", 1)[0] + "," + "1" * 65)),
        text="a cell of 65 characters; allowed at most 64")
    yield _case("csv_line_64MiB", "data", _huge_line, text="is longer than", child=True)
    # the case: read whole, a 2 GB sparse CSV took uqguide past 4 GB
    yield _case(f"csv_sparse_{big / 1e9:g}GB", "data",
                lambda f: _stream_csv(f, "a,b,y", b",,\n", big, max_memory="4 GB"),
                text="more than max_memory", child=True, max_memory="4 GB")
    yield _case("csv_dense_read", "data",
                lambda f: _stream_csv(f, "a,b,y", b"", 3 * 10**7, dense=True), expect=0,
                text="OK", child=True)
    yield _case("h5_156TB_claimed", "data", _h5_terabytes, text="more than max_memory",
                child=True)
    yield _case("npz_header_lies", "data", _npz_lying, text="its header claims shape "
                "(1000000000000,) float64", child=True)
    yield _case("npz_pickled_member", "data", _npz_pickled, text="Python objects (pickled)")
    yield _case(f"npz_zip_bomb_{bomb:g}GiB", "data", _npz_bomb(bomb),
                text="more than max_memory", child=True, max_memory=NPZ_BOMB_MEMORY)
    yield _case("one_row_std", "data", lambda f: _csv(f, "a,b,y", n=1), args=("run", "--out"),
                expect=0, text="needs 2 runs")
    yield _case("fit_repeated_column", "data", lambda f: f, api=_fit_repeated,
                text="appears twice")
    if not _fmus_buildable():
        return
    for name, member, mode, text in (
            ("absolute", "/tmp/evil.so", 0, "an absolute path"),
            ("climbing", "resources/../../evil.so", 0, "a path out of the FMU's folder"),
            ("backslash", "resources\\evil.so", 0, "a path with a backslash"),
            ("symlink", "resources/passwd", stat.S_IFLNK | 0o777, "a symbolic link"),
            ("fifo", "resources/pipe", stat.S_IFIFO | 0o644, "a special file"),
            ("device", "resources/disk", stat.S_IFBLK | 0o644, "a special file"),
            ("duplicate", "sources/decay.c", 0, "a second member of that name")):
        yield _case(f"fmu_member_{name}", "fmu", _bad_fmu(_member(member, mode)), text=text)
    yield _case(f"fmu_zip_bomb_{bomb:g}GiB", "fmu", _bad_fmu(_bomb(bomb)),
                text="a zip bomb's ratio", child=True)
    yield _case("fmu_size_lies", "fmu", _lying_fmu, text="cannot be unzipped")
    yield _case("fmu_10001_members", "fmu", _bad_fmu(_many), text="an FMU may have at most")
    yield _case("fmu_run", "fmu", _good_fmu, args=("run", "-q", "--out"), expect=0,
                child=True)
    yield _case("fmu_crashing_run", "fmu", _crashing, args=("run", "-q", "--out"), expect=0,
                child=True)
    yield _case("fmu_ctrl_c", "fmu", _long_fmu_run, args=("run", "-q", "--out"), expect=130,
                child=True, signal=signal.SIGINT)
    yield _case("fmu_killed_then_validate", "fmu", _long_fmu_run, args=("run", "-q", "--out"),
                child=True, signal=signal.SIGKILL)


def _case(name: str, kind: str, build: Callable[[Path], Path],
          args: Sequence[str] = ("validate",), expect: int = 2, text: str = "",
          child: bool = False, signal: int = 0, api: Callable[[Path], object] | None = None,
          max_memory: str | None = None) -> Case:
    """A case of fuzz_containment: ``build`` writes the input and its config (whose
    ``max_memory`` is given here too) into the sandbox's input folder; the command is
    ``uqguide ARGS CONFIG`` (``--out`` last in ARGS: the sandbox's), or ``api`` of that folder.
    A run killed (``signal``: SIGKILL) must be followed by a clean ``validate``."""
    def prepare(box: Box) -> list[str | Path]:
        cfg = build(box.inputs)
        cmd: list[str | Path] = list(args)
        if cmd[-1] == "--out":
            cmd.append(box.out)
        return [*cmd, cfg]

    def check(box: Box, run: Run) -> list[str]:
        said = run.stdout + run.stderr
        problems = [] if text in said else [f"no {text!r} in {said.strip()[-200:]!r}"]
        if signal == _KILL:  # the next command sweeps the killed run's unzipped FMU
            again = run_child(["validate", box.inputs / "c.yaml"], {}, box.tmp, None, CAP)
            if again.exit_code != 0 or again.traceback:
                problems.append(f"validate after the kill: exit {again.exit_code}: "
                                f"{again.stderr.strip()[-200:]}")
        return problems

    call = None if api is None else (lambda box: api(box.inputs))
    return Case(f"data {'file' if kind == 'data' else kind}: {name}", prepare,
                expect=(-signal if signal == _KILL else expect,), child=child, check=check,
                max_memory=memory_limit(max_memory), signal=signal,
                address_space=CAP if child else None, call=call)


_KILL = signal.SIGKILL


@functools.cache
def _fmus_buildable() -> bool:
    """The test FMU needs FMPy and a C compiler."""
    return importlib.util.find_spec("fmpy") is not None and shutil.which("cc") is not None


def main(argv: list[str] | None = None) -> int:
    """fuzz_containment's campaign, the data and FMU cases only."""
    return fuzz_main(["--group", "data", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
