"""The execution engine of a run, above ``results``.

- ``propagate``: design -> evaluate -> refine -> estimate, for every method of a config;
- ``stage``: one design stage of one model evaluated chunk by chunk, folded in chunk order;
- ``propagate_levels``: a multi-fidelity method's pilot, allocation and main runs over the
  fidelity levels of one model;
- ``execution/``: chunks, seeds, the serial / process-pool / Dask executors, isolation;
- ``checkpoint``: a resumable run folder (``RunStore``), made of ``run_manifest`` (whose run
  the folder is: identity, resume checks, refusals), ``chunk_store`` (the finished chunks'
  files) and ``checkpoint_writer`` (the background thread that writes them);
- ``runlock``, ``interrupts``: one owner per run folder; Ctrl-C and SIGTERM;
- ``progress``, ``progress_display``: counts, ETA and how they are shown.
"""
