"""``uqguide simulate`` of the shipped studies fits a 160-column terminal: the paper's table
and its footnotes (the robust statistics of chaotic rows, the notes) wrapped to the console."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.config.catalog import resolve
from uqguide.report.tables import CONSOLE_WIDTH


def _widest(study: str) -> tuple[int, str]:
    res = CliRunner().invoke(main, ["simulate", str(resolve(study))])
    assert res.exit_code == 0, res.output
    return max((len(line), line) for line in res.output.splitlines())


@pytest.mark.parametrize("study", [
    "ftcapn_nominal",       # notes of up to 164 characters before
    "gmm_ftc_nominal",      # notes of up to 188
    pytest.param("ft_as_nominal", marks=pytest.mark.slow),  # ~23 CPU-s; footnotes up to 207
])
def test_simulate_prints_no_line_wider_than_the_console(study):
    width, line = _widest(study)
    assert width <= CONSOLE_WIDTH, line
