"""Per-batch overhead of the ``command`` model, with a program that does no work.

    python benchmarks/command_overhead.py [--batches 50] [--sizes 1,10,100,1000,10000]

The program (C, compiled here with ``cc``) counts the lines of its inputs file and writes a
``y`` of 0 per sample: what is measured is uqguide's share (a work folder made and removed, the
inputs written, the process started and waited for, the outputs parsed) plus the program's own
file I/O. Columns: ``ms/batch`` a whole model call; ``spawn ms`` the same program started
directly with ``subprocess.run`` on a file already written (the operating system's part, which
no implementation avoids); ``write ms`` and ``read ms`` uqguide's writing of the inputs file and
reading of the outputs file alone (the I/O of the data); ``fixed ms`` what remains of a call
(folders, environment, waiting). One model call per batch, in this process (no pool).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

NOOP = r"""
#include <stdio.h>
int main(int argc, char **argv) {
    FILE *in = fopen(argv[1], "r"), *out = fopen(argv[2], "w");
    long n = -1;
    int c;
    if (!in || !out) return 1;
    while ((c = getc(in)) != EOF) n += c == '\n';
    fputs("y\n", out);
    for (long i = 0; i < n; i++) fputs("0\n", out);
    return fclose(out);
}
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batches", type=int, default=50, help="model calls per batch size")
    ap.add_argument("--sizes", default="1,10,100,1000,10000", help="samples per batch")
    ap.add_argument("--inputs", type=int, default=6, help="input columns")
    args = ap.parse_args()
    cc = shutil.which("cc")
    if cc is None:
        sys.exit("no C compiler 'cc' on PATH: the benchmark compiles its no-op program")

    from uqguide.models.command import CommandModel
    from uqguide.models.command.files import OutputSpec, read_outputs, write_inputs

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "noop.c").write_text(NOOP)
        subprocess.run([cc, "-O2", "-o", str(folder / "noop"), str(folder / "noop.c")],
                       check=True)
        names = [f"x{j}" for j in range(args.inputs)]
        model = CommandModel({"command": f"{folder / 'noop'} {{inputs}} {{outputs}}",
                              "inputs": names, "outputs": ["y"],
                              "workdir": str(folder / "work")})
        rng = np.random.default_rng(0)
        print(f"{'batches':>8} {'samples/batch':>14} {'ms/batch':>9} {'spawn ms':>9} "
              f"{'write ms':>9} {'read ms':>8} {'fixed ms':>9} {'samples/s':>11}")
        for n in (int(s) for s in args.sizes.split(",")):
            x = rng.standard_normal((n, len(names)))
            model.evaluate(x, names, ["y"])  # warm: imports, page cache
            t0 = time.perf_counter()
            for _ in range(args.batches):
                out = model.evaluate(x, names, ["y"])
            per = (time.perf_counter() - t0) / args.batches
            assert not out.failed.any() and out.scalars["y"].shape == (n, 1)
            # the operating system's part: the same program on a file already written
            model.evaluate(x, names, ["y"])
            spawn_dir = folder / "spawn"
            spawn_dir.mkdir(exist_ok=True)
            inputs = spawn_dir / "inputs.csv"
            inputs.write_text(",".join(names) + "\n" + "0\n" * n)
            t0 = time.perf_counter()
            for _ in range(args.batches):
                subprocess.run([str(folder / "noop"), str(inputs), str(spawn_dir / "out.csv")],
                               check=True)
            spawn = (time.perf_counter() - t0) / args.batches
            t0 = time.perf_counter()
            for _ in range(args.batches):
                write_inputs(spawn_dir / "in.csv", names, x, "csv")
            write = (time.perf_counter() - t0) / args.batches
            t0 = time.perf_counter()
            for _ in range(args.batches):
                read_outputs(spawn_dir / "out.csv", [OutputSpec("y", "scalar", 1)], n, "csv")
            read = (time.perf_counter() - t0) / args.batches
            fixed = per - spawn - write - read
            print(f"{args.batches:>8} {n:>14,} {per * 1e3:>9.2f} {spawn * 1e3:>9.2f} "
                  f"{write * 1e3:>9.2f} {read * 1e3:>8.2f} {fixed * 1e3:>9.2f} "
                  f"{n / per:>11,.0f}")


if __name__ == "__main__":
    main()
