#!/usr/bin/env python
"""Regenerate the golden baselines of tests/golden/ — the only way they change, on purpose.

Each ``tests/golden/<name>.yaml`` is a small, fast version of a shipped config (or a benchmark);
its baseline is ``tests/golden/<name>.baseline.json``, checked by ``tests/test_golden.py`` with
the regression gate. To add a golden config, drop the YAML into tests/golden/ and run this
script with its name; commit both files.

Usage::

    python scripts/update_golden.py               # every golden config
    python scripts/update_golden.py ftcapn_table3 # only these
    python scripts/update_golden.py --dry-run     # show what would change, write nothing

Before overwriting a baseline the script prints the gate's verdict of the new run against the
old baseline, so the commit that changes a baseline can say what moved and why. Configs whose
model or methods are not registered are skipped with a message.

Every baseline is written with its round-off ensemble: the config is rerun ``ROUNDOFF_MEMBERS``
times with every model input moved by 1e-12 relative (``UQGUIDE_PERTURB``, a different
direction each time), as another CPU would move it, and once more with the NumPy reference
kernels (the test oracles of ``tests/oracles``: the same arithmetic in another order, as another
compiler would order it). A statistic that moves by more than a
quarter of its gate tolerance in any of them would make the gate's verdict depend on the CPU:
the baseline marks it chaotic, with the range it took, and the gate reports it without checking
it (an adaptive PCE of a study whose runs cross a non-smooth boundary is the case seen: its term
selection flips).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "golden"
sys.path.insert(0, str(ROOT))

from uqguide.gate.baseline import StatKey, parse_baseline  # noqa: E402
from uqguide.gate.baseline import make_baseline, to_jsonable  # noqa: E402
from uqguide.config.run_config import load_config  # noqa: E402
from uqguide.errors import UqguideError  # noqa: E402
from uqguide.gate.check import check_result, read_baseline, write_baseline  # noqa: E402
from uqguide.models.roundoff import MEMBER_ENV, PERTURB_ENV, ROUNDOFF  # noqa: E402
from uqguide.driver.propagate import run  # noqa: E402
from uqguide.config.registry import METHODS, MODELS  # noqa: E402
from uqguide.results.result import Result  # noqa: E402
from tests.oracles import substituted  # noqa: E402

ROUNDOFF_MEMBERS = 4
"""Perturbed reruns of each golden config when its baseline is written."""
CHAOS_SHARE = 0.25
"""A statistic moving by more than this share of its tolerance under round-off is chaotic."""


def roundoff_ranges(path: Path, result: Result) -> dict[StatKey, list[float | None]]:
    """The chaotic statistics of ``result`` and their ranges over the round-off ensemble."""
    base = parse_baseline(to_jsonable(make_baseline(result)))
    values: dict[StatKey, list[float]] = {}
    saved = {k: os.environ.get(k) for k in (PERTURB_ENV, MEMBER_ENV)}
    # the perturbed members, then the NumPy reference kernels unperturbed (None): another order
    # of the same floating-point operations, which is what another CPU or compiler does too
    members: list[dict[str, str] | None] = [
        {PERTURB_ENV: f"{ROUNDOFF:g}", MEMBER_ENV: str(m)}
        for m in range(1, ROUNDOFF_MEMBERS + 1)] + [None]
    try:
        for member in members:
            for k in saved:
                os.environ.pop(k, None)
            if member is None:
                with substituted():
                    member_result = run(load_config(path))
            else:
                os.environ.update(member)
                member_result = run(load_config(path))
            report = check_result(member_result, base)
            for r in report.rows:
                key = (r.label, r.output, _at(base, r), r.time, r.component, r.stat)
                values.setdefault(key, [r.baseline]).append(r.value)
                if not r.skipped and abs(r.difference) > CHAOS_SHARE * r.tolerance:
                    values[key].append(float("inf"))  # marks it chaotic
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    out: dict[StatKey, list[float | None]] = {}
    for key, vals in values.items():
        if float("inf") in vals:
            finite = [v for v in vals if v != float("inf")]
            out[key] = [min(finite), max(finite)]
    # An output whose other statistics the gate skips anyway (skewness and kurtosis of a zero
    # spread) would be left with nothing to check: the baseline leaves the whole output out.
    skipped = {(r.label, r.output, _at(base, r), r.time, r.component, r.stat)
               for r in check_result(result, base).rows if r.skipped}
    for label, output in {(k[0], k[1]) for k in out}:
        keys = [k for k in values if k[:2] == (label, output)]
        if all(k in out or k in skipped for k in keys):
            for k in keys:
                out.setdefault(k, [values[k][0], values[k][0]])
    return out


def _at(baseline, row) -> str:
    """The point kind (report, end, scalar) of a gate row; "event" for an event's probability
    (the baseline keeps events apart from the outputs)."""
    bo = baseline.methods[row.label].outputs.get(row.output)
    if bo is None:
        return "event"
    return next(p.at for p in bo.points if p.time == row.time)


def baseline_path(config: Path) -> Path:
    return config.with_name(f"{config.stem}.baseline.json")


def missing_registrations(config: Path) -> list[str]:
    """Model / method names of ``config`` that are not registered (yet)."""
    raw = yaml.safe_load(config.read_text(encoding="utf-8")) or {}
    missing = []
    model = (raw.get("model") or {}).get("name")
    if model not in MODELS:
        missing.append(f"model {model!r}")
    missing += [f"method {m.get('name')!r}" for m in raw.get("methods") or []
                if m.get("name") not in METHODS]
    return missing


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="golden config names (default: all)")
    ap.add_argument("--dry-run", action="store_true", help="compare only; write nothing")
    args = ap.parse_args(argv)
    configs = sorted(GOLDEN.glob("*.yaml"))
    if args.names:
        known = {p.stem: p for p in configs}
        unknown = [n for n in args.names if n not in known]
        if unknown:
            print(f"error: no golden config {', '.join(unknown)} in {GOLDEN} "
                  f"(have: {', '.join(known)})", file=sys.stderr)
            return 2
        configs = [known[n] for n in args.names]
    status = 0
    for path in configs:
        missing = missing_registrations(path)
        if missing:
            print(f"skip {path.stem}: {', '.join(missing)} not registered")
            continue
        t0 = time.perf_counter()
        try:
            result = run(load_config(path))
        except UqguideError as exc:
            print(f"FAIL {path.stem}: {exc}", file=sys.stderr)
            status = 1
            continue
        seconds = time.perf_counter() - t0
        bpath = baseline_path(path)
        if bpath.exists():
            try:
                verdict = check_result(result, read_baseline(bpath),
                                       source=str(bpath.relative_to(ROOT)))
                print(f"{path.stem}: against the old baseline: {verdict.render()}")
            except UqguideError as exc:
                print(f"{path.stem}: old baseline not comparable ({exc})")
        else:
            print(f"{path.stem}: new baseline")
        if not args.dry_run:
            ranges = roundoff_ranges(path, result)
            if ranges:
                print(f"{path.stem}: {len(ranges)} statistics chaotic under round-off (not "
                      "checked by the gate): " + ", ".join(
                          f"{k[0]} {k[5]} of {k[1]}" + (f" at {k[3]:g} s" if k[3] is not None
                                                        else "") for k in sorted(
                              ranges, key=str))[:2000])
            write_baseline(result, bpath, roundoff=ranges)
            print(f"wrote {bpath.relative_to(ROOT)} ({seconds:.1f} s run)")
    return status


if __name__ == "__main__":
    sys.exit(main())
