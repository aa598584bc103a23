"""Every page of README.md and docs/ runs as its reader runs it (``tests/doc_pages.py``).

Per page, in one temporary folder: the files it writes, then its commands in order, each
shown output compared with what its command prints. The default suite runs a page's commands
that are not marked slow; ``-m slow`` runs the whole page. The newcomer's path (README's
install, then docs/your-simulator.md's C example, its error budget printed and plotted) is
one slow test.
"""

from __future__ import annotations

import shutil

import pytest

from tests.doc_pages import ALL, OWN_TEST, PAGES, ROOT, Block, Step, check, compare, \
    line_matches, prepare, run, steps

RUN_PAGES = [p for p in PAGES if p not in OWN_TEST and steps(p)]


def _params(slow: bool) -> list:
    """One test per page: its cheap commands in the default suite, all of them with -m slow."""
    found = []
    for page in RUN_PAGES:
        marks = [s.command.mark for s in steps(page)]
        if slow and "slow" in marks:
            found.append(pytest.param(page, id=str(page.relative_to(ROOT)),
                                      marks=[pytest.mark.slow]))
        elif not slow and "" in marks:
            found.append(pytest.param(page, id=str(page.relative_to(ROOT))))
    return found


def _run_page(page, folder, slow: bool) -> None:
    prepare(folder, page)
    for step in steps(page):
        if slow or step.command.mark != "slow":
            problems = check(step, folder)
            assert not problems, "\n".join(problems)


@pytest.mark.parametrize("page", _params(slow=False))
def test_the_page_runs_as_read(page, tmp_path):
    _run_page(page, tmp_path, slow=False)


@pytest.mark.parametrize("page", _params(slow=True))
def test_the_whole_page_runs_as_read(page, tmp_path):
    _run_page(page, tmp_path, slow=True)


def test_the_pages_name_their_files_and_the_examples_the_issue_names():
    """The C, CSV, data: and multi-fidelity examples are files their page writes and then runs
    (a file written by no command of its page would be checked by nothing here)."""
    names = {(b.page.name, b.file_name) for b in ALL if b.file_name}
    for page, name in [("your-simulator.md", "mysim.c"), ("your-simulator.md", "sim.yaml"),
                       ("your-simulator.md", "make_runs.py"), ("your-simulator.md",
                                                               "samples.yaml"),
                       ("multifidelity.md", "mfmc_decay.yaml"),
                       ("multifidelity.md", "mfmc_command.yaml")]:
        assert (page, name) in names, f"docs/{page} writes {name} (a `file: {name}` block)"
        used = " ".join(s.command.script for s in steps(ROOT / "docs" / page))
        assert name in used or name.rsplit(".", 1)[0] in used, \
            f"docs/{page}: no command of the page uses {name}"
    shown = [s for p in RUN_PAGES for s in steps(p) if s.shown]
    assert len(shown) >= 6, [s.command.where for s in shown]


@pytest.mark.parametrize("shown,printed,same", [
    # an estimate inside the other's interval, each way, columns spaced otherwise: the same
    ("   mc 1.284 [1.274, 1.294] 5.493 [>= 4.184]", "mc  1.29 [1.28, 1.30] 5.2 [>= 4.1]", True),
    # the shown estimate outside the printed interval
    ("mc 1.284 [1.274, 1.294]", "mc 1.31 [1.30, 1.32]", False),
    # the printed estimate outside the shown interval (a narrow printed interval holding it)
    ("mc 1.284 [1.283, 1.285]", "mc 1.29 [1.27, 1.31]", False),
    # a floor: the shown estimate below the printed floor
    ("mc 3.8 [>= 2.68]", "mc 4.1 [>= 3.9]", False),
    # a line without intervals: equal text up to spacing
    ("  shares sum to 99.5% of y", "shares sum to   99.5% of y", True),
    ("  shares sum to 99.5% of y", "shares sum to 99.6% of y", False),
    # another word is another line
    ("mc 1.284 [1.274, 1.294]", "mc2 1.284 [1.274, 1.294]", False),
])
def test_a_shown_line_matches_a_printed_one_by_its_intervals_or_its_text(shown, printed, same):
    assert line_matches(shown, printed) is same


def test_the_shown_lines_come_in_order_and_a_missing_one_is_named():
    printed = "a 1\nb 2\nc 3\n"
    assert compare("a 1\n...\nc 3\n", printed) == []
    assert compare("c 3\na 1\n", printed)  # out of order
    (message,) = compare("b 5\n", printed)
    assert message.startswith("the page shows `b 5`, it printed `b 2`")


def test_a_command_that_fails_is_named_with_its_page_and_line(tmp_path):
    block = Block(ROOT / "README.md", 7, "bash", "echo so far\nfalse\necho never\n", "")
    (problem,) = check(Step(block, None), tmp_path)
    assert problem.startswith("README.md:7: the example exits 1") and "never" not in problem


# --------------------------------------------------------------------- the newcomer's path
@pytest.mark.slow
def test_a_newcomers_path_from_the_readme_to_a_plotted_error_budget_of_a_c_simulator(
        tmp_path):
    """README's install line is .ci/run's (a fresh venv is .ci/run's own first step; here the
    current install stands for it) and the rest of that line runs as written; then
    docs/your-simulator.md's C example as the page writes it: its config and program, then
    its commands (compile, run, plot), the shown output compared. No step edited."""
    if shutil.which("cc") is None:
        pytest.skip("no C compiler `cc` on PATH: docs/your-simulator.md's C example needs one")
    (install,) = [b for b in ALL if b.page.name == "README.md" and b.mark == "ci"
                  and "pip install" in b.script]
    ci = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()]
    line = install.script.strip()
    assert line in ci, f"{install.where}: README's install line is not a line of .ci/run"
    first_run = [p.strip() for p in line.split("pip install", 1)[1].split("&&")[1:]]
    assert first_run == ["uqguide run configs/ftcapn_table3.yaml"], first_run

    readme = Block(install.page, install.line, "bash", "\n".join(first_run) + "\n", "")
    page = ROOT / "docs" / "your-simulator.md"
    prepare(tmp_path, page)
    p = run(readme, tmp_path)
    assert p.returncode == 0, p.stdout[-3000:]
    assert (tmp_path / "results" / "runs" / "ftcapn_table3.h5").is_file()

    c_example = [s for s in steps(page) if s.command.section == "3. A program in C"]
    assert len(c_example) == 1 and c_example[0].shown is not None, c_example
    script = c_example[0].command.script
    assert "cc " in script and "uqguide run sim.yaml" in script and "uqguide plot" in script
    problems = check(c_example[0], tmp_path)
    assert not problems, "\n".join(problems)
    figures = tmp_path / "out" / "figures"
    assert (figures / "sim_path_budget.png").stat().st_size > 10_000
    assert (figures / "sim_y_hist.png").is_file()
