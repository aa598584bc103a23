"""The execution engine of a run, above ``results``: ``propagate`` (every method of a config),
``stage`` (a method's runner: chunks evaluated and folded in order), ``surrogate_level``,
``execution/`` (chunks, executors, isolation), ``run_folder`` (the resumable run folder),
``interrupts`` (Ctrl-C and SIGTERM) and ``progress``.
"""
