"""Every example in README.md and docs/**/*.md runs.

A fenced block in ``bash``, ``sh``, ``console`` or ``python`` is an example. Each runs in a
fresh temporary folder holding a link to the checkout's ``configs/``, links to each file of its
``results/`` (in folders of the temporary one, so nothing is written into the checkout) and the
page's ``# file: NAME`` blocks (a block whose first line is ``# file: NAME`` is also written
there as NAME, so a later command can use it). Shell blocks run with ``bash -e`` (a ``console``
block: its ``$ `` lines), Python blocks as scripts. ``uqguide`` and ``python`` are this
interpreter's, importing the package under test.

``docs/your-model.md`` is left to ``tests/test_your_model_doc.py``, which runs its blocks
with closer checks. An HTML comment on the line before a block says how it is treated:

- ``<!-- example: slow -->``: runs only under ``pytest -m slow``;
- ``<!-- example: output -->``: output pasted from a run, not a command (or use ```text);
- ``<!-- example: ci -->``: the install and test commands, which ``.ci/run`` runs itself;
  here they are only checked to appear in ``.ci/run`` word for word.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

import uqguide

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_ROOT = Path(uqguide.__file__).resolve().parents[1]  # the checkout under test
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
RUNNABLE = {"bash", "sh", "console", "python"}
MARK = re.compile(r"<!--\s*example:\s*(\w+)\s*-->")
FENCE = re.compile(r"^(\s*)```(\S*)\s*$")


@dataclass
class Block:
    page: Path
    line: int    # 1-based line of the opening fence
    lang: str
    body: str
    mark: str    # "", "slow", "output" or "ci"

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"

    @property
    def file_name(self) -> str | None:
        first = self.body.splitlines()[0] if self.body.strip() else ""
        return first[len("# file: "):].strip() if first.startswith("# file: ") else None


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of ``page`` with their line, language and mark."""
    lines = page.read_text().splitlines()
    found: list[Block] = []
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
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
        found.append(Block(page, i + 1, lang, body, mark.group(1) if mark else ""))
        i = j + 1
    return found


ALL = [b for page in PAGES for b in blocks(page)]
# pages whose examples a test of their own runs, with more checks than that they exit 0
OWN_TEST = {ROOT / "docs" / "your-model.md": "tests/test_your_model_doc.py"}
EXAMPLES = [b for b in ALL if b.lang in RUNNABLE and b.mark not in ("output", "ci")
            and b.page not in OWN_TEST]


def _params() -> list:
    return [pytest.param(b, id=b.where, marks=[pytest.mark.slow] if b.mark == "slow" else [])
            for b in EXAMPLES]


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = str(PACKAGE_ROOT)
    env["MPLBACKEND"] = "Agg"
    return env


def _script(block: Block) -> str:
    if block.lang != "console":
        return block.body
    return "\n".join(line[2:] for line in block.body.splitlines() if line.startswith("$ "))


def _folder(tmp: Path, block: Block) -> None:
    (tmp / "configs").symlink_to(ROOT / "configs", target_is_directory=True)
    # the committed results, file by file in folders of the temporary one: what an example
    # writes under results/ lands there, never in the checkout
    for f in (ROOT / "results").rglob("*"):
        # results/runs/ is uqguide run's default --out (not committed; .ci/run writes there
        # first): linked in, a run's own result would be a link it rightly refuses to replace
        if f.is_file() and "runs" not in f.relative_to(ROOT / "results").parts[:1]:
            link = tmp / f.relative_to(ROOT)
            link.parent.mkdir(parents=True, exist_ok=True)
            link.symlink_to(f)
    for other in ALL:
        if other.page == block.page and other.file_name:
            (tmp / other.file_name).parent.mkdir(parents=True, exist_ok=True)
            (tmp / other.file_name).write_text(other.body)


def test_the_pages_have_examples_and_every_mark_is_known():
    assert len(EXAMPLES) >= 8
    for page, test in OWN_TEST.items():
        assert (ROOT / test).read_text().count(page.name), f"{test} runs {page.name}"
    for b in ALL:
        assert b.mark in ("", "slow", "output", "ci"), f"{b.where}: unknown mark {b.mark!r}"
        assert b.lang != "console" or b.mark or _script(b).strip(), \
            f"{b.where}: a ```console block runs its `$ ` lines and has none"


def test_the_ci_marked_commands_are_what_ci_runs():
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    marked = [b for b in ALL if b.mark == "ci"]
    assert marked, "README.md's install and test commands are marked <!-- example: ci -->"
    for b in marked:
        for line in _script(b).splitlines():
            if line.strip() and not line.startswith("#"):
                assert line.strip() in (c.strip() for c in ci), \
                    f"{b.where}: `{line.strip()}` is not a line of .ci/run"


@pytest.mark.parametrize("block", _params())
def test_example_runs(block, tmp_path):
    _folder(tmp_path, block)
    if block.lang == "python":
        script = tmp_path / (block.file_name or "example.py")
        script.parent.mkdir(parents=True, exist_ok=True)
        script.write_text(block.body)
        cmd = [sys.executable, str(script.relative_to(tmp_path))]
    else:
        script = tmp_path / "example.sh"
        script.write_text(_script(block))
        cmd = ["bash", "-e", script.name]
    p = subprocess.run(cmd, cwd=tmp_path, env=_env(), capture_output=True, text=True,
                       timeout=900)
    assert p.returncode == 0, (f"{block.where}: the example exits {p.returncode}\n"
                               f"--- stdout (tail)\n{p.stdout[-3000:]}\n"
                               f"--- stderr (tail)\n{p.stderr[-3000:]}")


def test_the_readme_links_to_files_that_exist():
    """mkdocs checks the links between the docs pages; README.md is outside the site."""
    text = (ROOT / "README.md").read_text()
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    local = [t for t in targets if "://" not in t]
    assert local, "README.md links to its docs pages"
    for t in local:
        assert (ROOT / t).exists(), f"README.md links to {t}, which does not exist"
