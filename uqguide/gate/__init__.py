"""Statistics as a CI regression gate, above ``driver``.

- ``baseline``: a result's statistics and their standard errors, kept as JSON;
- ``check``: a result against a baseline, statistic by statistic;
- ``tolerances``: the tolerances and their upper limits, the same for ``check`` and
  ``baseline``.
"""
