"""The execution engine of a run, above ``results``: ``propagate`` (every method of a config),
``stage`` (the runners: chunks evaluated and folded in order, a surrogate as a level),
``execution/`` (chunks, executors, isolation), ``run_folder`` (the resumable run folder),
``interrupts`` (Ctrl-C and SIGTERM) and ``progress``.
"""
