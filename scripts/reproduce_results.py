#!/usr/bin/env python
"""Run every paper config into results/<name>/: result, tables, figures and report.

For each ``configs/<name>.yaml`` (or the names given):

- a config with uncertain inputs is run (``uqguide run``): ``<name>.h5``, ``<name>_stats.csv``,
  ``<name>_cost.csv``, ``<name>_summary.md``, the console tables in ``<name>.txt``, then
  ``uqguide report``: ``<name>_report.md`` with its figures in ``figures/``;
- a config without uncertain inputs is a nominal scenario: ``uqguide simulate`` writes the
  model's headline figures beside the paper's into ``<name>.txt`` and the nominal figures into
  ``figures/`` (models without a paper scenario are run as above).

Configs whose model or methods are not registered are skipped with a message; a config that
fails is reported and the others still run. ``results/index.md`` lists what ran, when, how long
it took and what was skipped. The exit code is 1 if any config failed.

Usage::

    python scripts/reproduce_results.py                      # every config (long: 1e5-run MC)
    python scripts/reproduce_results.py ftcapn_table3 ...    # only these
    python scripts/reproduce_results.py --skip-existing      # keep results already there
    python scripts/reproduce_results.py --check              # compare the nominal studies

``--check`` writes nothing: it reruns each nominal study (``uqguide simulate``) and compares
it with the committed ``results/<name>/<name>.txt`` row by row. A row marked reproducible must
keep its verdict and its value within 1 % (the bound ``tests/test_roundoff_robustness.py``
holds such rows to under round-off; strings must be equal); chaotic rows are listed, not
compared. Exit 1 on a mismatch. The Monte Carlo and PCE studies are statistics, checked
through the regression gate by their golden versions (``tests/test_golden.py``).
"""

from __future__ import annotations

import argparse
import datetime as dt
import logging
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from update_golden import missing_registrations  # noqa: E402

from uqguide.config.run_config import RunConfig, load_config  # noqa: E402
from uqguide.errors import UqguideError  # noqa: E402
from uqguide.papers import format_report, has_scenario, nominal_figures, nominal_report  # noqa: E402
from uqguide.driver.propagate import run  # noqa: E402
from uqguide.report.tables import render_text, write_tables  # noqa: E402
from uqguide.report.document import write_report  # noqa: E402
from uqguide.results.result import write_hdf5  # noqa: E402

log = logging.getLogger("reproduce_results")

#: A result file above this size is written but flagged: too large to commit to the repository.
LARGE_MB = 20.0


INDEX_HEAD = """# Results index

Written by `scripts/reproduce_results.py`: one row per config, from its latest run.

| config | status | when | wall s | notes |
|---|---|---|---|---|"""


def _read_index(index: Path) -> dict[str, str]:
    """Rows of an existing index by config name, so a partial rerun keeps the others."""
    if not index.is_file():
        return {}
    rows = {}
    for line in index.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if line.startswith("| ") and len(cells) == 5 and cells[0] not in ("config", "---"):
            rows[cells[0]] = line
    return rows


def reproduce_one(cfg: RunConfig, out: Path) -> list[str]:
    """Write one config's outputs into ``out``; returns notes for the index."""
    out.mkdir(parents=True, exist_ok=True)
    name = cfg.name
    notes = []
    if cfg.space.dim == 0 and has_scenario(cfg.model):
        rows = nominal_report(cfg.model)
        (out / f"{name}.txt").write_text(format_report(cfg.model.name, rows) + "\n",
                                         encoding="utf-8")
        figures = nominal_figures(cfg.model, out / "figures")
        return [f"nominal scenario: {len(rows)} headline values beside the paper's, "
                f"{len(figures)} plots"]
    result = run(cfg)
    (out / f"{name}.txt").write_text(render_text(result) + "\n", encoding="utf-8")
    h5 = write_hdf5(result, out / f"{name}.h5")
    write_tables(result, out, name)
    report, figures = write_report(result, out)
    size_mb = h5.stat().st_size / 2**20
    notes.append(f"{len(result.runs)} methods, {len(figures)} figures, result {size_mb:.1f} MB")
    if size_mb > LARGE_MB:
        notes.append(f"{h5.name} is over {LARGE_MB:g} MB: leave it out of the commit")
    return notes


def _committed_rows(path: Path) -> dict[str, tuple[str, str, str]]:
    """quantity -> (value, check, kind) from a committed ``uqguide simulate`` table."""
    lines = path.read_text(encoding="utf-8").splitlines()
    head = next(i for i, ln in enumerate(lines) if ln.startswith("quantity"))
    spans, start = [], 0
    for dashes in lines[head + 1].split("  "):
        spans.append((start, start + len(dashes)))
        start += len(dashes) + 2
    rows = {}
    for ln in lines[head + 2:]:
        if not ln.strip():
            break
        cells = [ln[a:b].strip() for a, b in spans]
        rows[cells[0]] = (cells[2], cells[5], cells[6] if len(cells) > 6 else "")
    return rows


def check_nominal(cfg: RunConfig, committed: Path) -> list[str]:
    """Mismatches of the reproducible rows of a fresh nominal report against ``committed``."""
    from uqguide.papers.rows import cell_text

    old = _committed_rows(committed)
    bad = []
    for r in nominal_report(cfg.model):
        if r.kind != "reproducible":
            continue
        if r.quantity not in old:
            bad.append(f"{r.quantity}: not in {committed.name}")
            continue
        value, check, _ = old[r.quantity]
        verdict = {True: "ok", False: "MISS", None: "—"}[r.ok]
        same = value == cell_text(r.value)
        if not same and isinstance(r.value, float):
            try:
                same = abs(float(value) - r.value) <= 1e-2 * abs(r.value) + 1e-12
            except ValueError:
                same = False
        if not same or verdict != check:
            bad.append(f"{r.quantity}: committed {value} ({check}), now {cell_text(r.value)} "
                       f"({verdict})")
    return bad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", help="config names (default: every configs/*.yaml)")
    ap.add_argument("--configs", type=Path, default=ROOT / "configs", help="config folder")
    ap.add_argument("--out", type=Path, default=ROOT / "results", help="results folder")
    ap.add_argument("--skip-existing", action="store_true",
                    help="skip a config whose results/<name>/ already has its report or .txt")
    ap.add_argument("--check", action="store_true",
                    help="compare fresh nominal reports with the committed ones; write nothing")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)
    configs = sorted(args.configs.glob("*.yaml"))
    if args.check:
        mismatched = 0
        for path in configs:
            cfg = load_config(path)
            committed = args.out / path.stem / f"{path.stem}.txt"
            if cfg.space.dim or not committed.is_file() or (args.names and path.stem
                                                             not in args.names):
                continue
            bad = check_nominal(cfg, committed)
            mismatched += len(bad)
            print(f"{path.stem}: {'every reproducible row matches' if not bad else ''}")
            for b in bad:
                print(f"  MISMATCH {b}")
        return 1 if mismatched else 0
    if args.names:
        known = {p.stem: p for p in configs}
        unknown = [n for n in args.names if n not in known]
        if unknown:
            log.error("no config %s in %s", ", ".join(unknown), args.configs)
            return 2
        configs = [known[n] for n in args.names]
    index = args.out / "index.md"
    rows = _read_index(index)
    stamp = f"{dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M} UTC"
    failed = 0
    for path in configs:
        out = args.out / path.stem
        missing = missing_registrations(path)
        if missing:
            log.info("skip %s: %s not registered", path.stem, ", ".join(missing))
            rows[path.stem] = f"| {path.stem} | skipped | {stamp} | | {', '.join(missing)} " \
                              f"not registered |"
            continue
        if args.skip_existing and ((out / f"{path.stem}.txt").is_file()):
            log.info("keep %s: results exist", path.stem)
            continue
        log.info("run %s ...", path.stem)
        t0 = time.perf_counter()
        try:
            notes = reproduce_one(load_config(path), out)
            status = "done"
        except UqguideError as exc:
            notes, status = [str(exc)], "FAILED"
            failed += 1
        seconds = time.perf_counter() - t0
        log.info("%s %s in %.0f s: %s", status, path.stem, seconds, "; ".join(notes))
        rows[path.stem] = f"| {path.stem} | {status} | {stamp} | {seconds:.0f} | " \
                          f"{'; '.join(notes)} |"
    index.parent.mkdir(parents=True, exist_ok=True)
    index.write_text("\n".join([INDEX_HEAD, *[rows[k] for k in sorted(rows)]]) + "\n",
                     encoding="utf-8")
    log.info("wrote %s", index)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
