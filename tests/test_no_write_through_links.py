"""No file is written through a symbolic link: a link where the lock, the run folder or the
result goes is refused with exit 2, naming it, and its target is neither created nor changed.

Before, a link at ``<out>/<name>.run.lock`` made ``uqguide run`` truncate and write the file it
pointed to, anywhere on the machine, and create a missing target.
"""

from __future__ import annotations


import pytest
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.core import atomic
from uqguide.driver.run_folder import RunLock
from uqguide.errors import ConfigError

PRECIOUS = "the user's own file\n"


@pytest.fixture
def outside(tmp_path):
    """A folder beside --out standing for 'anywhere else on the machine'."""
    d = tmp_path / "elsewhere"
    d.mkdir()
    (d / "precious.txt").write_text(PRECIOUS)
    return d


def _run(config, out):
    return CliRunner().invoke(main, ["run", str(config), "--out", str(out)])


def _assert_refused(res, link):
    assert res.exit_code == 2, res.output
    assert str(link) in res.output and "symbolic link" in res.output
    assert "Traceback" not in res.output


@pytest.mark.parametrize("target_exists", [True, False], ids=["existing", "missing"])
def test_a_link_at_the_lock_is_refused_and_its_target_untouched(
        write_config, lognormal_config, tmp_path, outside, target_exists):
    out = tmp_path / "out"
    out.mkdir()
    target = outside / ("precious.txt" if target_exists else "created.txt")
    link = out / "config.run.lock"
    link.symlink_to(target)
    _assert_refused(_run(write_config(lognormal_config), out), link)
    if target_exists:
        assert target.read_text() == PRECIOUS
    else:
        assert not target.exists()
    assert sorted(p.name for p in out.iterdir()) == ["config.run.lock"]


def test_a_link_at_the_run_folder_is_refused(write_config, lognormal_config, tmp_path, outside):
    out = tmp_path / "out"
    out.mkdir()
    link = out / "config.run"
    link.symlink_to(outside, target_is_directory=True)
    _assert_refused(_run(write_config(lognormal_config), out), link)
    assert sorted(p.name for p in outside.iterdir()) == ["precious.txt"]


def test_a_link_at_the_result_is_refused_before_the_run(write_config, lognormal_config, tmp_path,
                                                        outside):
    out = tmp_path / "out"
    out.mkdir()
    link = out / "config.h5"
    link.symlink_to(outside / "precious.txt")
    _assert_refused(_run(write_config(lognormal_config), out), link)
    assert (outside / "precious.txt").read_text() == PRECIOUS
    assert not (out / "config.run").exists()


def test_the_lock_itself_refuses_a_link(tmp_path, outside):
    (tmp_path / "r.run.lock").symlink_to(outside / "new.txt")
    with pytest.raises(ConfigError, match="symbolic link"):
        RunLock(tmp_path / "r.run").acquire()
    assert not (outside / "new.txt").exists()


def test_an_atomic_write_refuses_a_link_at_the_final_name(tmp_path, outside):
    link = tmp_path / "table.csv"
    link.symlink_to(outside / "precious.txt")
    with pytest.raises(ConfigError, match="symbolic link"):
        atomic.write_text(link, "a,b\n")
    assert link.is_symlink() and (outside / "precious.txt").read_text() == PRECIOUS


def test_a_link_planted_at_the_temporary_name_does_not_redirect_the_write(tmp_path, outside,
                                                                          monkeypatch):
    """The temporary name is random; were it guessed, the link there is left alone and
    another name taken."""
    final = tmp_path / "table.csv"
    tokens = iter(["0badc0de", "0badc0de", "5eed5eed"])
    monkeypatch.setattr(atomic.secrets, "token_hex", lambda n: next(tokens))
    planted = atomic.temp_path(final)  # the name the first write will try
    planted.symlink_to(outside / "precious.txt")
    atomic.write_text(final, "a,b\n")
    assert final.read_text() == "a,b\n" and not final.is_symlink()
    assert (outside / "precious.txt").read_text() == PRECIOUS
    assert planted.is_symlink()  # not ours: never deleted
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([planted.name, "table.csv",
                                                                "elsewhere"])
