"""The marks of the blocks of README.md and docs/**/*.md, and README's links.

The examples themselves run page by page, as read (``tests/test_doc_pages.py``, with the
conventions of ``tests/doc_pages.py``). An HTML comment on the line before a block says how it
is treated:

- ``<!-- example: slow -->``: runs only under ``pytest -m slow``;
- ``<!-- example: output -->``: output pasted from a run, not a command (or use ```text);
  right after a command block, what that command prints, compared with it;
- ``<!-- example: ci -->``: the install and test commands, which ``.ci/run`` runs itself;
  here they are only checked to appear in ``.ci/run`` word for word.
"""

from __future__ import annotations

import re

from tests.doc_pages import ALL, MARKS, OWN_TEST, ROOT

EXAMPLES = [b for b in ALL if b.runs and b.page not in OWN_TEST]


def test_the_pages_have_examples_and_every_mark_is_known():
    assert len(EXAMPLES) >= 8
    for page, test in OWN_TEST.items():
        assert (ROOT / test).read_text().count(page.name), f"{test} runs {page.name}"
    for b in ALL:
        assert b.mark in MARKS, f"{b.where}: unknown mark {b.mark!r}"
        assert b.lang != "console" or b.mark or b.script.strip(), \
            f"{b.where}: a ```console block runs its `$ ` lines and has none"


def test_the_ci_marked_commands_are_what_ci_runs():
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    marked = [b for b in ALL if b.mark == "ci"]
    assert marked, "README.md's install and test commands are marked <!-- example: ci -->"
    for b in marked:
        for line in b.script.splitlines():
            if line.strip() and not line.startswith("#"):
                assert line.strip() in (c.strip() for c in ci), \
                    f"{b.where}: `{line.strip()}` is not a line of .ci/run"


def test_the_readme_links_to_files_that_exist():
    """mkdocs checks the links between the docs pages; README.md is outside the site."""
    text = (ROOT / "README.md").read_text()
    targets = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text)
    local = [t for t in targets if "://" not in t]
    assert local, "README.md links to its docs pages"
    for t in local:
        assert (ROOT / t).exists(), f"README.md links to {t}, which does not exist"
