"""The shipped studies: listed, found by name from any folder, copied out."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from uqguide.config.catalog import resolve, studies
from uqguide.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "uqguide.cli", *args], cwd=cwd,
                          capture_output=True, text=True)


def test_every_config_of_the_checkout_is_a_shipped_study_with_a_description():
    shipped = {s.name: s for s in studies()}
    assert sorted(shipped) == sorted(p.stem for p in (ROOT / "configs").glob("*.yaml"))
    for s in shipped.values():
        assert s.description and ("paper" in s.description or "Table" in s.description), s.name


def test_configs_lists_one_line_per_study(tmp_path):
    out = _cli("configs", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert [ln.split()[0] for ln in lines] == [s.name for s in studies()]
    table3 = next(ln for ln in lines if ln.startswith("ftcapn_table3 "))
    assert "Table 3" in table3


def test_a_bare_name_is_a_shipped_study_from_any_folder(tmp_path):
    out = _cli("validate", "ftcapn_table3", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("ftcapn_table3: OK — model ftcapn, 7 uncertain inputs")


def test_a_file_wins_over_a_study_and_a_missing_path_names_the_study(tmp_path):
    mine = tmp_path / "ftcapn_table3"
    mine.write_text("model: {name: ishigami}\nmethods: [{name: monte_carlo, n_samples: 10}]\n")
    assert resolve(mine) == mine
    with pytest.raises(ConfigError, match=r"configs/ftcapn_table3.yaml: config file not found "
                                          r"\(a shipped study has that name: `uqguide run "
                                          r"ftcapn_table3`\)"):
        resolve(tmp_path / "configs" / "ftcapn_table3.yaml")


@pytest.mark.slow
def test_an_unknown_name_exits_2_with_a_suggestion(tmp_path):
    out = _cli("run", "ftcapn_tabel3", cwd=tmp_path)
    assert out.returncode == 2
    assert out.stderr.strip() == (
        "error: CONFIG: 'ftcapn_tabel3' is neither a config file nor a shipped study (did you "
        "mean 'ftcapn_table3'?); `uqguide configs` lists the shipped studies")
    assert "Traceback" not in out.stderr


def test_copy_writes_the_study_and_refuses_to_overwrite(tmp_path):
    out = _cli("configs", "--copy", "ftcapn_table5", "edit", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    copied = tmp_path / "edit" / "ftcapn_table5.yaml"
    assert copied.read_bytes() == (ROOT / "configs" / "ftcapn_table5.yaml").read_bytes()
    again = _cli("configs", "--copy", "ftcapn_table5", "edit", cwd=tmp_path)
    assert again.returncode == 2 and "exists already" in again.stderr
