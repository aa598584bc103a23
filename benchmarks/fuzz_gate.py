"""Gate fuzz: corrupt and adversarial baselines, results and options fed to the regression gate.

One small real result (a callable model, Monte Carlo and full-tensor PCE) and its baseline give
the cases: baselines with empty, missing, non-finite, loosened or absurd parts (each edit once by
hand, once re-sealed as uqguide would), error bars loosened within the old rules, a baseline
re-sealed as if it had made 20 of its 400 runs, the keyed seal (``UQGUIDE_BASELINE_KEY``,
``check --require-key``) against re-sealing without the key; corrupt result files; tolerance
options out of range; a few real regressions. Each runs ``uqguide`` in a fresh process (60 s).

Expected: exit 2 with one ``error:`` line for an unusable input, exit 1 for a real regression,
exit 0 only where nothing the gate relies on changed; never a traceback, a hang, a wrong pass
(exit 0 where 1 or 2 is expected), or ``PASS: 0 statistics``.

Usage: ``python benchmarks/fuzz_gate.py`` (every case, prints the tally; ``--list``: the names).
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
import tempfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # the test models live in tests/
    sys.path.insert(0, str(ROOT))

from uqguide.gate.baseline import KEY_ENV, delta_std_se, sealed  # noqa: E402


@dataclass
class Case:
    name: str
    args: list[str]       # uqguide arguments
    expect: int           # 0 pass, 1 regression, 2 unusable input
    env: dict[str, str] = field(default_factory=dict)  # beyond the process's own


#: The keyed seal's key in the cases that set one (``UQGUIDE_BASELINE_KEY``).
KEY = "fuzz-gate-key-0123456789abcdef"


def base_config() -> dict:
    return {
        "name": "gatefuzz",
        "model": {"name": "callable", "function": "tests.failing_models:clean",
                  "inputs": ["a", "b"],
                  "outputs": ["y", {"name": "path", "kind": "series"}]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "uniform", "low": 0.0, "high": 2.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 400, "bootstrap": 20},
                    {"name": "pce_tensor", "label": "tp", "m": 3}],
        "report_times": [0.5, 1.0],
        "quantiles": [0.1, 0.5, 0.9],
        "events": [{"name": "big", "output": "y", "above": 2.0}],
        "seed": 5,
    }


def make_base(folder: Path) -> tuple[Path, Path]:
    """The real result and its baseline (written through the command line)."""
    import yaml

    from uqguide.cli import main
    from click.testing import CliRunner

    cfg = folder / "gatefuzz.yaml"
    cfg.write_text(yaml.safe_dump(base_config()))
    r = CliRunner().invoke(main, ["run", str(cfg), "--out", str(folder)])
    assert r.exit_code == 0, r.output
    h5 = folder / "gatefuzz.h5"
    b = folder / "base.json"
    r = CliRunner().invoke(main, ["baseline", str(h5), "-o", str(b)])
    assert r.exit_code == 0, r.output
    return h5, b


# ---------------------------------------------------------------------------- baselines
def _baseline_mutations() -> list[tuple[str, Callable[[dict], object], int]]:
    """(name, edit of the decoded baseline (returns a replacement or None), expected exit)."""
    def pt(d, label="mc", out="y", i=0):
        return d["methods"][label]["outputs"][out]["points"][i]

    def setp(label, out, key, value, i=0):
        def f(d):
            pt(d, label, out, i)[key] = value
        return f

    def seto(label, out, key, value):
        def f(d):
            d["methods"][label]["outputs"][out][key] = value
        return f

    def shift_mean(label, out, by_se):
        def f(d):
            p = pt(d, label, out)
            p["mean"] += by_se * (p.get("mean_se") or abs(p["mean"]) * 0.02 + 1e-3)
        return f

    def drop(*keys):
        def f(d):
            node = d
            for k in keys[:-1]:
                node = node[k]
            del node[keys[-1]]
        return f

    def q(d, label="mc", out="y", name="q0.5", i=0):
        return pt(d, label, out, i)["quantiles"][name]

    def shift_quantile(label, by_se, widen=1.0, name="q0.5"):
        def f(d):
            v, lo, hi = q(d, label, name=name)
            half = (hi - lo) / 2 if lo is not None and hi is not None else abs(v) * 0.02 + 1e-3
            v2 = v + by_se * half / 1.96
            pt(d, label)["quantiles"][name] = [v2, v2 - widen * (v - lo if lo is not None else
                                                                   half),
                                               v2 + widen * (hi - v if hi is not None else half)]
        return f

    def shift_event(by_runs):
        from uqguide.core.events import clopper_pearson

        def f(d):
            e = d["methods"]["mc"]["events"]["big"]
            e["n_in"] = min(e["n_used"], e["n_in"] + by_runs)
            e["probability"] = e["n_in"] / e["n_used"]
            e["ci"] = list(clopper_pearson(e["n_in"], e["n_used"]))
        return f

    def std_se_x(factor, std_by=1.0):
        """The std's error bar set to ``factor`` times what the point's own numbers give
        (inside the old x3 rule), the std itself moved by ``std_by`` (its mean_se with it)."""
        def f(d):
            o = d["methods"]["mc"]["outputs"]["y"]
            p = o["points"][0]
            p["std"] *= std_by
            p["mean_se"] = p["std"] / o["n_used"] ** 0.5
            p["std_se"] = factor * delta_std_se(p["std"], p["kurtosis"], o["n_used"])
        return f

    def std_regressed(sigmas):
        """The baseline's std below the run's by ``sigmas`` combined standard errors of two
        runs of its size, with the std's error bar x2.9: the old x3 rule passed it."""
        def f(d):
            o = d["methods"]["mc"]["outputs"]["y"]
            p = o["points"][0]
            rel = sigmas * 2 ** 0.5 * ((p["kurtosis"] - 1) / (4 * o["n_used"])) ** 0.5
            std_se_x(2.9, 1.0 - rel)(d)
        return f

    def few_runs(n, then=None):
        """The Monte Carlo method re-sealed as if it had made ``n`` runs: every count, standard
        error and the config say so, consistently (error bars sqrt(400 / n) wider)."""
        def f(d):
            m = d["methods"]["mc"]
            scale = (m["n_runs"] / n) ** 0.5
            m["n_runs"], m["n_failed"] = n, 0
            for o in m["outputs"].values():
                o["n_used"] = n
                for p in o["points"]:
                    if p.get("std") is not None:
                        p["mean_se"] = p["std"] / n ** 0.5
                    for k in ("std_se", "skewness_se", "kurtosis_se"):
                        if p.get(k) is not None:
                            p[k] *= scale
            for meth in d["config"]["methods"]:
                if meth.get("label") == "mc":
                    meth["n_samples"] = n
            if then is not None:
                then(d)
        return f

    def drop_quantiles(d):
        for meth in d["methods"].values():
            for o in meth["outputs"].values():
                for p in o["points"]:
                    p.pop("quantiles", None)

    m: list[tuple[str, Callable[[dict], object], int]] = [
        ("untouched", lambda d: None, 0),
        ("methods empty", lambda d: d.__setitem__("methods", {}), 2),
        ("mc outputs empty", lambda d: d["methods"]["mc"].__setitem__("outputs", {}), 2),
        ("points empty", seto("mc", "y", "points", []), 2),
        ("components empty", seto("mc", "y", "components", []), 2),
        ("components repeated", seto("mc", "y", "components", ["", ""]), 2),
        ("unknown component", setp("mc", "y", "component", "zz"), 2),
        ("series time null", setp("mc", "path", "time", None), 2),
        ("series time negative", setp("mc", "path", "time", -1.0), 2),
        ("series at scalar", setp("mc", "path", "at", "scalar"), 2),
        ("scalar with a time", setp("mc", "y", "time", 3.0), 2),
        ("at unknown", setp("mc", "y", "at", "middle"), 2),
        ("mean_se negative", setp("mc", "y", "mean_se", -0.1), 2),
        ("mean_se huge", setp("mc", "y", "mean_se", 1e300), 2),
        ("mean_se loosened 10x", lambda d: pt(d).__setitem__("mean_se", 10 * pt(d)["mean_se"]),
         2),
        ("mean_se null", setp("mc", "y", "mean_se", None), 2),
        ("std_se negative", setp("mc", "y", "std_se", -1.0), 2),
        ("std_se null", setp("mc", "y", "std_se", None), 2),
        ("kurtosis_se string", setp("mc", "y", "kurtosis_se", "big"), 2),
        ("std negative", setp("mc", "y", "std", -1.0), 2),
        ("mean and std null", lambda d: pt(d).update(mean=None, std=None), 2),
        ("mean is a list", setp("mc", "y", "mean", [1, 2]), 2),
        ("mean is bool", setp("mc", "y", "mean", True), 2),
        ("extra key in a point", setp("mc", "y", "bonus", 1), 2),
        ("n_used zero", seto("mc", "y", "n_used", 0), 2),
        ("n_used negative", seto("mc", "y", "n_used", -5), 2),
        ("n_used string", seto("mc", "y", "n_used", "many"), 2),
        ("uncertainty swapped", seto("mc", "y", "uncertainty", "relative_tolerance"), 2),
        ("moments_method swapped", seto("tp", "y", "moments_method", "sample"), 2),
        ("kind swapped", seto("mc", "y", "kind", "series"), 2),
        ("unit changed", seto("mc", "y", "unit", "parsec"), 2),
        ("unknown output", lambda d: d["methods"]["mc"]["outputs"].__setitem__(
            "ghost", d["methods"]["mc"]["outputs"]["y"]), 2),
        ("unknown method label", lambda d: d["methods"].__setitem__("ghost", d["methods"]["mc"]),
         2),
        ("method name swapped", lambda d: d["methods"]["mc"].__setitem__("method", "pce_tensor"),
         2),
        ("n_failed above n_runs", lambda d: d["methods"]["mc"].__setitem__("n_failed", 10**6),
         2),
        ("pce_rtol zero", lambda d: d["tolerances"].__setitem__("pce_rtol", 0), 2),
        ("pce_rtol negative", lambda d: d["tolerances"].__setitem__("pce_rtol", -0.02), 2),
        ("pce_rtol huge", lambda d: d["tolerances"].__setitem__("pce_rtol", 1e9), 2),
        ("pce_rtol string", lambda d: d["tolerances"].__setitem__("pce_rtol", "2%"), 2),
        ("tolerances missing", drop("tolerances"), 2),
        ("model other", lambda d: d.__setitem__("model", "ftcapn"), 2),
        ("format other", lambda d: d.__setitem__("format", "something"), 2),
        ("format_version 1", lambda d: d.__setitem__("format_version", 1), 2),
        ("format_version 7", lambda d: d.__setitem__("format_version", 7), 2),
        ("config not a mapping", lambda d: d.__setitem__("config", [1, 2]), 2),
        ("top is a list", lambda d: [d], 2),
        ("top is a number", lambda d: 3, 2),
        ("methods a list", lambda d: d.__setitem__("methods", [d["methods"]["mc"]]), 2),
        ("mean shifted 8 se", shift_mean("mc", "y", 8.0), 1),
        ("mean shifted 0.5 se", shift_mean("mc", "y", 0.5), 0),
        ("pce mean shifted 10%", lambda d: pt(d, "tp").__setitem__(
            "mean", pt(d, "tp")["mean"] * 1.1 + 0.1), 1),
        ("series std doubled", lambda d: pt(d, "mc", "path", -1).update(
            std=2 * pt(d, "mc", "path", -1)["std"],
            mean_se=2 * pt(d, "mc", "path", -1)["mean_se"]), 1),
        # issue 26: quantiles and event probabilities, sealed like the rest
        ("quantile interval 1e300 wide", lambda d: pt(d)["quantiles"].__setitem__(
            "q0.9", [q(d, name="q0.9")[0], -1e300, 1e300]), 2),
        ("quantile interval not holding its value", lambda d: pt(d)["quantiles"].__setitem__(
            "q0.5", [q(d)[0], q(d)[0] + 1.0, q(d)[0] + 2.0]), 2),
        ("quantile value null", lambda d: pt(d)["quantiles"].__setitem__(
            "q0.5", [None, None, None]), 2),
        ("quantile of level 1.5", lambda d: pt(d)["quantiles"].__setitem__(
            "q1.5", q(d)), 2),
        ("quantile named median", lambda d: pt(d)["quantiles"].__setitem__(
            "median", q(d)), 2),
        ("quantiles removed", drop_quantiles, 2),
        ("median shifted 8 se", shift_quantile("mc", 8.0), 1),
        ("median shifted 0.5 se", shift_quantile("mc", 0.5), 0),
        ("median shifted 8 se, interval widened 3x", shift_quantile("mc", 8.0, 3.0), 1),
        ("pce median shifted 10%", lambda d: pt(d, "tp")["quantiles"].__setitem__(
            "q0.5", [q(d, "tp")[0] * 1.1 + 0.1, None, None]), 1),
        ("event interval [0, 1]", lambda d: d["methods"]["mc"]["events"]["big"].__setitem__(
            "ci", [0.0, 1.0]), 2),
        ("event probability not n_in / n_used", lambda d: d["methods"]["mc"]["events"][
            "big"].__setitem__("probability", 0.5), 2),
        ("event n_in above n_used", lambda d: d["methods"]["mc"]["events"]["big"].__setitem__(
            "n_in", 10**6), 2),
        ("events removed", lambda d: [m.pop("events", None) for m in d["methods"].values()]
         and None, 2),
        ("event shifted 80 of 400 runs", shift_event(80), 1),
        ("event shifted 1 run", shift_event(1), 0),
        # issue 44: error bars loosened within what the old rules let through
        ("mean_se off by 1e-9 relative", lambda d: pt(d).__setitem__(
            "mean_se", pt(d)["mean_se"] * (1 + 1e-9)), 2),
        ("std_se x2.9 (the std's error bar is recomputed, so it loosens nothing)",
         std_se_x(2.9), 0),
        ("std_se x2.9 and the std 6 combined se below", std_regressed(6.0), 1),
        ("few runs: 20 of 400, re-sealed", few_runs(20), 2),
        ("few runs: 20 of 400, re-sealed, mean shifted 8 se", few_runs(20, shift_mean(
            "mc", "y", 8.0)), 2),
        ("few runs: 100 of 400, re-sealed (within 10x)", few_runs(100), 0),
    ]
    return m


def _raw_baselines() -> list[tuple[str, str, int]]:
    return [
        ("empty file", "", 2),
        ("not json", "{this is not json", 2),
        ("json null", "null", 2),
        ("NaN literal", '{"format": "uqguide-baseline", "x": NaN}', 2),
        ("Infinity literal", '{"format": "uqguide-baseline", "x": Infinity}', 2),
        ("deep nesting", "[" * 100_000 + "]" * 100_000, 2),
        ("binary", "\x00\x01\x02garbage", 2),
    ]


# ---------------------------------------------------------------------------- results
def _result_mutations() -> list[tuple[str, Callable[[object], None], int]]:
    import numpy as np

    def attr(key, value):
        def f(h):
            h.attrs[key] = value
        return f

    def replace(path, value):
        def f(h):
            del h[path]
            h[path] = value
        return f

    def delete(path):
        def f(h):
            del h[path]
        return f

    return [
        ("config_yaml not yaml", attr("config_yaml", "model: [unclosed"), 2),
        ("config_yaml a list", attr("config_yaml", "- 1\n- 2\n"), 2),
        ("config_yaml alias bomb", attr("config_yaml", "a: &a [1,1,1,1,1,1,1,1,1]\n"
                                        "b: &b [*a,*a,*a,*a,*a,*a,*a,*a,*a]\n"
                                        "c: &c [*b,*b,*b,*b,*b,*b,*b,*b,*b]\n"), 2),
        ("format attr 7", attr("format", 7), 2),
        ("method_order not json", attr("method_order", "[mc"), 2),
        ("method_order unknown label", attr("method_order", '["ghost"]'), 2),
        ("output components not json", lambda h: h["outputs/y"].attrs.__setitem__(
            "components", "{"), 2),
        ("stats wrong shape", replace("methods/mc/y", np.zeros((4, 3, 3))), 2),
        ("stats strings", replace("methods/mc/y", np.array([b"a"])), 2),
        ("series stats wrong length", replace("methods/mc/path", np.zeros((4, 2, 1))), 2),
        ("time 2-d", replace("time", np.zeros((2, 2))), 2),
        ("samples x wrong width", replace("methods/mc/samples/x", np.zeros((400, 5))), 2),
        ("failed wrong length", replace("methods/mc/samples/failed", np.zeros(3, bool)), 2),
        ("stats of an output gone", delete("methods/mc/y"), 2),
        ("samples group gone", delete("methods/mc/samples"), 2),
        ("outputs group gone", delete("outputs"), 2),
        ("n_used attr gone", lambda h: h["methods/mc/y"].attrs.__delitem__("n_used"), 2),
        ("diagnostics not json", lambda h: h["methods/mc"].attrs.__setitem__(
            "diagnostics_json", "{"), 2),
    ]


def build_cases(folder: Path) -> list[Case]:
    """Every case, its files written into ``folder``."""
    import h5py
    import shutil

    h5, base = make_base(folder)
    data = json.loads(base.read_text())
    cases: list[Case] = []
    for i, (name, edit, expect) in enumerate(_baseline_mutations()):
        d = copy.deepcopy(data)
        out = edit(d)
        d = d if out is None else out
        p = folder / f"b{i:03d}.json"
        p.write_text(json.dumps(d))
        # An edit by hand no longer matches the baseline's digest: refused, whatever it did.
        cases.append(Case(f"baseline, edited: {name}", ["check", str(h5), "--baseline", str(p)],
                          expect if d == data else 2))
        if isinstance(d, dict):
            # The same content as if uqguide had written it (digest matching): the structural
            # checks and the comparison must still give the expected verdict.
            p = folder / f"b{i:03d}s.json"
            p.write_text(json.dumps(sealed(d)))
            cases.append(Case(f"baseline, sealed: {name}", ["check", str(h5), "--baseline",
                                                            str(p)], expect))
    cases += _keyed_cases(folder, h5, data)
    for i, (name, text, expect) in enumerate(_raw_baselines()):
        p = folder / f"raw{i:03d}.json"
        p.write_text(text)
        cases.append(Case(f"baseline file: {name}", ["check", str(h5), "--baseline", str(p)],
                          expect))
    cases.append(Case("baseline file: missing", ["check", str(h5), "--baseline",
                                                 str(folder / "nope.json")], 2))
    cases.append(Case("baseline file: a folder", ["check", str(h5), "--baseline",
                                                  str(folder)], 2))
    for opt, values in (("--sigmas", ["inf", "nan", "0", "-4", "1e400", "four"]),
                        ("--pce-rtol", ["nan", "inf", "0", "-0.02"])):
        for v in values:
            cases.append(Case(f"check {opt} {v}", ["check", str(h5), "--baseline", str(base),
                                                   opt, v], 2))
    for v in ("nan", "0", "inf"):
        cases.append(Case(f"baseline --pce-rtol {v}",
                          ["baseline", str(h5), "-o", str(folder / f"new_{v}.json"),
                           "--pce-rtol", v], 2))
    for i, (name, edit, expect) in enumerate(_result_mutations()):
        p = folder / f"r{i:03d}.h5"
        shutil.copy(h5, p)
        with h5py.File(p, "r+") as f:
            edit(f)
        cases.append(Case(f"result: {name} (check)", ["check", str(p), "--baseline", str(base)],
                          expect))
        if i % 3 == 0:
            cases.append(Case(f"result: {name} (plot)", ["plot", str(p), "--out",
                                                         str(folder / f"fig{i}")], expect))
            cases.append(Case(f"result: {name} (report)", ["report", str(p), "--out",
                                                           str(folder / f"rep{i}")], expect))
            cases.append(Case(f"result: {name} (baseline)",
                              ["baseline", str(p), "-o", str(folder / f"rb{i}.json")], expect))
    trunc = folder / "truncated.h5"
    trunc.write_bytes(h5.read_bytes()[:5000])
    junk = folder / "junk.h5"
    junk.write_bytes(b"not an hdf5 file at all")
    for p, what in ((trunc, "truncated"), (junk, "not HDF5"), (folder / "nope.h5", "missing")):
        for cmd in (["check", str(p), "--baseline", str(base)], ["plot", str(p)],
                    ["report", str(p)], ["baseline", str(p), "-o", str(folder / "x.json")]):
            cases.append(Case(f"result {what} ({cmd[0]})", cmd, 2))
    return cases


def _keyed_cases(folder: Path, h5: Path, data: dict) -> list[Case]:
    """The keyed seal (``UQGUIDE_BASELINE_KEY``): what a baseline re-sealed without the key
    gives, with and without ``--require-key``."""
    key = KEY.encode()
    with_key = {KEY_ENV: KEY}
    edits = {name: f for name, f, _ in _baseline_mutations()}
    shifted, few = copy.deepcopy(data), copy.deepcopy(data)
    edits["mean shifted 8 se"](shifted)
    edits["few runs: 20 of 400, re-sealed"](few)
    good = sealed(copy.deepcopy(data), key)
    files = {
        "good": good,
        "edited, stale seal": _with_seal(sealed(shifted), good["seal"]),
        "few runs, stale seal": _with_seal(sealed(few), good["seal"]),
        "seal stripped": sealed(copy.deepcopy(data)),
        "other key": sealed(copy.deepcopy(data), b"another key"),
    }
    paths = {}
    for i, (name, d) in enumerate(files.items()):
        paths[name] = folder / f"k{i:03d}.json"
        paths[name].write_text(json.dumps(d))

    def case(name: str, file: str, require: bool, env: dict[str, str], expect: int) -> Case:
        args = ["check", str(h5), "--baseline", str(paths[file])]
        return Case(f"keyed seal: {name}", args + (["--require-key"] if require else []),
                    expect, env)

    return [
        case("sealed, --require-key, key set", "good", True, with_key, 0),
        case("sealed, key set", "good", False, with_key, 0),
        case("sealed, key not set", "good", False, {}, 0),
        case("sealed, --require-key, key not set", "good", True, {}, 2),
        case("sealed, --require-key, key empty", "good", True, {KEY_ENV: ""}, 2),
        case("mean shifted 8 se, digest redone, stale seal, key set", "edited, stale seal",
             False, with_key, 2),
        case("mean shifted 8 se, digest redone, stale seal, --require-key",
             "edited, stale seal", True, with_key, 2),
        case("few runs, digest redone, stale seal, --require-key", "few runs, stale seal",
             True, with_key, 2),
        case("seal stripped, digest redone, --require-key", "seal stripped", True, with_key, 2),
        case("seal stripped, digest redone, key set (a note)", "seal stripped", False,
             with_key, 0),
        case("sealed with another key, key set", "other key", False, with_key, 2),
        case("sealed with another key, --require-key", "other key", True, with_key, 2),
    ]


def _with_seal(d: dict, seal: str) -> dict:
    """``d`` (digest and all) with ``seal`` put back and the digest redone over it: what
    someone without the key can make of an edit."""
    from uqguide.gate.baseline import baseline_digest

    out = {k: v for k, v in d.items()}
    out["seal"] = seal
    out["digest"] = baseline_digest(out)
    return out


@dataclass
class Outcome:
    case: Case
    code: int | None
    stderr: str
    stdout: str

    @property
    def traceback(self) -> bool:
        return "Traceback" in self.stderr or "Traceback" in self.stdout

    @property
    def verdict(self) -> str:
        if self.code is None:
            return "hang"
        if self.traceback:
            return "traceback"
        if "PASS: 0 statistics" in self.stdout:
            return "passed nothing"
        if self.code != self.case.expect:
            return f"exit {self.code}, expected {self.case.expect}"
        if self.code == 2 and not self.stderr.strip().splitlines()[-1].startswith(("error:",
                                                                                    "Error:")):
            return "exit 2 without an error line"
        return "ok"


def run_case(case: Case, timeout: float = 60.0) -> Outcome:
    env = {k: v for k, v in os.environ.items() if k != KEY_ENV}
    env.update({"PYTHONPATH": str(ROOT), **case.env})
    try:
        p = subprocess.run([sys.executable, "-m", "uqguide.cli", *case.args], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return Outcome(case, None, "", "")
    return Outcome(case, p.returncode, p.stderr, p.stdout)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--list", action="store_true")
    ap.add_argument("--match", default="", help="only the cases whose name holds this")
    args = ap.parse_args()
    os.environ.pop(KEY_ENV, None)  # the base baseline unsealed; the keyed cases set their own
    with tempfile.TemporaryDirectory(prefix="uq_gatefuzz_") as tmp:
        cases = [c for c in build_cases(Path(tmp)) if args.match in c.name]
        if args.list:
            print("\n".join(c.name for c in cases))
            return 0
        outcomes = [run_case(c) for c in cases]
    tally = Counter(o.verdict for o in outcomes)
    codes = Counter((o.case.expect, o.code) for o in outcomes)
    print(f"{len(outcomes)} gate cases")
    print(f"  expected exit 2 (unusable): {sum(c.expect == 2 for c in cases)}, "
          f"got exit 2: {codes[(2, 2)]}")
    print(f"  expected exit 1 (regression): {sum(c.expect == 1 for c in cases)}, "
          f"got exit 1: {codes[(1, 1)]}")
    print(f"  expected exit 0 (pass): {sum(c.expect == 0 for c in cases)}, got exit 0: "
          f"{codes[(0, 0)]}")
    wrong_passes = sum(o.code == 0 and o.case.expect != 0 for o in outcomes)
    print(f"  tracebacks: {tally['traceback']}, hangs: {tally['hang']}, "
          f"'PASS: 0 statistics': {tally['passed nothing']}, wrong passes: {wrong_passes}")
    bad = [o for o in outcomes if o.verdict != "ok"]
    for o in bad:
        last = (o.stderr.strip().splitlines() or [""])[-1][:150]
        print(f"  NOT OK {o.case.name}: {o.verdict}: {last}")
    print("all ok" if not bad else f"{len(bad)} not ok")
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
