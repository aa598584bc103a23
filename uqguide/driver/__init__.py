"""The driver of a run, above ``papers`` (the top layer under the front doors).

- ``propagate``: design -> evaluate -> refine -> estimate, for every method of a config;
- ``stage``: one design stage of one model evaluated chunk by chunk, folded in chunk order;
- ``propagate_levels``: a multi-fidelity method's pilot, allocation and main runs over the
  fidelity levels of one model;
- ``run_and_write``: a whole run as the command line makes it (budget, lock, run, write);
- ``execution/``: chunks, seeds, the serial / process-pool / Dask executors, isolation;
- ``checkpoint``: a resumable run folder (``RunStore``), made of ``run_manifest`` (whose run
  the folder is: identity, resume checks, refusals), ``chunk_store`` (the finished chunks'
  files) and ``checkpoint_writer`` (the background thread that writes them);
- ``runlock``, ``interrupts``: one owner per run folder; Ctrl-C and SIGTERM;
- ``progress``, ``progress_display``: counts, ETA and how they are shown;
- ``replay``: one sample of a result run again with its full time histories.
- ``compile_kernels``: every study's kernel compiled up front (``uqguide compile``).
"""
