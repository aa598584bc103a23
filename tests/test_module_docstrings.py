"""Module docstrings stay short, and uqguide/ points only at what the repository holds.

A module docstring says what the module is for, where to change its behaviour and which docs/
page explains it, in at most 15 lines; derivations, measured figures and references live in the
docs/ pages. Nothing in the package may send a reader to a file or an issue thread they cannot
open: the specifications the simulators were built from and the issue tracker are not shipped,
so what the code relies on of them is written into docs/ and linked as ``docs/<page>.md#<anchor>``.
"""

from __future__ import annotations

import re
import tokenize
import unicodedata
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "uqguide"
DOCS = ROOT / "docs"
_LAYOUT = (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.ENCODING)

MAX_LINES = 15

# References a reader of the repository cannot follow: the specifications by file name, and
# issue numbers ("issue 27", "issues 3", "#45"; a quoted colour such as "#1f77b4" is not one).
OUTSIDE = re.compile(
    r"\b(?:uq-methods|gmm-controllers|ftcapn|ft-as-controller)\.md\b"
    r"|\bissues? \d+"
    r"|(?<![\w\"'#&])#\d+\b",
    re.IGNORECASE,
)

# A link into the documentation: a page, optionally with an anchor.
DOCS_LINK = re.compile(r"docs/([\w-]+\.md)(?:#([\w-]+))?")

# Modules that other work on the package is rewriting now: exempt from both checks until that
# rewrite lands. This list only shrinks and must go to empty: a module leaves it as soon as it
# passes (test_the_allow_list_only_holds_modules_that_still_need_it fails until it is
# removed), and nothing is ever added to it.
NOT_YET: frozenset[str] = frozenset()


def modules() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def name(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


def docstring_lines(path: Path) -> int:
    """Lines of the module docstring, quotes included (0 without one): the first token that is
    not a comment or a blank line, when it is a string that stands alone as a statement."""
    with path.open(encoding="utf-8") as f:
        tokens = tokenize.generate_tokens(f.readline)
        first = next(t for t in tokens if t.type not in _LAYOUT)
        if first.type != tokenize.STRING:
            return 0
        after = next(t for t in tokens if t.type not in (tokenize.COMMENT, tokenize.NL))
    # a string followed by an operator ("..." + x, "...".join) is an expression, not a docstring
    return first.end[0] - first.start[0] + 1 if after.type != tokenize.OP else 0


def outside_references(path: Path) -> list[str]:
    text = path.read_text(encoding="utf-8")
    return [f"{name(path)}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)!r}"
            for m in OUTSIDE.finditer(text)]


def slug(heading: str) -> str:
    """The anchor mkdocs (Python-Markdown's toc) gives a heading."""
    text = unicodedata.normalize("NFKD", heading.replace("`", ""))
    text = re.sub(r"[^\w\s-]", "", text.encode("ascii", "ignore").decode("ascii")).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def anchors(page: Path) -> set[str]:
    found, fenced = set(), False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            fenced = not fenced
        elif not fenced and re.match(r"#{1,6} ", line):
            found.add(slug(line.lstrip("#").strip()))
    return found


def test_module_docstrings_are_at_most_15_lines():
    long = [f"{name(p)}: {n} lines" for p in modules()
            if name(p) not in NOT_YET and (n := docstring_lines(p)) > MAX_LINES]
    assert not long, ("module docstrings over 15 lines (what the module is for, where to change "
                      "it, a docs/ link; derivations and figures go to docs/):\n" + "\n".join(long))


def test_no_reference_to_files_or_issues_outside_the_repository():
    found = [r for p in modules() if name(p) not in NOT_YET for r in outside_references(p)]
    assert not found, ("references a reader cannot follow; link the docs/ section that holds the "
                       "content instead:\n" + "\n".join(found))


def test_links_into_the_docs_resolve():
    pages: dict[str, set[str]] = {}
    broken = []
    for p in modules():
        for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1):
            for m in DOCS_LINK.finditer(line):
                page, anchor = m.group(1), m.group(2)
                if page not in pages:
                    pages[page] = anchors(DOCS / page) if (DOCS / page).is_file() else set()
                if not (DOCS / page).is_file():
                    broken.append(f"{name(p)}:{i}: no page docs/{page}")
                elif anchor is not None and anchor not in pages[page]:
                    broken.append(f"{name(p)}:{i}: no heading with anchor #{anchor} in docs/{page}")
    assert not broken, "\n".join(broken)


def test_the_allow_list_only_holds_modules_that_still_need_it():
    done = []
    for entry in sorted(NOT_YET):
        path = ROOT / entry
        if not path.is_file():
            done.append(f"{entry}: gone")
        elif docstring_lines(path) <= MAX_LINES and not outside_references(path):
            done.append(f"{entry}: passes now")
    assert not done, "remove from NOT_YET (it only shrinks):\n" + "\n".join(done)


def test_the_line_count_is_the_docstring_s(tmp_path):
    cases = {'"""One line."""\n': 1, '# c\n\n"""a\n\nb\n"""\nx = 1\n': 4,
             'x = 1\n"""not a docstring"""\n': 0, '"a" + "b"\n': 0, "": 0}
    for i, (text, lines) in enumerate(cases.items()):
        (tmp_path / f"m{i}.py").write_text(text)
        assert docstring_lines(tmp_path / f"m{i}.py") == lines, text


def test_the_checks_catch_what_they_are_for():
    assert OUTSIDE.search("see gmm-controllers.md section 4")
    assert OUTSIDE.search("(issue 27, item 4)") and OUTSIDE.search("as #45 asks")
    assert not OUTSIDE.search('_COLOURS = ["#1f77b4", "#123456"]')
    assert not OUTSIDE.search("docs/papers.md#the-gmm-papers-ambiguities-as-settled")
    assert slug("Checkpoints and `--resume`") == "checkpoints-and-resume"
    assert slug("The GMM papers' ambiguities, as settled") == (
        "the-gmm-papers-ambiguities-as-settled")
