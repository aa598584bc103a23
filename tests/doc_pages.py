"""A docs page as its reader runs it: the files it writes, then its commands in order.

The blocks of ``README.md`` and ``docs/**/*.md``, their marks and the page runner of
``tests/test_doc_pages.py``; the conventions are docs/architecture.md's "Examples that run".
A block whose first line is a comment ``file: NAME`` (``# file:``, ``// file:``,
``/* file: ... */``, ``% file:``) is a file the page writes; its runnable blocks run one after
the other in one temporary folder; a ``<!-- example: output -->`` block right after a command
block is what that command prints, compared by ``compare`` (numbers by their intervals).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import uqguide

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_ROOT = Path(uqguide.__file__).resolve().parents[1]  # the checkout under test
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
RUNNABLE = {"bash", "sh", "console", "python"}
MARKS = ("", "slow", "output", "ci")
MARK = re.compile(r"<!--\s*example:\s*(\w+)\s*-->")
FENCE = re.compile(r"^(\s*)```(\S*)\s*$")
FILE_LINE = re.compile(r"^(?:#|//|/\*|%)\s*file:\s*(\S+?)(?::|\s*\*/)?(?:\s.*)?$")
# a page whose examples a test of its own runs, with more checks than that they exit 0
OWN_TEST = {ROOT / "docs" / "your-model.md": "tests/test_your_model_doc.py"}


@dataclass
class Block:
    page: Path
    line: int    # 1-based line of the opening fence
    lang: str
    body: str
    mark: str    # one of MARKS
    section: str = ""   # the heading it stands under

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"

    @property
    def file_name(self) -> str | None:
        first = self.body.splitlines()[0] if self.body.strip() else ""
        m = FILE_LINE.match(first)
        return m.group(1) if m else None

    @property
    def runs(self) -> bool:
        return self.lang in RUNNABLE and self.mark not in ("output", "ci")

    @property
    def script(self) -> str:
        """What runs: the body, or a ``console`` block's ``$ `` lines."""
        if self.lang != "console":
            return self.body
        return "\n".join(line[2:] for line in self.body.splitlines() if line.startswith("$ "))


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of ``page`` with their line, language and mark."""
    lines = page.read_text().splitlines()
    found: list[Block] = []
    section = ""
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            if lines[i].startswith("#"):
                section = lines[i].lstrip("#").strip()
            i += 1
            continue
        indent, lang = m.groups()
        j = i + 1
        while j < len(lines) and lines[j].strip() != "```":
            j += 1
        body = "\n".join(line[len(indent):] for line in lines[i + 1:j]) + "\n"
        k = i - 1
        while k >= 0 and not lines[k].strip():
            k -= 1
        mark = MARK.search(lines[k]) if k >= 0 else None
        found.append(Block(page, i + 1, lang, body, mark.group(1) if mark else "", section))
        i = j + 1
    return found


ALL = [b for page in PAGES for b in blocks(page)]


@dataclass
class Step:
    command: Block
    shown: Block | None   # the output the page shows for it


def steps(page: Path) -> list[Step]:
    """The page's commands in order, each with the output block that directly follows it."""
    found: list[Step] = []
    previous: Block | None = None
    for b in blocks(page):
        if b.runs:
            found.append(Step(b, None))
        elif b.mark == "output" and previous is not None and previous.runs:
            found[-1].shown = b
        previous = b
    return found


def env() -> dict[str, str]:
    """A reader's shell: ``uqguide`` and ``python`` are this interpreter's, importing the
    package under test; output unbuffered so that stdout and stderr interleave as printed."""
    e = dict(os.environ)
    e["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{e.get('PATH', '')}"
    e["PYTHONPATH"] = str(PACKAGE_ROOT)
    e["MPLBACKEND"] = "Agg"
    e["PYTHONUNBUFFERED"] = "1"
    return e


def prepare(folder: Path, page: Path) -> None:
    """``folder`` as a fresh clone holds it for the page: ``configs/``, the committed results
    (linked file by file, so what an example writes under results/ lands in ``folder``) and
    the files the page writes."""
    (folder / "configs").symlink_to(ROOT / "configs", target_is_directory=True)
    for f in (ROOT / "results").rglob("*"):
        # results/runs/ is uqguide run's default --out (not committed; .ci/run writes there
        # first): linked in, a run's own result would be a link it rightly refuses to replace
        if f.is_file() and "runs" not in f.relative_to(ROOT / "results").parts[:1]:
            link = folder / f.relative_to(ROOT)
            link.parent.mkdir(parents=True, exist_ok=True)
            link.symlink_to(f)
    for b in blocks(page):
        if b.file_name:
            (folder / b.file_name).parent.mkdir(parents=True, exist_ok=True)
            (folder / b.file_name).write_text(b.body)


def run(block: Block, folder: Path) -> subprocess.CompletedProcess:
    """``block`` run in ``folder``: shell blocks with ``bash -e``, Python blocks as scripts;
    stderr merged into stdout, as a terminal shows them."""
    if block.lang == "python":
        script = folder / (block.file_name or "example.py")
        script.parent.mkdir(parents=True, exist_ok=True)
        script.write_text(block.body)
        cmd = [sys.executable, str(script.relative_to(folder))]
    else:
        (folder / "example.sh").write_text(block.script)
        cmd = ["bash", "-e", "example.sh"]
    return subprocess.run(cmd, cwd=folder, env=env(), stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=900)


def check(step: Step, folder: Path) -> list[str]:
    """Runs the step's command; what went wrong, each naming the page and line."""
    p = run(step.command, folder)
    if p.returncode != 0:
        return [f"{step.command.where}: the example exits {p.returncode}\n"
                f"--- its output (tail)\n{p.stdout[-4000:]}"]
    if step.shown is None:
        return []
    return [f"{step.shown.where}: {m}" for m in compare(step.shown.body, p.stdout)]


# ------------------------------------------------------------------ shown against printed
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
NUM = re.compile(rf"(?<![\w.]){NUMBER}(?![\w.])")
# an estimate and its printed interval: "1.209 [1.194, 1.224]", a floor "3.8 [>= 2.68]"
INTERVAL = re.compile(rf"({NUMBER}) \[(?:({NUMBER}), ({NUMBER})|(>=|<=) ({NUMBER}))\]")


def _skeleton(line: str) -> str:
    return " ".join(NUM.sub("#", line).split())


def _intervals(line: str) -> list[tuple[float, float, float]]:
    """(estimate, low, high) of each interval on ``line`` (a floor's high is +inf)."""
    found = []
    for m in INTERVAL.finditer(" ".join(line.split())):
        v = float(m.group(1))
        if m.group(4) == ">=":
            found.append((v, float(m.group(5)), float("inf")))
        elif m.group(4) == "<=":
            found.append((v, float("-inf"), float(m.group(5))))
        else:
            found.append((v, float(m.group(2)), float(m.group(3))))
    return found


def line_matches(shown: str, printed: str) -> bool:
    """Equal text, up to the spacing of columns; on a line that prints intervals its numbers
    instead agree as estimates: each estimate lies in the other's interval (a statistic the
    page shows is then one this code still gives, within its own uncertainty). Other numbers
    on such a line (shares, differences) follow from those and are not compared again."""
    if _skeleton(shown) != _skeleton(printed):
        return False
    a, b = _intervals(shown), _intervals(printed)
    if not a:
        return " ".join(shown.split()) == " ".join(printed.split())
    return len(a) == len(b) and all(lo2 <= v1 <= hi2 and lo1 <= v2 <= hi1
                                    for (v1, lo1, hi1), (v2, lo2, hi2) in zip(a, b))


def compare(shown: str, printed: str) -> list[str]:
    """Each line the page shows is, in order, a line of what the command printed (a ``...``
    line stands for lines the page leaves out); a line that is not, named with the printed
    line of the same shape, if any."""
    lines = [line for line in printed.splitlines() if line.strip()]
    at = 0
    for want in shown.splitlines():
        if not want.strip() or want.strip() == "...":
            continue
        hit = next((i for i in range(at, len(lines)) if line_matches(want, lines[i])), None)
        if hit is None:
            alike = [g for g in lines[at:] if _skeleton(g) == _skeleton(want)]
            got = f"it printed `{alike[0].strip()}`" if alike else \
                "it printed no line of that shape"
            return [f"the page shows `{want.strip()}`, {got}\n--- printed\n{printed[-4000:]}"]
        at = hit + 1
    return []
