"""Config fuzz: 500+ mutated configs through ``uqguide validate``, each with a 20 s limit.

Mutations of a few small valid configs (a callable model, the lognormal and Ishigami benchmarks,
FTCAPN Monte Carlo, a tensor PCE): YAML alias bombs, anchors, deep nesting (to 100k brackets),
duplicate keys at every level, files of 1 to 50 MB, extreme sizes (samples, chunks, batches,
grid levels, dt, durations, memory and step limits), every value replaced by values of other
types (lists, mappings, NaN, inf, huge integers, NUL bytes, path names), ragged and non-finite
correlation matrices, unknown and missing keys, non-mapping documents, invalid UTF-8 and
random character edits of the YAML text.

Each mutation says what it must give: ``invalid`` (exit 2 with one ``error:`` line), ``valid``
(exit 0) or ``either`` (a random edit that may or may not break the file: exit 0 or 2). Each
runs in a forked child of one spawned process (uqguide imported once) and is killed after 20 s.

Tally: exit 2 / exit 0 per class, hangs (killed at 20 s), tracebacks, silent acceptances (exit
0 for an invalid config), messages that are not one ``error:`` line.

Usage::

    python benchmarks/fuzz_configs.py             # every mutation, prints the tally
    python benchmarks/fuzz_configs.py --sample 40 # a random sample
"""

from __future__ import annotations

import argparse
import copy
import json
import multiprocessing
import random
import sys
import tempfile
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # the test models live in tests/
    sys.path.insert(0, str(ROOT))

TIMEOUT_S = 20.0


@dataclass
class Mutation:
    name: str
    text: str | bytes
    expect: str  # "invalid" | "valid" | "either"


def bases() -> dict[str, dict]:
    ftcapn = yaml.safe_load((ROOT / "configs" / "ftcapn_table3.yaml").read_text())
    ftcapn.pop("reference", None)
    ftcapn["methods"] = [{"name": "monte_carlo", "label": "mc", "n_samples": 1000}]
    return {
        "callable": {
            "name": "fz",
            "model": {"name": "callable", "function": "tests.failing_models:clean_sum",
                      "inputs": ["a", "b"], "outputs": ["y"]},
            "inputs": [{"name": "a", "dist": "normal", "mean": 0.0, "std": 1.0},
                       {"name": "b", "dist": "normal", "mean": 1.0, "std": 2.0}],
            "correlations": [{"inputs": ["a", "b"], "matrix": [[1.0, 0.3], [0.3, 1.0]]}],
            "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 500,
                         "chunk_size": 128, "bootstrap": 50}],
            "seed": 3, "batch_size": 1000, "max_failed_fraction": 0.05,
        },
        "lognormal": {
            "model": {"name": "lognormal", "a": [0.3, 0.2, 0.1]},
            "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                       for i in (1, 2, 3)],
            "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 4000},
                        {"name": "pce_adaptive", "label": "ap", "max_runs": 200}],
            "reference": "mc", "seed": 7,
        },
        "ishigami": {
            "model": {"name": "ishigami"},
            "inputs": [{"name": f"x{i}", "dist": "uniform", "low": -3.14159, "high": 3.14159}
                       for i in (1, 2, 3)],
            "methods": [{"name": "pce_tensor", "label": "tp", "m": 6},
                        {"name": "pce_smolyak", "label": "sm", "level": 3}],
            "seed": 1,
        },
        "ftcapn": ftcapn,
    }


def _leaves(node, path=()):
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _leaves(v, (*path, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _leaves(v, (*path, i))
    yield path


def _set(cfg, path, value):
    node = cfg
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value


def _dump(cfg) -> str:
    return yaml.safe_dump(cfg, sort_keys=False)


def mutations(seed: int = 2026, heavy: bool = True) -> list[Mutation]:
    """Every mutation; ``heavy=False`` leaves out the three that take seconds to build (the
    10 and 50 MB files, 100k inputs)."""
    rng = random.Random(seed)
    out: list[Mutation] = []
    B = bases()

    # -- YAML bombs and structure
    for width, depth in [(9, 9), (10, 6), (3, 20), (2, 30), (50, 3)]:
        lines = ["a0: &a0 [" + ", ".join(["lol"] * width) + "]"]
        for d in range(1, depth):
            lines.append(f"a{d}: &a{d} [" + ", ".join([f"*a{d - 1}"] * width) + "]")
        out.append(Mutation(f"alias bomb {width}^{depth}", "\n".join(lines) + "\n", "invalid"))
        text = _dump(B["callable"]) + "\n".join(lines) + "\n"
        out.append(Mutation(f"alias bomb {width}^{depth} in a config", text, "invalid"))
    out.append(Mutation("recursive alias", "a: &a [*a]\n", "invalid"))
    out.append(Mutation("undefined alias", "model: *nothing\n", "invalid"))
    out.append(Mutation("merge key", "base: &b {name: lognormal}\nmodel: {<<: *b}\n", "invalid"))
    for name, base in B.items():
        text = _dump(base)
        first = text.splitlines()[0]
        out.append(Mutation(f"{name}: anchor on a value", text.replace(
            first, first.split(":")[0] + ": &x " + first.split(":", 1)[1].strip(), 1),
            "invalid"))
    for depth in (33, 40, 100, 1000, 10_000, 100_000):
        out.append(Mutation(f"nested brackets {depth}", "model: " + "[" * depth + "]" * depth,
                            "invalid"))
        out.append(Mutation(f"nested braces {depth}",
                            "model: " + "{a: " * depth + "1" + "}" * depth, "invalid"))
    for depth in (33, 60):
        block = "".join("  " * i + f"k{i}:\n" for i in range(depth)) + "  " * depth + "v: 1\n"
        out.append(Mutation(f"nested block mapping {depth}", "model:\n" + "  " + block.replace(
            "\n", "\n  ").rstrip() + "\n", "invalid"))
    for name, base in B.items():
        text = _dump(base)
        for key in list(base):
            line = next(ln for ln in text.splitlines() if ln.startswith(f"{key}:"))
            dup = text + (line if "{" in line or "[" in line or not line.endswith(":")
                          else f"{key}: 1") + "\n"
            out.append(Mutation(f"{name}: duplicate top key {key}", dup, "invalid"))
        m = json.dumps(base["methods"][0])
        out.append(Mutation(f"{name}: duplicate key in a method", text.replace(
            "methods:\n", "methods:\n- {name: monte_carlo, name: pce_tensor}\n", 1), "invalid"))
        out.append(Mutation(f"{name}: duplicate key in the model", text.replace(
            "model:\n", "model:\n  name: lognormal\n", 1), "invalid"))
        del m
    # -- sizes of the file
    for mb in (1.1, 2, 10, 50) if heavy else (1.1, 2):
        pad = int(mb * 1_000_000)
        out.append(Mutation(f"file of {mb} MB (long string)", _dump(B["callable"]) +
                            "description: '" + "x" * pad + "'\n", "invalid"))
    if heavy:
        out.append(Mutation("file of 5 MB (many inputs)", _dump({**B["lognormal"], "inputs": [
            {"name": f"x{i}", "dist": "normal", "std": 1.0} for i in range(100_000)]}),
            "invalid"))
    out.append(Mutation("empty file", "", "invalid"))
    out.append(Mutation("only a comment", "# nothing\n", "invalid"))
    out.append(Mutation("a list", "- 1\n- 2\n", "invalid"))
    out.append(Mutation("a scalar", "42\n", "invalid"))
    out.append(Mutation("invalid UTF-8", b"model: {name: \xff\xfe}\n", "invalid"))
    out.append(Mutation("binary", bytes(range(256)) * 10, "invalid"))
    out.append(Mutation("two documents", _dump(B["callable"]) + "---\n" + _dump(B["callable"]),
                        "invalid"))
    out.append(Mutation("tabs", "model:\n\tname: lognormal\n", "invalid"))
    out.append(Mutation("python tag", "model: !!python/object/apply:os.system ['true']\n",
                        "invalid"))
    out.append(Mutation("list as a key", "? [a, b]\n: 1\n" + _dump(B["callable"]), "invalid"))

    # -- extreme sizes and limits
    def edit(name, base, fn, expect):
        cfg = copy.deepcopy(B[base])
        fn(cfg)
        out.append(Mutation(f"{base}: {name}", _dump(cfg), expect))

    def m0(key, value):
        return lambda c: c["methods"][0].__setitem__(key, value)

    def mdl(key, value):
        return lambda c: c["model"].__setitem__(key, value)

    for v in (0, -1, 10**8 + 1, 10**9, 10**30, 1.5, "1e8x", "many", None, True):
        edit(f"n_samples {v!r}", "callable", m0("n_samples", v), "invalid")
    # Written plain, 1e8 is a number (YAML 1.2 float, integral): valid where memory allows.
    edit("n_samples written 1e8", "callable", m0("n_samples", "1e8"), "either")
    edit("n_samples 1e8 over max_memory 1 GB", "ftcapn",
         lambda c: (m0("n_samples", 10**8)(c), c.__setitem__("max_memory", "1 GB")), "invalid")
    edit("n_samples 1e8", "ftcapn", m0("n_samples", 10**8), "either")
    for v in (0, -5, 10**7 + 1, 2.5):
        edit(f"chunk_size {v!r}", "callable", m0("chunk_size", v), "invalid")
    edit("chunk_size 1e7 over max_memory 1 GB", "ftcapn",
         lambda c: (m0("chunk_size", 10**7)(c), m0("n_samples", 10**7)(c),
                    c.__setitem__("max_memory", "1 GB")), "invalid")
    for v in (0, -1, 10**7 + 1, "big"):
        edit(f"batch_size {v!r}", "callable", lambda c, v=v: c.__setitem__("batch_size", v),
             "invalid")
    for v in (-1, 10**6, 1.5):
        edit(f"bootstrap {v!r}", "callable", m0("bootstrap", v), "invalid")
    for m in (20, 30, 64):
        edit(f"tensor m {m} on 3 inputs", "ishigami", m0("m", m),
             "invalid" if m ** 3 > 2_000_000 else "either")
    edit("tensor m 0", "ishigami", m0("m", 0), "invalid")
    edit("tensor m 65", "ishigami", m0("m", 65), "invalid")
    edit("tensor m 20 on 7 inputs", "ftcapn",
         lambda c: c.__setitem__("methods", [{"name": "pce_tensor", "m": 20}]), "invalid")
    edit("tensor 6^7 (basis over memory)", "ftcapn",
         lambda c: c.__setitem__("methods", [{"name": "pce_tensor", "m": 6}]), "invalid")
    for level in (0, 13, -1):
        edit(f"smolyak level {level}", "ishigami",
             lambda c, lv=level: c["methods"][1].__setitem__("level", lv), "invalid")
    for dt in (1e-9, 1e-6, 0.0, -0.5, 1e-300, "fast"):
        edit(f"dt {dt!r}", "ftcapn", mdl("dt", dt), "invalid")
    for t in (1e12, 1e300, -1.0, 0.0):
        edit(f"t_max {t!r}", "ftcapn", mdl("t_max", t), "invalid")
    for v in (0, -1, 10**13, "many", 1.5):
        edit(f"max_steps {v!r}", "callable", lambda c, v=v: c.__setitem__("max_steps", v),
             "invalid")
    for v in ("1 kB", "-4 GB", "lots", 0, -1, [1], "4 parsec"):
        edit(f"max_memory {v!r}", "callable", lambda c, v=v: c.__setitem__("max_memory", v),
             "invalid")
    for v in (0, -1, 1e7, "soon"):
        edit(f"timeout_s {v!r}", "callable", lambda c, v=v: c.__setitem__("timeout_s", v),
             "invalid")
    for v in (-0.1, 1.5, "1%"):
        edit(f"max_failed_fraction {v!r}", "callable",
             lambda c, v=v: c.__setitem__("max_failed_fraction", v), "invalid")
    for v in (-1, 2**63, 1.5, "seed"):
        edit(f"seed {v!r}", "callable", lambda c, v=v: c.__setitem__("seed", v), "invalid")

    # -- names, strings
    for v in ("/elsewhere/victim", "../../evil", "a/b", "..", ".", "", "a\x00b", "x" * 201,
              "spaced name", "naïve", "a\\b", 42, None):
        edit(f"name {v!r}", "callable", lambda c, v=v: c.__setitem__("name", v),
             "valid" if v is None else "invalid")
    for v in ("a\x00b", "tests.failing_models:nope", "nonexistent.module:f",
              "tests.failing_models", ":f", ""):
        edit(f"function {v!r}", "callable", mdl("function", v), "invalid")
    # A callable model runs the user's code (README, trust model): any importable function
    # is accepted, os.system included; configs are to be treated like code.
    edit("function 'os:system'", "callable", mdl("function", "os:system"), "either")
    for v in ("mc/../x", "a b", "", "x" * 10, "mc\x00"):
        edit(f"label {v!r}", "callable", m0("label", v), "valid" if v == "x" * 10 else "invalid")
    edit("description with NUL", "callable", lambda c: c.__setitem__("description", "a\x00"),
         "invalid")

    # -- correlations
    for mat, exp in [([[1, 0.3], [0.3]], "invalid"), ([[1, 0.3, 0], [0.3, 1, 0]], "invalid"),
                     ([[1, 2], [2, 1]], "invalid"), ([[1, 0.3], [0.2, 1]], "invalid"),
                     ([[1, float("inf")], [float("inf"), 1]], "invalid"),
                     ([[1, float("nan")], [float("nan"), 1]], "invalid"), ([], "invalid"),
                     ([[1]], "invalid"), ("identity", "invalid"), ([[1, 0], [0, 1]], "valid"),
                     ([["a", 0], [0, 1]], "invalid"), ([[1, 0.3], [0.3, 1], [0, 0]], "invalid")]:
        edit(f"matrix {mat!r}", "callable",
             lambda c, m=mat: c["correlations"][0].__setitem__("matrix", m), exp)

    # -- unknown / missing keys
    for name, base in B.items():
        for key in list(base):
            cfg = copy.deepcopy(base)
            del cfg[key]
            required = key in ("model", "methods")
            out.append(Mutation(f"{name}: without {key}", _dump(cfg),
                                "invalid" if required else "either"))
        cfg = copy.deepcopy(base)
        cfg["sede"] = 1
        out.append(Mutation(f"{name}: unknown key", _dump(cfg), "invalid"))
        cfg = copy.deepcopy(base)
        cfg["methods"][0]["n_sample"] = 5
        out.append(Mutation(f"{name}: unknown method key", _dump(cfg), "invalid"))
        cfg = copy.deepcopy(base)
        cfg["model"]["gravit"] = 5
        out.append(Mutation(f"{name}: unknown model key", _dump(cfg), "invalid"))

    # -- every leaf replaced by values of other types
    bad_values = [None, [], {}, [1, [2]], {"a": 1}, float("nan"), float("inf"), -float("inf"),
                  10**40, -10**40, "", "\x00", "x" * 300, True]
    for name, base in B.items():
        paths = [p for p in _leaves(base) if p]
        for p in rng.sample(paths, min(len(paths), 40)):
            v = rng.choice(bad_values)
            cfg = copy.deepcopy(base)
            _set(cfg, p, v)
            out.append(Mutation(f"{name}: {'.'.join(map(str, p))} = {v!r:.30}",
                                _dump(cfg) if v == v else _dump(cfg), "either"))

    # -- issue 26: isolation, per-process memory, surrogate draws in the budget
    for name, base in B.items():
        for v, expect in [(True, "valid"), (False, "valid"), (None, "valid"), ("yes", "invalid"),
                          (1, "invalid"), (0, "invalid"), ([], "invalid"), ({}, "invalid"),
                          ("true", "invalid")]:
            cfg = copy.deepcopy(base)
            cfg["model"]["isolate"] = v
            out.append(Mutation(f"{name}: model.isolate = {v!r}", _dump(cfg), expect))
        for v, expect in [("2 GB", "valid"), ("100 MB", "invalid"), ("1 kB", "invalid")]:
            cfg = copy.deepcopy(base)
            cfg["max_memory"] = v
            out.append(Mutation(f"{name}: max_memory = {v}", _dump(cfg), expect))
    for draws, expect in [(100_000_000, "invalid"), (50_000_000, "invalid"),
                          (10_000_000, "valid"), (1_000_000, "valid")]:
        for method in ({"name": "pce_tensor", "label": "tp", "m": 6},
                       {"name": "pce_adaptive", "label": "ap", "max_runs": 400}):
            cfg = copy.deepcopy(B["ishigami"])
            cfg["methods"] = [{**method, "surrogate_draws": draws}]
            cfg["quantiles"] = "3sigma"
            out.append(Mutation(f"ishigami: {method['name']} surrogate_draws = {draws:.0e}",
                                _dump(cfg), expect))

    # -- random edits of the text
    for name, base in B.items():
        text = _dump(base)
        for i in range(40):
            t = list(text)
            for _ in range(rng.randint(1, 3)):
                pos = rng.randrange(len(t))
                op = rng.random()
                if op < 0.4:
                    del t[pos]
                elif op < 0.8:
                    t.insert(pos, rng.choice("{}[]:,&*!|>'\"#-?%@` \t\n0.e"))
                else:
                    t[pos] = rng.choice("{}[]:&*\n")
            out.append(Mutation(f"{name}: random edit {i}", "".join(t), "either"))
    return out


# ---------------------------------------------------------------------------- running
def _child(path: str, conn) -> None:
    from click.testing import CliRunner

    from uqguide.cli import main

    res = CliRunner().invoke(main, ["validate", path])
    tb = res.exception is not None and not isinstance(res.exception, SystemExit)
    conn.send((res.exit_code, res.stdout, res.stderr, tb, repr(res.exception)[:200]))
    conn.close()


@dataclass
class Outcome:
    m: Mutation
    code: int | None
    stdout: str = ""
    stderr: str = ""
    traceback: bool = False
    seconds: float = 0.0

    @property
    def verdict(self) -> str:
        if self.code is None:
            return "hang"
        if self.traceback or "Traceback" in self.stderr:
            return "traceback"
        if self.code not in (0, 2):
            return f"exit {self.code}"
        if self.code == 0 and self.m.expect == "invalid":
            return "silent acceptance"
        if self.code == 2 and self.m.expect == "valid":
            return "valid refused"
        if self.code == 2:
            lines = self.stderr.strip().splitlines()
            if len(lines) != 1 or not lines[0].startswith("error: "):
                return "not one error line"
        return "ok"


def run_one(m: Mutation, folder: Path, i: int) -> Outcome:
    path = folder / f"m{i:04d}.yaml"
    path.write_bytes(m.text if isinstance(m.text, bytes) else m.text.encode("utf-8",
                                                                          "surrogatepass"))
    ctx = multiprocessing.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    p = ctx.Process(target=_child, args=(str(path), child))
    t0 = time.monotonic()
    p.start()
    child.close()
    got = parent.poll(TIMEOUT_S)
    if not got:
        p.kill()
        p.join()
        path.unlink()
        return Outcome(m, None, seconds=time.monotonic() - t0)
    try:
        code, so, se, tb, _ = parent.recv()
    except EOFError:
        p.join()
        return Outcome(m, p.exitcode or -1, "", "child died", True, time.monotonic() - t0)
    p.join()
    path.unlink()
    return Outcome(m, code, so, se, tb, time.monotonic() - t0)


def _run_all_here(ms: list[Mutation], conn) -> None:
    import uqguide.cli  # noqa: F401 - imported once, before the forks
    import uqguide.config.run_config  # noqa: F401

    with tempfile.TemporaryDirectory(prefix="uq_cfgfuzz_") as tmp:
        conn.send([run_one(m, Path(tmp), i) for i, m in enumerate(ms)])
    conn.close()


def run_all(ms: list[Mutation]) -> list[Outcome]:
    """Run the mutations from a freshly spawned process that forks one child per mutation.

    Not from this process: after a numba kernel has run here under GNU OpenMP (as the test
    suite's own tests do), a forked child is not safe and numba SIGTERMs it on its first kernel.
    """
    ctx = multiprocessing.get_context("spawn")
    parent, child = ctx.Pipe(duplex=False)
    here = str(Path(__file__).resolve().parent)
    added = here not in sys.path
    if added:  # the spawned process imports this module by name
        sys.path.insert(0, here)
    try:
        p = ctx.Process(target=_run_all_here, args=(ms, child))
        p.start()
    finally:
        if added:
            sys.path.remove(here)
    child.close()
    try:
        outcomes: list[Outcome] = parent.recv()
    finally:
        p.join()
    return outcomes


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sample", type=int, default=0, help="run a random sample of this size")
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args()
    ms = mutations(args.seed)
    if args.sample:
        ms = random.Random(args.seed).sample(ms, args.sample)
    outcomes = run_all(ms)
    tally = Counter(o.verdict for o in outcomes)
    by = Counter((o.m.expect, o.code) for o in outcomes)
    n_inv = sum(o.m.expect == "invalid" for o in outcomes)
    print(f"{len(outcomes)} mutated configs (timeout {TIMEOUT_S:g} s each)")
    print(f"  invalid by construction: {n_inv}; clean exit 2: {by[('invalid', 2)]} "
          f"({100 * by[('invalid', 2)] / max(n_inv, 1):.1f}%)")
    n_val = sum(o.m.expect == "valid" for o in outcomes)
    print(f"  valid by construction: {n_val}; exit 0: {by[('valid', 0)]}")
    n_eit = sum(o.m.expect == "either" for o in outcomes)
    print(f"  may be valid (random text edits, values of other types, optional keys left "
          f"out): {n_eit}; exit 0: {by[('either', 0)]}, exit 2: {by[('either', 2)]}")
    print(f"  hangs: {tally['hang']}, tracebacks: {tally['traceback']}, silent acceptances: "
          f"{tally['silent acceptance']}, not one error line: {tally['not one error line']}")
    slow = max(outcomes, key=lambda o: o.seconds)
    print(f"  slowest: {slow.seconds:.2f} s ({slow.m.name[:60]})")
    bad = [o for o in outcomes if o.verdict != "ok"]
    for o in bad:
        print(f"  NOT OK {o.m.name[:70]!r}: {o.verdict}: {o.stderr.strip()[-200:]!r}")
    print("all ok" if not bad else f"{len(bad)} not ok")
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
