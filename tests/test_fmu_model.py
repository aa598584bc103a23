"""The ``fmu`` model on the test FMU of ``tests/fmu_decay.py``, compiled once per session.

The FMU holds ``x(t) = x0 exp(-k t)``. With ``x0 ~ N(mu, s)`` and ``k ~ U(a, b)`` independent,
the raw moments are closed forms, ``E[x(t)^p] = E[x0^p] E[exp(-p k t)]`` with
``E[exp(-p k t)] = (exp(-p a t) - exp(-p b t)) / (p t (b - a))``, and so are the mean, the
standard deviation and the standard errors of their Monte Carlo estimates: the mean's
``sd / sqrt(n)``, the standard deviation's ``sqrt((m4 - sd^4) / n) / (2 sd)`` (delta method,
``m4`` the fourth central moment). The Monte Carlo statistics of the config in
``docs/your-simulator.md`` must fall within 4 of those standard errors of the closed form, for
several seeds. Skipped (with the reason) without FMPy or a C compiler.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import uqguide
from uqguide.cli import main
from uqguide.models.fmu import FmuModel, archive

ROOT = Path(__file__).resolve().parents[1]
MU, S, A, B = 1.0, 0.2, 0.2, 0.8  # the doc config's x0 ~ N(MU, S), rate ~ U(A, B)


def _doc_config(fmu: Path) -> dict:
    """The config of the "An FMU" section of docs/your-simulator.md, reading ``fmu``."""
    text = (ROOT / "docs" / "your-simulator.md").read_text()
    section = text.split("\n## An FMU\n", 1)[1]
    block = re.search(r"```yaml\n(model:\n  name: fmu\n.*?)```", section, re.S)
    assert block, "docs/your-simulator.md: the An FMU section shows its config"
    cfg = yaml.safe_load(block.group(1))
    assert cfg["model"]["path"] == "decay.fmu"
    cfg["model"]["path"] = str(fmu)
    return cfg


def _exact(t: float) -> tuple[float, float, float]:
    """Mean, standard deviation and fourth central moment of ``x(t)``."""
    def decay(p: int) -> float:
        return 1.0 if t == 0 else (math.exp(-p * A * t) - math.exp(-p * B * t)) / (p * t * (B - A))

    x0 = [MU, MU ** 2 + S ** 2, MU ** 3 + 3 * MU * S ** 2, MU ** 4 + 6 * MU ** 2 * S ** 2
          + 3 * S ** 4]
    r1, r2, r3, r4 = (x0[p - 1] * decay(p) for p in range(1, 5))
    var = r2 - r1 ** 2
    return r1, math.sqrt(var), r4 - 4 * r3 * r1 + 6 * r2 * r1 ** 2 - 3 * r1 ** 4


def _within_4_se(stats, i: int, t: float, n: int, what: str) -> None:
    mean, sd, m4 = _exact(t)
    se_mean = sd / math.sqrt(n)
    se_sd = math.sqrt((m4 - sd ** 4) / n) / (2 * sd)
    got_mean, got_sd = float(stats.mean.reshape(-1)[i]), float(stats.std.reshape(-1)[i])
    assert abs(got_mean - mean) <= 4 * se_mean, (what, t, got_mean, mean, se_mean)
    assert abs(got_sd - sd) <= 4 * se_sd, (what, t, got_sd, sd, se_sd)


@pytest.mark.parametrize("seed", [1, 2])
def test_the_documented_config_gives_the_closed_form_mean_and_std(decay_fmu, seed):
    cfg = _doc_config(decay_fmu)
    n = cfg["methods"][0]["n_samples"]
    t_end, dt = cfg["model"]["stop_time"], cfg["model"]["output_interval"]
    mc = uqguide.run(cfg, seed=seed).run("mc")
    assert mc.n_failed == 0
    _within_4_se(mc.estimate.stats["x"], 0, t_end, n, "x")
    series = mc.estimate.stats["x_path"]
    assert np.allclose(mc.time, np.arange(0.0, t_end + dt / 2, dt), rtol=0, atol=1e-12)
    for i, t in enumerate(mc.time):
        _within_4_se(series, i, float(t), n, "x_path")
    # each sample is the closed form to round-off (the FMU advances x exactly)
    x = np.asarray(mc.x)
    assert np.allclose(mc.scalars["x"][:, 0], x[:, 0] * np.exp(-x[:, 1] * t_end),
                       rtol=1e-13, atol=0)


def test_a_serial_run_simulates_the_fmu_in_a_guard_process_unless_told_not_to(decay_fmu):
    # An FMU is native code: like a callable, a crash in it must cost its samples only (the
    # guard process and its bisection are tested in tests/test_containment.py).
    from uqguide.config.run_config import validate_config

    cfg = _doc_config(decay_fmu)
    assert validate_config(cfg).isolate
    cfg["model"]["isolate"] = False
    assert not validate_config(cfg).isolate


def test_tensor_pce_through_the_fmu_gives_the_exact_mean_and_std(decay_fmu):
    """A 7 x 7 Gauss rule: exact in x0 (degree 2 at most), and for E[exp(-p k t)] on the
    uniform k its error is (b-a)^14 (7!)^4 / (15 (14!)^3) (p t)^14 <= 2e-14 for p <= 2, t = 2:
    the moments must agree to round-off (1e-12 relative)."""
    cfg = _doc_config(decay_fmu)
    cfg["methods"] = [{"name": "pce_tensor", "label": "pce", "m": 7}]
    pce = uqguide.run(cfg).run("pce")
    mean, sd, _ = _exact(cfg["model"]["stop_time"])
    assert pce.n_runs == 49
    assert pce.estimate.stats["x"].mean[0] == pytest.approx(mean, rel=1e-12)
    assert pce.estimate.stats["x"].std[0] == pytest.approx(sd, rel=1e-12)


def test_a_failing_simulation_fails_its_sample_with_the_fmus_reason(decay_fmu):
    model = FmuModel({"path": str(decay_fmu), "inputs": ["x0", "k"], "outputs": ["x"],
                      "stop_time": 2.0, "output_interval": 0.5, "start_values": {"x_max": 1.0}})
    x = np.array([[0.5, 0.5], [1.5, 0.5], [0.9, 1.0], [2.0, 0.1], [0.7, 0.2]])
    out = model.evaluate(x, ["x0", "k"], ["x"])
    bad = x[:, 0] > 1.0
    assert out.failed.tolist() == bad.tolist()
    assert out.reasons[1] == ("FMICallException: fmi2DoStep failed with status 3 (error). "
                              "(FMU: x = 1.5 exceeds x_max = 1 at t = 0)")
    assert np.isnan(out.scalars["x"][bad]).all()
    # the samples after a failure run on a fresh instance: still exact
    assert np.allclose(out.scalars["x"][~bad, 0], x[~bad, 0] * np.exp(-2 * x[~bad, 1]),
                       rtol=1e-13, atol=0)


def test_an_fmu_that_stops_before_stop_time_fails_that_sample(decay_fmu):
    model = FmuModel({"path": str(decay_fmu), "inputs": ["x0", "t_end"],
                      "outputs": ["x", {"name": "p", "kind": "series", "variable": "x"}],
                      "stop_time": 2.0, "output_interval": 0.5})
    out = model.evaluate(np.array([[1.0, 5.0], [1.0, 1.0], [2.0, 5.0]]), ["x0", "t_end"])
    assert out.failed.tolist() == [False, True, False]
    assert out.reasons[1] == ("the simulation stopped at t = 1 s, before stop_time = 2 s (the "
                              "FMU terminated or gave up)")
    assert np.isnan(out.series["p"][1]).all()
    assert np.allclose(out.series["p"][2, :, 0], 2.0 * np.exp(-0.5 * np.arange(5) * 0.5))


def test_failed_samples_are_counted_in_a_run_not_raised(decay_fmu):
    cfg = _doc_config(decay_fmu)
    cfg["model"]["start_values"] = {"x_max": 1.2}
    cfg["methods"][0]["n_samples"] = 200
    cfg["max_failed_fraction"] = 0.5
    mc = uqguide.run(cfg, seed=3).run("mc")
    x0 = np.asarray(mc.x)[:, 0]
    assert mc.n_failed == int(np.sum(x0 > 1.2)) > 0
    assert mc.failed.tolist() == (x0 > 1.2).tolist()
    assert all("exceeds x_max" in r for r in mc.reasons[mc.failed])


def test_without_output_interval_the_fmus_default_step_is_fitted_to_the_span(decay_fmu):
    # the test FMU's DefaultExperiment stepSize is 0.5 s: 2 s is 4 steps of it, 2.2 s 5 of 0.44
    for stop, steps in ((2.0, 4), (2.2, 5)):
        model = FmuModel({"path": str(decay_fmu), "inputs": ["x0", "k"], "outputs": ["x"],
                          "stop_time": stop})
        assert model.step_count().steps == pytest.approx(steps, rel=1e-12)
        out = model.evaluate(np.array([[2.0, 0.3]]), ["x0", "k"])
        assert out.scalars["x"][0, 0] == pytest.approx(2.0 * math.exp(-0.3 * stop), rel=1e-13)


def test_a_model_exchange_fmu_is_integrated_by_fmpy_to_its_tolerance(decay_fmu):
    """The same binary declared model-exchange only: FMPy's CVode integrates x' = -k x. Its
    local error is held at relative_tolerance (1e-8); over 2 s of this stable decay the global
    error stays far below 1000 times that, while a sample run from the wrong start values or
    read at the wrong time would be off by O(1)."""
    from tests.fmu_decay import MODEL_EXCHANGE, build

    me = build(decay_fmu.parent, (MODEL_EXCHANGE,), "decay_me.fmu")
    model = FmuModel({"path": str(me), "inputs": ["x0", "k"],
                      "outputs": ["x", {"name": "p", "kind": "series", "variable": "x"}],
                      "stop_time": 2.0, "output_interval": 0.5, "relative_tolerance": 1e-8})
    x = np.column_stack([np.linspace(0.5, 1.5, 12), np.linspace(0.2, 0.8, 12)])
    out = model.evaluate(x, ["x0", "k"], ["x", "p"])
    assert not out.failed.any()
    exact = x[:, :1] * np.exp(-x[:, 1:] * out.time)
    assert np.allclose(out.time, [0.0, 0.5, 1.0, 1.5, 2.0], rtol=0, atol=1e-12)
    assert np.allclose(out.series["p"][:, :, 0], exact, rtol=1e-5, atol=0)
    assert np.array_equal(out.scalars["x"][:, 0], out.series["p"][:, -1, 0])


def test_an_fmu_that_cannot_be_instantiated_stops_the_run_not_its_samples(decay_fmu, tmp_path):
    # a description whose GUID is not the binary's: fmi2Instantiate refuses, whatever the sample
    import zipfile

    from tests.fmu_decay import GUID
    from uqguide.errors import ModelError

    other = tmp_path / "other.fmu"
    with zipfile.ZipFile(decay_fmu) as src, zipfile.ZipFile(other, "w") as dst:
        for item in src.namelist():
            data = src.read(item)
            if item == "modelDescription.xml":
                data = data.replace(GUID.encode(), b"{00000000-0000-0000-0000-000000000000}")
            dst.writestr(item, data)
    model = FmuModel({"path": str(other), "inputs": ["x0"], "outputs": ["x"], "stop_time": 1.0})
    with pytest.raises(ModelError, match=r"other\.fmu: the FMU cannot be instantiated \("):
        model.evaluate(np.array([[1.0]]), ["x0"])


def _validate(tmp_path: Path, model: dict) -> tuple[int, str]:
    cfg = {"model": {"name": "fmu", "stop_time": 2.0, "output_interval": 0.5, **model},
           "inputs": [{"name": "x0", "dist": "normal", "mean": 1.0, "std": 0.1}],
           "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 10}]}
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    res = CliRunner().invoke(main, ["validate", str(path)])
    assert "Traceback" not in res.output
    return res.exit_code, res.stderr.strip()


def test_bad_fmu_configs_are_exit_2_with_one_line_naming_field_value_and_variables(
        decay_fmu, tmp_path):
    fmu = str(decay_fmu)
    cases = [
        ({"path": fmu, "inputs": {"x0": "kk"}, "outputs": ["x"]},
         "model.inputs: FMU variable 'kk' (input 'x0') is not a variable of decay.fmu; its "
         "real variables that can be set: x0, k, x_max, t_end"),
        ({"path": fmu, "inputs": {"x0": "rate"}, "outputs": ["x"]},
         "model.inputs: FMU variable 'rate' (input 'x0') cannot be set before a simulation "
         "(output, continuous) in decay.fmu; its real variables that can be set: x0, k, x_max, "
         "t_end"),
        ({"path": fmu, "inputs": ["x0"], "outputs": ["x", {"name": "v", "variable": "vel"}]},
         "model.outputs: FMU variable 'vel' (output 'v') is not a variable of decay.fmu; its "
         "numeric variables: x0, k, x_max, t_end, x, rate"),
        ({"path": fmu, "inputs": ["x0"], "outputs": ["x"], "start_values": {"gain": 2}},
         "model.start_values: FMU variable 'gain' is not a variable of decay.fmu; its "
         "variables that can be set: x0, k, x_max, t_end"),
        ({"path": "nope.fmu", "inputs": ["x0"], "outputs": ["x"]},
         f"model.path: no FMU file {tmp_path / 'nope.fmu'} (a relative path is taken from the "
         f"config's folder) (got 'nope.fmu')"),
        ({"path": "c.yaml", "inputs": ["x0"], "outputs": ["x"]},
         f"model.path: {tmp_path / 'c.yaml'} is not an FMU FMPy can read (BadZipFile: File is "
         f"not a zip file) (got 'c.yaml')"),
        ({"path": fmu, "inputs": ["x0"], "outputs": [{"name": "p", "kind": "series",
                                                      "variable": "x"}],
          "output_interval": None},
         "model.output_interval: is required with series outputs (it sets their time grid) "
         "(got None)"),
    ]
    for model, message in cases:
        assert _validate(tmp_path, model) == (2, f"error: {message}"), model


def test_without_fmpy_the_config_says_how_to_install_it(decay_fmu, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "fmpy", None)  # import fmpy now raises ImportError
    assert _validate(tmp_path, {"path": str(decay_fmu), "inputs": ["x0"], "outputs": ["x"]}) \
        == (2, "error: model.name: the fmu model needs FMPy, which is not installed: "
               "pip install 'uqguide[fmu]'")


@pytest.mark.slow
def test_workers_give_the_serial_numbers_bit_for_bit(decay_fmu):
    cfg = _doc_config(decay_fmu)
    cfg["batch_size"] = 100
    serial = uqguide.run(cfg).run("mc")
    pooled = uqguide.run(cfg, workers=2).run("mc")
    assert np.array_equal(serial.scalars["x"], pooled.scalars["x"])
    for name in ("x", "x_path"):
        assert np.array_equal(serial.estimate.stats[name].mean, pooled.estimate.stats[name].mean)
        assert np.array_equal(serial.estimate.stats[name].std, pooled.estimate.stats[name].std)


# ---------------------------------------------------------------------------- hostile archives
def _rezip(src: Path, dst: Path, extra: list[tuple[zipfile.ZipInfo | str, bytes]],
           compression: int = zipfile.ZIP_STORED) -> Path:
    """``src``'s members, then ``extra``, in a new archive ``dst``."""
    import warnings

    with zipfile.ZipFile(src) as z, zipfile.ZipFile(dst, "w", compression) as out, \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zipfile warns of a duplicate name: that is the case
        for info in z.infolist():
            out.writestr(info, z.read(info))
        for info, data in extra:
            out.writestr(info, data)
    return dst


def _unix(name: str, mode: int) -> zipfile.ZipInfo:
    info = zipfile.ZipInfo(name)
    info.create_system, info.external_attr = 3, mode << 16
    return info


@pytest.fixture
def temp_folder(tmp_path, monkeypatch) -> Path:
    """This process's temporary folder, where the FMU is unzipped: empty, watched by a test."""
    import tempfile

    folder = tmp_path / "tmp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


BAD_MEMBERS = [
    ("absolute", "/tmp/evil.so", 0, "'/tmp/evil.so' is an absolute path"),
    ("climbing", "resources/../../evil.so", 0, "'resources/../../evil.so' is a path out of the "
                                               "FMU's folder ('..')"),
    ("backslash", "resources\\evil.so", 0, "'resources\\\\evil.so' is a path with a backslash or "
                                           "a drive letter (FMI paths use '/')"),
    ("symlink", "resources/passwd", stat.S_IFLNK | 0o777, "'resources/passwd' is a symbolic link"),
    ("fifo", "resources/pipe", stat.S_IFIFO | 0o644, "'resources/pipe' is a special file (a "
                                                     "device, FIFO or socket)"),
    ("device", "resources/disk", stat.S_IFBLK | 0o644, "'resources/disk' is a special file"),
    ("duplicate", "sources/decay.c", 0, "'sources/decay.c' is a second member of that name"),
]


@pytest.mark.parametrize("case,name,mode,message", BAD_MEMBERS, ids=[b[0] for b in BAD_MEMBERS])
def test_a_bad_member_is_refused_at_validate_and_nothing_is_unzipped(
        decay_fmu, tmp_path, temp_folder, case, name, mode, message):
    bad = _rezip(decay_fmu, tmp_path / "bad.fmu",
                 [(_unix(name, mode) if mode else name, b"/etc/passwd")])
    code, err = _validate(tmp_path, {"path": str(bad), "inputs": ["x0"], "outputs": ["x"]})
    assert (code, err.splitlines()[0]) == (2, err), err
    assert err.startswith(f"error: model.path: {bad} holds a member uqguide does not unzip: "
                          f"{message}"), err
    assert list(temp_folder.iterdir()) == []


def test_a_zip_bomb_is_refused_by_its_ratio_before_a_byte_is_unzipped(decay_fmu, tmp_path,
                                                                     temp_folder):
    """64 MiB of zeros deflate about 1000 to 1 (benchmarks/containment_data.py unzips the
    1 GiB one of the issue the same way): over the 100 to 1 a member above 1 MiB may have."""
    info = zipfile.ZipInfo("resources/zeros.bin")
    info.compress_type = zipfile.ZIP_DEFLATED
    bomb = _rezip(decay_fmu, tmp_path / "bomb.fmu", [(info, bytes(64 * 2**20))])
    assert bomb.stat().st_size < 2**20
    code, err = _validate(tmp_path, {"path": str(bomb), "inputs": ["x0"], "outputs": ["x"]})
    assert code == 2 and re.fullmatch(
        rf"error: model\.path: {re.escape(str(bomb))} holds a member uqguide does not unzip: "
        r"'resources/zeros\.bin' is 67,108,864 bytes compressed (\d+) to 1 \(a zip bomb's "
        r"ratio\); allowed at most 100 to 1 for a member over 1 MiB \(got .*\)", err), err
    assert list(temp_folder.iterdir()) == []


def test_an_fmu_over_the_size_or_member_limits_is_refused(decay_fmu, tmp_path, temp_folder,
                                                          monkeypatch):
    from uqguide.models.fmu import archive

    # a copy: this process keeps the folder it unzipped decay.fmu into, unchecked again
    decay_fmu = _rezip(decay_fmu, tmp_path / "copy.fmu", [])
    total = sum(i.file_size for i in zipfile.ZipFile(decay_fmu).infolist())
    monkeypatch.setattr(archive, "MAX_UNZIPPED_BYTES", total - 1)
    code, err = _validate(tmp_path, {"path": str(decay_fmu), "inputs": ["x0"],
                                     "outputs": ["x"]})
    assert code == 2 and err.startswith(
        f"error: model.path: {decay_fmu} unzips to {total:,} bytes, more than the "
        f"{total - 1:,} uqguide unzips; unzip it yourself and give its folder as the path "
        f"(got "), err
    monkeypatch.setattr(archive, "MAX_MEMBERS", 2)
    code, err = _validate(tmp_path, {"path": str(decay_fmu), "inputs": ["x0"],
                                     "outputs": ["x"]})
    assert code == 2 and err.startswith(
        f"error: model.path: {decay_fmu} has 3 members; an FMU may have at most 2 (got "), err
    assert list(temp_folder.iterdir()) == []


def _lying(src: Path, dst: Path, declared: int) -> Path:
    """``src`` plus a deflated member of 4 MiB of zeros whose headers declare ``declared``
    bytes (both its local header and the central directory say so)."""
    info = zipfile.ZipInfo("resources/table.bin")
    info.compress_type = zipfile.ZIP_DEFLATED
    _rezip(src, dst, [(info, bytes(4 * 2**20))])
    raw = bytearray(dst.read_bytes())
    with zipfile.ZipFile(dst) as z:
        member = z.getinfo("resources/table.bin")
    size = member.file_size.to_bytes(4, "little")
    local = member.header_offset + 22  # the local header's uncompressed size
    assert raw[local:local + 4] == size
    raw[local:local + 4] = declared.to_bytes(4, "little")
    central = raw.rindex(b"PK\x01\x02", 0, raw.rindex(b"resources/table.bin"))
    assert raw[central + 24:central + 28] == size
    raw[central + 24:central + 28] = declared.to_bytes(4, "little")
    dst.write_bytes(bytes(raw))
    return dst


def test_a_member_that_inflates_past_its_declared_size_is_cut_there(decay_fmu, tmp_path,
                                                                    temp_folder):
    from uqguide.models.fmu import archive

    liar = _lying(decay_fmu, tmp_path / "liar.fmu", 1000)
    code, err = _validate(tmp_path, {"path": str(liar), "inputs": ["x0"], "outputs": ["x"]})
    assert code == 2 and err.startswith(f"error: model.path: {liar} cannot be unzipped ("), err
    assert list(temp_folder.iterdir()) == []
    # what was written of it: no more than the 1000 bytes declared
    into = tmp_path / "into"
    into.mkdir()
    with pytest.raises(Exception):  # noqa: B017 - zipfile's CRC error or the count's
        archive._copy_members(liar, into, zipfile.ZipFile(liar).infolist())
    assert (into / "resources" / "table.bin").stat().st_size <= 1000


def test_only_marked_folders_of_dead_processes_are_swept(tmp_path, temp_folder):
    from uqguide.core import temp_folders
    from uqguide.models.fmu import archive

    dead = _dead_pid()

    def marked(name: str, pid: int) -> Path:
        folder = temp_folder / name
        folder.mkdir()
        (folder / archive.MARK).write_text(json.dumps({"pid": pid, "folder": name,
                                                       "key": ["x", 1, 2]}))
        (folder / "binaries").mkdir()
        return folder

    gone = marked(f"{archive.PREFIX}{dead}-abc", dead)
    alive = marked(f"{archive.PREFIX}{os.getppid()}-def", os.getppid())
    users = temp_folder / f"{archive.PREFIX}{dead}-mine"  # named like one, not marked
    users.mkdir()
    (users / "thesis.txt").write_text("mine")
    copied = marked(f"{archive.PREFIX}{dead}-ghi", dead)
    (copied / archive.MARK).write_text(json.dumps({"pid": dead, "folder": "elsewhere"}))
    link = temp_folder / f"{archive.PREFIX}{dead}-lnk"
    link.symlink_to(gone)
    assert temp_folders.sweep() == 1
    assert not gone.exists() and alive.is_dir() and copied.is_dir()
    assert (users / "thesis.txt").read_text() == "mine" and link.is_symlink()


def _dead_pid() -> int:
    """The PID of a process that has ended (and been reaped)."""
    import subprocess

    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


def test_guards_use_the_folder_the_validating_process_unzipped(decay_fmu):
    """A guard process (the default for an FMU) finds the driver's unzipped folder through
    the environment: no guard unzips its own copy (one per guard, never removed, before)."""
    import tempfile

    from uqguide.core import temp_folders
    from uqguide.models.fmu import archive

    def marked_by_others() -> set[str]:
        root = Path(tempfile.gettempdir())
        return {p.name for p in root.glob(f"{archive.PREFIX}*")
                if (temp_folders.mark_of(p, temp_folders.FMU) or {}).get("pid", os.getpid())
                != os.getpid()}

    before = marked_by_others()
    cfg = _doc_config(decay_fmu)
    cfg["methods"][0]["n_samples"] = 20
    result = uqguide.run(cfg)
    assert result.run("mc").n_failed == 0
    assert marked_by_others() == before
    key = json.dumps(list(archive._key(decay_fmu)))
    assert key in json.loads(os.environ[archive.ENV])


def _cli(config: Path, tmpdir: Path, *args: str) -> subprocess.Popen:
    from tests.failing_models import sigint_as_on_a_terminal

    env = {**os.environ, "TMPDIR": str(tmpdir), "PYTHONPATH": str(ROOT)}
    env.pop(archive.ENV, None)  # this process's own unzipped folders are not the child's
    return subprocess.Popen([sys.executable, "-m", "uqguide.cli", *args, str(config)], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=sigint_as_on_a_terminal)


def _left(tmpdir: Path) -> list[str]:
    return sorted(p.name for p in tmpdir.glob(f"{archive.PREFIX}*"))


@pytest.mark.slow
def test_no_unzipped_folder_outlives_its_run_crashed_interrupted_or_killed(tmp_path):
    """A run whose FMU crashes on 1 sample in 6 (each crash a fresh guard: 51 folders were
    left by one run), a run stopped by Ctrl-C, and a killed run's folder, which the next run
    removes."""
    import signal
    import time

    from tests.fmu_decay import CRASHING, SOURCE, build

    assert CRASHING != SOURCE
    fmu = build(tmp_path, name="crash.fmu", source=CRASHING)
    cfg = _doc_config(fmu)
    cfg["model"]["start_values"] = {"x_max": 1.2}
    cfg.update(max_failed_fraction=1.0, batch_size=50)
    cfg["methods"][0]["n_samples"] = 100
    config = tmp_path / "crash.yaml"
    config.write_text(yaml.safe_dump(cfg))
    tmpdir = tmp_path / "tmp"
    tmpdir.mkdir()
    proc = _cli(config, tmpdir, "run", "--out", str(tmp_path / "a"), "-q")
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    crashed = uqguide.read_result(tmp_path / "a" / "crash.h5").run("mc")
    assert 0 < crashed.n_failed < 100  # the crashing samples, isolated one by one
    assert _left(tmpdir) == []

    cfg["model"]["start_values"] = {}
    cfg["methods"][0]["n_samples"] = 200_000  # a minute's work: stopped long before
    config.write_text(yaml.safe_dump(cfg))
    for sig, code in ((signal.SIGINT, 130), (signal.SIGKILL, -9)):
        out = tmp_path / f"b{sig}"
        proc = _cli(config, tmpdir, "run", "--out", str(out), "-q")
        deadline = time.monotonic() + 120
        # a chunk written: the run is into its samples (a Ctrl-C while a guard process starts
        # is another matter: it is ignored, so that the guard is born ignoring it)
        while not list(out.glob("crash.run/*.npz")) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _left(tmpdir), "the run unzipped its FMU"
        proc.send_signal(sig)
        proc.communicate(timeout=120)
        assert proc.returncode == code
        if sig == signal.SIGINT:
            assert _left(tmpdir) == []
    assert len(_left(tmpdir)) == 1  # the killed run's, which nothing could remove
    proc = _cli(config, tmpdir, "validate")
    assert proc.communicate(timeout=300)[0] and proc.returncode == 0
    assert _left(tmpdir) == []
