"""The driver of a run, above ``papers`` (the top layer under the front doors).

- ``propagate``: design -> evaluate -> refine -> estimate, for every method of a config;
- ``run_and_write``: a whole run as the command line makes it (budget, lock, run, write);
- ``execution/``: chunks, seeds, the serial / process-pool / Dask executors, isolation;
- ``checkpoint``, ``runlock``, ``interrupts``: resumable run folders, one owner each, Ctrl-C;
- ``progress``, ``progress_display``: counts, ETA and how they are shown;
- ``replay``: one sample of a result run again with its full time histories.
"""
