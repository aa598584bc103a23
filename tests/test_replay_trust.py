"""A result file names its model, and a callable, command or fmu model is code: `uqguide
replay` says what it would run and runs it only with --run-code, or when the user's own config
names the same model; a built-in simulator needs neither."""

from __future__ import annotations

import sys
import uuid
from pathlib import Path
from types import SimpleNamespace

import pytest
import yaml
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.commands.replay import allowed_code, named_code, replay
from uqguide.config.run_config import load_config
from uqguide.driver.propagate import run
from uqguide.errors import ConfigError
from uqguide.results.result import write_hdf5

from .failing_models import mc_config

#: A module whose import leaves a mark: the proof that a refused replay imported nothing.
SENT = """
import os
open(os.environ["UQGUIDE_TEST_IMPORTED"], "a").write(__name__ + "\\n")

def f(x):
    return x[:, 0] + x[:, 1]
"""


@pytest.fixture
def study(tmp_path, monkeypatch):
    """A callable study of the user's own module, its config file and its result; and a module
    of someone else's beside it (``sent``), never imported yet."""
    tag = uuid.uuid4().hex[:8]
    mine, sent = f"mine_{tag}", f"sent_{tag}"
    (tmp_path / f"{mine}.py").write_text("def f(x):\n    return x[:, 0] + x[:, 1]\n")
    (tmp_path / f"{sent}.py").write_text(SENT)
    marks = tmp_path / "imported.txt"
    monkeypatch.setenv("UQGUIDE_TEST_IMPORTED", str(marks))
    raw = mc_config(f"{mine}:f", 40, 20, name="study")
    raw["model"]["isolate"] = False  # (how it runs, not which code: not compared)
    cfg = tmp_path / "study.yaml"
    cfg.write_text(yaml.safe_dump(raw))
    result = run(load_config(cfg))
    yield SimpleNamespace(path=tmp_path, cfg=cfg, raw=raw, result=result, mine=mine, sent=sent,
                          marks=marks)
    for m in (mine, sent):
        sys.modules.pop(m, None)


def _sent_result(study, **model) -> Path:
    """The study's result as someone else would send it: its config names other code."""
    study.result.config["model"].update(model or {"function": f"{study.sent}:f"})
    return write_hdf5(study.result, study.path / "sent.h5")


def _replay(h5: Path, *args: str):
    return CliRunner().invoke(main, ["replay", str(h5), "--label", "mc", "--sample", "3",
                                     "--out", str(h5.parent / "rp"), *args])


def test_a_result_naming_code_is_refused_with_one_line_and_nothing_imported(study):
    h5 = _sent_result(study)
    res = _replay(h5)
    assert res.exit_code == 2
    assert res.stderr.splitlines() == [
        f"error: {h5}: its replay would run the Python function '{study.sent}:f' from the "
        f"folder '{study.path}', as the file names it; a result file can name any code: pass "
        f"--run-code to run it, or --config with your own config of this model"]
    assert res.stdout == ""
    assert not study.marks.exists() and study.sent not in sys.modules
    assert not (study.path / "rp").exists()


def test_run_code_says_what_it_runs_and_runs_it(study):
    h5 = _sent_result(study)
    res = _replay(h5, "--run-code")
    assert res.exit_code == 0, res.output
    assert res.stderr.splitlines()[0] == (f"replay runs the Python function '{study.sent}:f' "
                                          f"from the folder '{study.path}'")
    assert "replayed scalars equal the stored ones bit for bit" in res.stdout
    assert study.marks.read_text() == f"{study.sent}\n"


def test_your_own_config_of_the_same_model_runs_without_the_flag(study):
    h5 = write_hdf5(study.result, study.path / "mine.h5")
    res = _replay(h5, "--config", str(study.cfg))
    assert res.exit_code == 0, res.output
    assert res.stderr.splitlines()[0] == (f"replay runs the Python function '{study.mine}:f' "
                                          f"from the folder '{study.path}'")
    # the same config run from elsewhere, `isolate` changed: the same code
    raw = {**study.raw, "model": {**study.raw["model"], "isolate": True,
                                  "module_dir": str(study.path)}}
    elsewhere = study.path / "sub"
    elsewhere.mkdir()
    (elsewhere / "study.yaml").write_text(yaml.safe_dump(raw))
    assert _replay(h5, "--config", str(elsewhere / "study.yaml")).exit_code == 0


def test_your_config_of_another_model_does_not_allow_the_files_code(study):
    h5 = _sent_result(study)
    res = _replay(h5, "--config", str(study.cfg))
    assert res.exit_code == 2
    assert res.stderr.splitlines() == [
        f"error: {h5}: its replay would run the Python function '{study.sent}:f' from the "
        f"folder '{study.path}', as the file names it ({study.cfg} is not the same model: "
        f"model.function is '{study.mine}:f', the file's '{study.sent}:f'); a result file can "
        f"name any code: pass --run-code to run it, or --config with your own config of this "
        f"model"]
    assert not study.marks.exists()


@pytest.mark.parametrize("model, code", [
    ({"name": "command", "command": "./sim.sh {inputs} {outputs}", "shell": True,
      "config_dir": "/home/x"},
     "the program './sim.sh {inputs} {outputs}' through /bin/sh (relative paths from "
     "'/home/x')"),
    ({"name": "fmu", "path": "plant.fmu", "config_dir": "/home/x"},
     "the compiled model of the FMU 'plant.fmu' (relative to '/home/x')"),
])
def test_a_program_or_an_fmu_is_named_and_refused_before_anything_is_read(study, model, code):
    study.result.config["model"] = model  # nothing validates it before the refusal
    h5 = write_hdf5(study.result, study.path / "sent.h5")
    res = _replay(h5)
    assert res.exit_code == 2
    assert res.stderr.splitlines() == [
        f"error: {h5}: its replay would run {code}, as the file names it; a result file can "
        f"name any code: pass --run-code to run it, or --config with your own config of this "
        f"model"]


def test_the_library_refuses_too_unless_told():
    result = SimpleNamespace(name="r", config={"model": {"name": "callable",
                                                         "function": "x:f"}})
    with pytest.raises(ConfigError, match=r"^r: its replay would run the Python function "
                                          r"'x:f' from the Python path, as the file names it"):
        replay(result, "mc", sample=0)  # type: ignore[arg-type]


def test_a_multi_fidelity_level_is_code_too_and_must_be_yours():
    model = {"name": "callable", "function": "mine:f", "module_dir": "/w"}
    theirs = {"model": model, "methods": [
        {"name": "mfmc", "fidelities": [{}, {"function": "sent:g"}, {"surrogate": "pce"}]}]}
    result = SimpleNamespace(name="r", config=theirs)
    assert named_code(theirs) == ["the Python function 'mine:f' from the folder '/w'",
                                  "the Python function 'sent:g' from the folder '/w'"]
    own = SimpleNamespace(source="mine.yaml", resolved=lambda: {
        "model": model, "methods": [{"name": "mfmc", "fidelities": [{}]}]})
    with pytest.raises(ConfigError, match=r"\(mine\.yaml is not the same model: the methods' "
                                          r"fidelities differ\)"):
        allowed_code(result, own=own)  # type: ignore[arg-type]
    own.resolved = lambda: theirs
    assert len(allowed_code(result, own=own)) == 2  # type: ignore[arg-type]


def test_what_will_run_is_one_line_whatever_the_file_holds():
    [text] = named_code({"model": {"name": "callable", "function": "a\nb:f\x1b[2J\u202e",
                                   "module_dir": "/tmp/x\ny"}})
    assert text == ("the Python function 'a\\nb:f\\x1b[2J\\u202e' from the folder "
                    "'/tmp/x\\ny'")


def test_built_in_simulators_and_data_files_name_no_code():
    # (a built-in result replays without a flag: tests/test_replay.py)
    assert named_code({"model": {"name": "ftcapn", "gravity": "none"}}) == []
    assert named_code({"model": None, "data": {"path": "runs.csv"}}) == []
    with pytest.raises(ConfigError, match="^model.name: unknown model 'evil'"):
        named_code({"model": {"name": "evil"}})


def test_replay_help_says_a_result_can_run_code():
    out = CliRunner().invoke(main, ["replay", "--help"]).output
    assert "--run-code" in out and "--config" in out
    assert "a result file someone sent you can run any code" in " ".join(out.split())


def test_a_kept_surrogate_of_a_sent_result_imports_none_of_its_code(study):
    """plot and report rebuild a PCE's surrogate from the stored config: its inputs, never its
    model, when the model is code (a callable's module would run on import)."""
    from uqguide.results.result import read_hdf5

    cfg = study.path / "pce.yaml"
    cfg.write_text(yaml.safe_dump(dict(study.raw, name="pce_study",
                                       methods=[{"name": "pce_tensor", "label": "pce", "m": 2}])))
    result = run(load_config(cfg))
    result.config["model"]["function"] = f"{study.sent}:f"
    h5 = write_hdf5(result, study.path / "sent_pce.h5")
    surrogate = read_hdf5(h5).surrogate("pce")
    assert surrogate.expansions
    assert not study.marks.exists(), "the sent module was imported"
