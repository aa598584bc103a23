"""From YAML to a typed :class:`~uqguide.config.run_config.RunConfig`, above ``methods``.

- ``run_config``: the configuration, validated into typed objects before anything runs;
- ``limits``, ``budget``: what one run may cost, checked before it starts;
- ``registry``: model and method names -> classes (a new simulator or method adds a line here);
- ``catalog``: the shipped studies (``studies/``, the repository's ``configs/``);
- ``report_times``: the config's report times checked against the model's time grid.
"""
