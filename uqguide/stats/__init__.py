"""Statistics on arrays, above ``core``.

- ``moments``: mean, covariance, skewness and kurtosis of an output, the mergeable moment sums
  and their intervals (docs/statistics.md#statistics);
- ``moment_sums_kernel``: the compiled central sums of a chunk (the hot loop of ``moments``);
- ``tail_intervals``: the tail-aware (Hall, one-sided where the runs cannot bound) intervals;
- ``quantiles``: quantiles from order statistics with distribution-free intervals;
- ``sobol_given_data``, ``sobol_bins_kernel``, ``sobol_groups``: first-order indices of inputs
  and groups from Monte Carlo runs; ``sobol_pick_freeze``: a Saltelli design's indices;
- ``mfmc_allocation``: multi-fidelity Monte Carlo's choice of levels and runs per level;
- ``mfmc_estimator``: its estimates of mean, std, skewness and kurtosis, with intervals.
"""
