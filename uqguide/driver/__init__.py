"""The execution engine of a run, above ``results``.

- ``propagate``: design -> evaluate -> refine -> estimate, for every method of a config;
- ``stage``: one design stage of one model evaluated chunk by chunk, folded in chunk order;
- ``propagate_levels``: a multi-fidelity method's pilot, allocation and main runs over the
  fidelity levels of one model;
- ``execution/``: chunks, seeds, the serial / process-pool / Dask executors, isolation;
- ``run_folder``: the resumable run folder: its lock, manifest, chunk files and writer thread;
- ``interrupts``: Ctrl-C and SIGTERM;
- ``progress``: counts, ETA and how they are shown.
"""
