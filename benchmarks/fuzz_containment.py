"""Containment fuzz: links, files and folders planted where a run writes, then a run, a resume
and a clean-up; after each, nothing outside ``--out`` changed and nothing of the user's is gone.

A sandbox holds ``outside/`` (a file, a folder with a file, and a path that must stay absent)
beside ``out/`` (the ``--out``). Into ``out/`` and into the run folder ``out/st.run/`` go
**plants**: a user's file, a user's folder (with a file), a symbolic link to the outside file,
to the outside folder or to the absent path, and a hard link to the outside file, at every name
a run creates, truncates, appends to or deletes (result, tables, run folder, lock, manifest,
chunk files and their temporary names) and at names of the user's own. Each layout (one plant,
or several at random) is tried in three phases:

- **run**: a fresh ``uqguide run`` into ``out/``;
- **resume**: ``--resume`` of a run interrupted after two chunks (a real Ctrl-C: the model
  raises KeyboardInterrupt in the driver);
- **cleanup**: a run of the same config over a run folder whose chunks are all done but whose
  result was interrupted while it was written (the folder is recognised as finished, its files
  removed).

After each command: every file, folder and link outside ``out/`` is as it was (type, bytes,
link target; the absent path still absent), every plant is still there as planted (the
names of the run's own result and tables excepted: a run replaces those, never writes through
them), and the command ended with exit 0, 1 or 2 and no traceback.

Everything runs in this process (click's CliRunner; the config's model is evaluated in the
driver), so a few hundred layouts take seconds.

Usage::

    python benchmarks/fuzz_containment.py              # every layout, prints the table
    python benchmarks/fuzz_containment.py --sample 12  # 12 layouts at random
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import os
import random
import shutil
import sys
import tempfile
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # the test models live in tests/
    sys.path.insert(0, str(ROOT))

from click.testing import CliRunner  # noqa: E402

from uqguide.cli import main  # noqa: E402
from tests import failing_models  # noqa: E402

NAME = "st"
CONFIG = {**failing_models.mc_config("tests.failing_models:ctrl_c_on_third_call", 200, 50),
          "name": NAME}
CONFIG["model"] = {**CONFIG["model"], "isolate": False}  # the Ctrl-C must reach the driver

#: Names a run writes (its own: replacing them is its job, writing through them is not): in
#: ``out/`` its result, tables, lock and their temporary names (a temporary name of a dead
#: process is removed by design); in the run folder its chunks and their temporary names.
OWN = {f"{NAME}.h5", f"{NAME}_stats.csv", f"{NAME}_cost.csv", f"{NAME}_summary.md",
       f"{NAME}_events.csv", f"{NAME}.run.lock", f".{NAME}.h5.99999.tmp"}
OWN_IN_RUN = {"mc.s0.c000000.npz", "mc.s0.c000003.npz", ".mc.s0.c000002.npz.99999.tmp"}
OUT_NAMES = sorted(OWN - {f"{NAME}_events.csv"}) + [
    f"{NAME}.run", f"{NAME}.run.lock", f".{NAME}.h5.99999.tmp", "notes.txt", "data"]
RUN_NAMES = ["manifest.jsonl", "mc.s0.c000000.npz", "mc.s0.c000003.npz",
             ".mc.s0.c000002.npz.99999.tmp", "notes.txt", "sub"]
KINDS = ["file", "folder", "link_file", "link_folder", "link_absent", "hardlink"]
PHASES = ["run", "resume", "cleanup"]


@dataclass(frozen=True)
class Plant:
    where: str  # "out" or "run"
    name: str
    kind: str

    @property
    def rel(self) -> str:
        return self.name if self.where == "out" else f"{NAME}.run/{self.name}"


@dataclass(frozen=True)
class Layout:
    phase: str
    plants: tuple[Plant, ...]

    @property
    def label(self) -> str:
        return f"{self.phase}: " + ", ".join(f"{p.kind}@{p.rel}" for p in self.plants)


def layouts(n_random: int = 120, seed: int = 26) -> list[Layout]:
    """Every single plant in every phase it applies to, then ``n_random`` layouts of 2 to 4
    plants."""
    singles = [Plant("out", n, k) for n in OUT_NAMES for k in KINDS] + \
        [Plant("run", n, k) for n in RUN_NAMES for k in KINDS]
    out = []
    for phase in PHASES:
        for p in singles:
            if p.where == "run" and phase == "run":
                continue  # a fresh run has no run folder: out/st.run plants cover it
            if p.where == "run" and p.name == "manifest.jsonl" and p.kind == "file":
                continue  # the run's own manifest, replaced by a user's file: not a layout
            out.append(Layout(phase, (p,)))
    rng = random.Random(seed)
    while n_random > 0:
        phase = rng.choice(PHASES)
        pool = [p for p in singles if not (p.where == "run" and phase == "run")]
        picked = rng.sample(pool, rng.randint(2, 4))
        if len({p.rel for p in picked}) != len(picked) or any(
                p.where == "run" for p in picked) and any(
                p.rel == f"{NAME}.run" for p in picked):
            continue  # one plant per name; the run folder itself is not also a plant
        out.append(Layout(phase, tuple(picked)))
        n_random -= 1
    return out


# ---------------------------------------------------------------------------- snapshots
def snapshot(top: Path, skip: Path | None = None) -> dict[str, tuple]:
    """Every entry under ``top`` (links not followed): type and bytes, or link target."""
    out: dict[str, tuple] = {}
    for dirpath, dirnames, filenames in os.walk(top, followlinks=False):
        d = Path(dirpath)
        if skip is not None and (d == skip or skip in d.parents):
            dirnames[:] = []
            continue
        for n in dirnames + filenames:
            p = d / n
            if skip is not None and p == skip:
                continue
            rel = str(p.relative_to(top))
            if p.is_symlink():
                out[rel] = ("link", os.readlink(p))
            elif p.is_dir():
                out[rel] = ("dir",)
            else:
                st = p.stat()
                out[rel] = ("file", hashlib.sha256(p.read_bytes()).hexdigest(), st.st_ino)
    return out


def _plant(base: Path, p: Plant, outside: Path) -> None:
    path = base / p.rel
    path.parent.mkdir(parents=True, exist_ok=True)
    if path.is_symlink() or path.is_file():
        path.unlink()
    elif path.is_dir():
        shutil.rmtree(path)
    if p.kind == "file":
        path.write_text(f"the user's {p.name}\n")
    elif p.kind == "folder":
        path.mkdir()
        (path / "keep.txt").write_text("the user's\n")
    elif p.kind == "link_file":
        path.symlink_to(outside / "victim.txt")
    elif p.kind == "link_folder":
        path.symlink_to(outside / "vdir", target_is_directory=True)
    elif p.kind == "link_absent":
        path.symlink_to(outside / "ghost")
    elif p.kind == "hardlink":
        os.link(outside / "victim.txt", path)


def _as_planted(base: Path, p: Plant, outside: Path) -> bool:
    path = base / p.rel
    if p.kind == "file":
        return path.is_file() and not path.is_symlink() and \
            path.read_bytes() == f"the user's {p.name}\n".encode()
    if p.kind == "folder":
        return path.is_dir() and not path.is_symlink() and (path / "keep.txt").is_file()
    if p.kind.startswith("link"):
        want = {"link_file": outside / "victim.txt", "link_folder": outside / "vdir",
                "link_absent": outside / "ghost"}[p.kind]
        return path.is_symlink() and Path(os.readlink(path)) == want
    return path.is_file() and path.stat().st_ino == (outside / "victim.txt").stat().st_ino


# ---------------------------------------------------------------------------- the states
@contextlib.contextmanager
def _armed(on: bool) -> Iterator[None]:
    old = os.environ.get("UQGUIDE_TEST_ARM_CTRL_C")
    os.environ["UQGUIDE_TEST_ARM_CTRL_C"] = "1" if on else "0"
    failing_models._calls["n"] = 0
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("UQGUIDE_TEST_ARM_CTRL_C", None)
        else:
            os.environ["UQGUIDE_TEST_ARM_CTRL_C"] = old


def _invoke(*args: str | Path):
    return CliRunner().invoke(main, [str(a) for a in args])


def templates(tmp: Path, cfg: Path) -> dict[str, Path]:
    """The run folders the resume and clean-up phases start from, made by real runs."""
    made = {}
    with _armed(True):
        res = _invoke("run", cfg, "--out", tmp / "t_resume", "-q")
    assert res.exit_code == 130, res.output
    made["resume"] = tmp / "t_resume" / f"{NAME}.run"
    from uqguide.commands import run_and_write as rw

    real = rw.write_hdf5

    def stopped(*a, **k):
        raise KeyboardInterrupt

    rw.write_hdf5 = stopped
    try:
        with _armed(False):
            res = _invoke("run", cfg, "--out", tmp / "t_cleanup", "-q")
    finally:
        rw.write_hdf5 = real
    assert res.exit_code == 130, res.output
    made["cleanup"] = tmp / "t_cleanup" / f"{NAME}.run"
    return made


@dataclass
class Outcome:
    layout: Layout
    exit_code: int
    escaped: list[str]
    lost: list[str]
    traceback: bool
    error: str = ""

    @property
    def verdict(self) -> str:
        if self.escaped:
            return "WRITE OUTSIDE --out"
        if self.lost:
            return "USER FILE LOST"
        if self.traceback or self.exit_code not in (0, 1, 2):
            return "CRASH"
        return "ok"


def try_layout(layout: Layout, tmp: Path, cfg: Path, made: dict[str, Path]) -> Outcome:
    box = tmp / "box"
    if box.exists():
        shutil.rmtree(box)
    outside, out = box / "outside", box / "out"
    (outside / "vdir").mkdir(parents=True)
    (outside / "victim.txt").write_text("outside, untouched\n")
    (outside / "vdir" / "f.txt").write_text("outside, untouched\n")
    out.mkdir()
    if layout.phase in made:
        shutil.copytree(made[layout.phase], out / f"{NAME}.run")
    for p in layout.plants:
        _plant(out, p, outside)
    before = snapshot(box, skip=out)
    with _armed(False):
        res = _invoke("run", cfg, "--out", out, "-q",
                      *(["--resume"] if layout.phase == "resume" else []))
    after = snapshot(box, skip=out)
    escaped = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    lost = [p.rel for p in layout.plants
            if not _as_planted(out, p, outside) and p.name not in (
                OWN if p.where == "out" else OWN_IN_RUN)]
    tb = res.exception is not None and not isinstance(res.exception, SystemExit)
    error = f"{type(res.exception).__name__}: {res.exception}"[:160] if tb else ""
    return Outcome(layout, res.exit_code, escaped, lost, tb, error)


def run_all(sample: int | None = None, seed: int = 26) -> list[Outcome]:
    """Every layout (or ``sample`` of them at random), each in a fresh sandbox."""
    all_layouts = layouts()
    if sample is not None:
        all_layouts = random.Random(seed).sample(all_layouts, sample)
    with tempfile.TemporaryDirectory() as t:
        tmp = Path(t)
        cfg = tmp / "st.yaml"
        cfg.write_text(yaml.safe_dump(CONFIG))
        made = templates(tmp, cfg)
        return [try_layout(lay, tmp, cfg, made) for lay in all_layouts]


def main_(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sample", type=int, default=None)
    args = ap.parse_args(argv)
    outcomes = run_all(args.sample)
    by = Counter((o.layout.phase, o.verdict, o.exit_code) for o in outcomes)
    print("| phase | verdict | exit | layouts |\n|---|---|---|---|")
    for (phase, verdict, code), n in sorted(by.items()):
        print(f"| {phase} | {verdict} | {code} | {n} |")
    bad = [o for o in outcomes if o.verdict != "ok"]
    for o in bad[:60]:
        print(f"  {o.verdict} (exit {o.exit_code}): {o.layout.label}: escaped {o.escaped}, "
              f"lost {o.lost}{': ' + o.error if o.error else ''}")
    print(f"\n{len(outcomes)} layouts: {sum(bool(o.escaped) for o in outcomes)} with a write "
          f"outside --out, {sum(bool(o.lost) for o in outcomes)} with a user file lost, "
          f"{sum(o.verdict == 'CRASH' for o in outcomes)} crashes")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main_())
