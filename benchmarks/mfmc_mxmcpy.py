"""The peer side of ``benchmarks/multifidelity.py --peer-python``: MXMCPy's (NASA Langley)
optimal allocations for the costs and covariances that script measured.

It runs under an interpreter that has MXMCPy (``pip install mxmcpy``, which pulls in torch, so it
is kept out of the project's environment) and needs nothing of uqguide. It reads a JSON file
``{"costs": [...], "quantities": {name: covariance K x K}}`` and prints one JSON line per
quantity and algorithm: the samples per model and the variance ratio against plain Monte Carlo
of model 0 at the same cost (``variance * cost / (sigma_0^2 w_0)``), with MXMCPy's own model
selection. MXMCPy 1.0's ACV optimisers call ``torch.solve(B, A)``, which torch removed in 1.9:
it is put back here as ``torch.linalg.solve(A, B)`` (same solution; the LU factor it also
returned is not used by MXMCPy). A peer's error is printed instead of a number.

    /path/to/venv-with-mxmcpy/bin/python benchmarks/mfmc_mxmcpy.py quantities.json
"""

from __future__ import annotations

import json
import sys

import numpy as np

ALGORITHMS = ("mfmc", "mlmc", "acvmf", "acvis", "grdmr")


def _torch_solve_shim() -> None:
    import torch

    def solve(b: "torch.Tensor", a: "torch.Tensor") -> tuple["torch.Tensor", None]:
        return torch.linalg.solve(a, b), None

    # (torch keeps the name, as a function that raises)
    torch.solve = solve  # type: ignore[attr-defined]


def main(path: str) -> None:
    _torch_solve_shim()
    from mxmc import Optimizer

    spec = json.loads(open(path).read())
    costs = np.asarray(spec["costs"], dtype=float)
    budget = 1000.0 * costs[0]
    for name, cov in spec["quantities"].items():
        cov = np.asarray(cov, dtype=float)
        for alg in ALGORITHMS:
            row: dict[str, object] = {"quantity": name, "algorithm": alg}
            try:
                r = Optimizer(costs, cov).optimize(alg, target_cost=budget,
                                                   auto_model_selection=True)
                n = r.allocation.get_number_of_samples_per_model()
                row |= {"samples": [int(v) for v in n],
                        "variance_ratio": float(r.variance * r.cost / (cov[0, 0] * costs[0]))}
            except Exception as exc:  # noqa: BLE001 - a peer's failure is reported, not raised
                row["error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0][:120]}"
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main(sys.argv[1])
