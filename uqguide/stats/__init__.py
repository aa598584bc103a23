"""Statistics on arrays, above ``core``.

- ``moments``: mean, covariance, skewness and kurtosis of an output, the mergeable moment sums
  and their intervals (uq-methods.md section 3);
- ``moment_sums_kernel``: the compiled central sums of a chunk (the hot loop of ``moments``);
- ``quantiles``: quantiles from order statistics with distribution-free intervals;
- ``mfmc_allocation``: multi-fidelity Monte Carlo's choice of levels and runs per level;
- ``mfmc_estimator``: its estimates of mean, std, skewness and kurtosis, with intervals.
"""
