"""The execution engine of a run, above ``results``.

- ``propagate``: every method of a config, each through its own ``Method.propagate`` hook;
- ``stage``: one design stage of one model evaluated chunk by chunk, folded in chunk order, and
  the runner a method's hook evaluates its rows through;
- ``surrogate_level``: an earlier PCE method's surrogate as a multi-fidelity level;
- ``execution/``: chunks, seeds, the serial / process-pool / Dask executors, isolation;
- ``run_folder``: the resumable run folder: its lock, manifest, chunk files and writer thread;
- ``interrupts``: Ctrl-C and SIGTERM;
- ``progress``: counts, ETA and how they are shown.
"""
