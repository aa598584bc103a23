"""Fuzz the config loader: hundreds of mutated configs, each exit 2 with one line that names
the field (or the YAML line), never a traceback.

A seeded mutation loop over a good config: every mutation is invalid by construction (wrong
type, unknown key, bad distribution, negative or zero size, broken YAML), and its expected
field path is known, so the message is checked to start with it.
"""

from __future__ import annotations

import copy
import random
import re
from typing import Any

import pytest
import yaml
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from uqguide.cli import main

GOOD: dict[str, Any] = {
    "name": "fuzz",
    "model": {"name": "lognormal", "a": [0.3, 0.2]},
    "inputs": [{"name": "x1", "dist": "normal", "mean": 0.0, "std": 1.0},
               {"name": "x2", "dist": "uniform", "low": -1.0, "high": 1.0}],
    "outputs": ["y"],
    "report_times": [0.0],
    "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 100, "sampling": "lhs",
                 "chunk_size": 64, "bootstrap": 10}],
    "reference": "mc",
    "seed": 1,
    "batch_size": 50,
    "max_failed_fraction": 0.05,
    "pce_failure_policy": "fail",
}

# Leaves that must be numbers (path, is_int) and strings with a closed set of values.
NUMBERS = [("seed", True), ("batch_size", True), ("max_failed_fraction", False),
           ("inputs[0].mean", False), ("inputs[0].std", False), ("inputs[1].low", False),
           ("inputs[1].high", False), ("methods[0].n_samples", True),
           ("methods[0].chunk_size", True), ("methods[0].bootstrap", True),
           ("model.a[0]", False), ("report_times[0]", False)]
CHOICES = ["methods[0].sampling", "pce_failure_policy", "inputs[0].dist", "model.name",
           "methods[0].name", "inputs[0].name", "outputs[0]", "reference"]
MAPPINGS = ["", "model", "inputs[0]", "inputs[1]", "methods[0]"]
SIZES = [("batch_size", 0), ("methods[0].n_samples", 0), ("methods[0].n_samples", -5),
         ("methods[0].chunk_size", -1), ("methods[0].bootstrap", -2), ("seed", -1),
         ("inputs[0].std", 0.0), ("inputs[0].std", -1.0), ("max_failed_fraction", 1.5),
         ("max_failed_fraction", -0.1), ("report_times[0]", -3.0)]
BAD_TYPES = ["abc", [1, 2], {"k": 1}, None, True, "", "1e400x"]


def _steps(path: str) -> list[Any]:
    out: list[Any] = []
    for part in path.replace("]", "").split("."):
        name, *idx = part.split("[")
        if name:
            out.append(name)
        out += [int(i) for i in idx]
    return out


def _set(cfg: dict, path: str, value: Any) -> None:
    steps = _steps(path)
    node = cfg
    for s in steps[:-1]:
        node = node[s]
    node[steps[-1]] = value


def _get(cfg: dict, path: str) -> Any:
    node: Any = cfg
    for s in _steps(path):
        node = node[s]
    return node


#: libyaml's emitter where PyYAML has it: the 400 texts are made at collection, and the pure
#: Python emitter spends ~1 CPU-s of the default suite on them
_DUMPER = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


def _mutations(rng: random.Random, n: int) -> list[tuple[str, str, str]]:
    """``(kind, yaml text, expected message prefix)``."""
    cases = []
    for _ in range(n):
        cfg = copy.deepcopy(GOOD)
        kind = rng.choice(["type", "choice", "unknown_key", "size", "distribution", "missing",
                           "yaml"])
        if kind == "type":
            path, is_int = rng.choice(NUMBERS)
            bad = rng.choice(BAD_TYPES + ([2.5] if is_int else []))
            if isinstance(bad, bool) and not is_int:
                bad = "abc"  # a bool is a valid float to pydantic (lax mode): not a defect
            if isinstance(bad, bool):
                bad = [True]
            _set(cfg, path, bad)
            expect = path
        elif kind == "choice":
            path = rng.choice(CHOICES)
            bad = rng.choice(["nosuchthing", "Monte_Carlo", 3, [1], {"a": 1}]
                             + ([None] if path != "reference" else []))  # reference: optional
            _set(cfg, path, bad)
            expect = path
            if path == "inputs[0].dist":
                expect = "inputs[0].dist"
        elif kind == "unknown_key":
            where = rng.choice(MAPPINGS)
            key = rng.choice(["foo", "sede", "n_sample", "sigma2", "labels", "x_1"])
            node = _get(cfg, where) if where else cfg
            node[key] = rng.choice([1, "a", [1], None])
            expect = f"{where}.{key}" if where else key
        elif kind == "size":
            path, bad = rng.choice(SIZES)
            _set(cfg, path, bad)
            expect = path
        elif kind == "distribution":
            i = rng.choice([0, 1])
            choice = rng.choice(["swap_params", "reversed", "unknown", "lognormal_sigma",
                                 "trunc_bounds", "non_finite"])
            if choice == "swap_params":  # a normal given uniform parameters
                cfg["inputs"][i] = {"name": f"x{i + 1}", "dist": "normal", "low": 0, "high": 1}
                expect = f"inputs[{i}]"
            elif choice == "reversed":
                cfg["inputs"][i] = {"name": f"x{i + 1}", "dist": "uniform", "low": 2, "high": 1}
                expect = f"inputs[{i}]"
            elif choice == "unknown":
                cfg["inputs"][i]["dist"] = rng.choice(["gauss", "Normal", "beta"])
                expect = f"inputs[{i}].dist"
            elif choice == "lognormal_sigma":
                cfg["inputs"][i] = {"name": f"x{i + 1}", "dist": "lognormal", "mu": 0,
                                    "sigma": rng.choice([0, -1, "wide"])}
                expect = f"inputs[{i}].sigma"
            elif choice == "trunc_bounds":
                cfg["inputs"][i] = {"name": f"x{i + 1}", "dist": "truncnormal", "mean": 0,
                                    "std": 1, "low": 1, "high": -1}
                expect = f"inputs[{i}]"
            else:  # .inf / .nan where a finite value is needed
                key = rng.choice(["mean", "std"] if i == 0 else ["low", "high"])
                cfg["inputs"][i][key] = rng.choice([float("inf"), float("-inf"), float("nan")])
                # a uniform's bound may first break low < high, which names the entry
                expect = f"inputs[{i}].{key}" if i == 0 else f"inputs[{i}]"
        elif kind == "missing":
            path = rng.choice(["model", "methods", "model.name", "inputs[0].name",
                               "inputs[0].dist", "methods[0].name", "methods[0].n_samples"])
            steps = _steps(path)
            node = cfg
            for s in steps[:-1]:
                node = node[s]
            del node[steps[-1]]
            expect = path
        else:
            text = yaml.dump(cfg, Dumper=_DUMPER, sort_keys=False, default_flow_style=None)
            lines = text.splitlines()
            j = rng.randrange(1, len(lines))
            breakage = rng.choice(["unclosed_flow", "tab", "unclosed_quote", "bad_indent"])
            if breakage == "unclosed_flow":
                lines[j] = lines[j] + " {"
            elif breakage == "tab":
                lines[j] = "\t" + lines[j]
            elif breakage == "unclosed_quote":
                lines.insert(j, 'note: "never closed')
            else:
                lines.insert(j, "  - ]broken: [")
            cases.append((f"yaml:{breakage}", "\n".join(lines) + "\n", "invalid YAML at line"))
            continue
        cases.append((kind, yaml.dump(cfg, Dumper=_DUMPER, sort_keys=False), expect))
    return cases


CASES = _mutations(random.Random(20240607), 400)
#: The first this many run in the default suite (every kind of mutation is among them), the
#: rest with the slow tests: the 400 cost 4.4 CPU-s of the suite's 150.
DEFAULT_CASES = 200


@pytest.mark.parametrize("kind,text,expect", [
    pytest.param(*c, id=f"{i}-{c[0]}", marks=[pytest.mark.slow] if i >= DEFAULT_CASES else [])
    for i, c in enumerate(CASES)])
def test_mutated_config_is_exit_2_naming_the_field(tmp_path, kind, text, expect):
    path = tmp_path / "fuzz.yaml"
    path.write_text(text)
    res = CliRunner().invoke(main, ["validate", str(path)])
    assert res.exit_code == 2, (res.output, res.exception)
    assert "Traceback" not in res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    if kind.startswith("yaml"):
        # Some breakages still parse (``seed: 1 {`` is the plain string "1 {"): then the
        # value's field is named instead of a YAML line.
        assert (lines[0].startswith(f"error: {path}: {expect}")
                or re.match(r"error: [A-Za-z_]\w*(\.\w+|\[\d+\])*: ", lines[0])), lines[0]
    else:
        assert lines[0].startswith(f"error: {expect}"), (kind, lines[0])


def _leaves(node: Any, path: str = "") -> list[str]:
    if isinstance(node, dict):
        return [p for k, v in node.items() for p in _leaves(v, f"{path}.{k}" if path else k)]
    if isinstance(node, list):
        return [p for i, v in enumerate(node) for p in _leaves(v, f"{path}[{i}]")]
    return [path]


JSONISH = st.recursive(
    st.none() | st.booleans() | st.integers(-10**20, 10**20) | st.floats(allow_nan=True)
    | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner,
                                                               max_size=3),
    max_leaves=5)


@pytest.mark.slow
@settings(max_examples=150, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_value_anywhere_is_exit_0_or_2_never_a_traceback(tmp_path, data):
    # Free fuzz: any leaf replaced by any YAML-able value. The result may be a valid config
    # (exit 0); otherwise exit 2 with one line. Never exit 1 or a traceback.
    cfg = copy.deepcopy(GOOD)
    path = data.draw(st.sampled_from(_leaves(cfg)))
    _set(cfg, path, data.draw(JSONISH))
    f = tmp_path / "free.yaml"
    f.write_text(yaml.safe_dump(cfg))
    res = CliRunner().invoke(main, ["validate", str(f)])
    assert res.exit_code in (0, 2), (path, res.output, res.exception)
    assert "Traceback" not in res.output
    if res.exit_code == 2:
        assert len(res.stderr.strip().splitlines()) == 1


def test_the_unmutated_config_is_valid(tmp_path):
    path = tmp_path / "fuzz.yaml"
    path.write_text(yaml.safe_dump(GOOD))
    assert CliRunner().invoke(main, ["validate", str(path)]).exit_code == 0
