#!/usr/bin/env python
"""A fingerprint of the statistics of every golden config, for refactors that must not move a bit.

Each ``tests/golden/<name>.yaml`` is run as the golden test runs it, its statistics are put in
the baseline form the regression gate keeps (mean, std, skewness, kurtosis, their standard errors
and probabilities, per method, output, point and component; no timings, no dates), and that JSON
is hashed. Run it before and after a change that should be a pure move or refactor: the last
line, ``ALL <hash>``, must be the same. It is not a tolerance check (that is the gate's job): one
changed bit in any statistic changes the hash. Run both in one checkout folder: the same code
at another path gave other last bits in ft_as_dispersion's PCE index intervals (2026-12-07).

Usage::

    python scripts/stats_hash.py                     # every golden config (a few minutes)
    python scripts/stats_hash.py ftcapn_table3 ...   # only these
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from uqguide.config.run_config import load_config  # noqa: E402
from uqguide.driver.propagate import run  # noqa: E402
from uqguide.gate.baseline import make_baseline, to_jsonable  # noqa: E402

GOLDEN = ROOT / "tests" / "golden"


def stats_hash(config: Path) -> str:
    """Hex SHA-256 of the statistics of one run of ``config``, in the baseline's JSON form."""
    baseline = to_jsonable(make_baseline(run(load_config(config))))
    text = json.dumps(baseline["methods"], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="golden config names (default: all)")
    args = ap.parse_args(argv)
    names = args.names or [p.stem for p in sorted(GOLDEN.glob("*.yaml"))]
    total = hashlib.sha256()
    for name in names:
        h = stats_hash(GOLDEN / f"{name}.yaml")
        total.update(bytes.fromhex(h))
        print(f"{name:32s} {h[:16]}", flush=True)
    print(f"ALL {total.hexdigest()[:16]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
