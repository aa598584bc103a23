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
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "golden"
sys.path.insert(0, str(ROOT))

from uqguide.config import load_config  # noqa: E402
from uqguide.errors import UqguideError  # noqa: E402
from uqguide.gate import check_result, read_baseline, write_baseline  # noqa: E402
from uqguide.propagate import run  # noqa: E402
from uqguide.registry import METHODS, MODELS  # noqa: E402


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
            write_baseline(result, bpath)
            print(f"wrote {bpath.relative_to(ROOT)} ({seconds:.1f} s run)")
    return status


if __name__ == "__main__":
    sys.exit(main())
