"""The shared vocabulary every layer speaks; imports nothing of uqguide but ``errors``.

- ``types``: what a model returns, the statistics of an output, what a method estimates;
- ``inputs``: uncertain inputs, their joint distribution and the map from the unit cube;
- ``events``: events such as ``collision: min_clearance below 0`` and their probabilities;
- ``failures``: failed runs tallied by reason;
- ``strict``: booleans are not numbers in a config;
- ``atomic``: files that are complete or absent;
- ``csv_rows``: a CSV file's rows read within bounds, a block at a time, with their errors;
- ``temp_folders``: uqguide's marked folders in ``$TMPDIR`` (and multiprocessing's), swept when
  their process was killed;
- ``safe_yaml``: a YAML loader that cannot be made to explode (configs, stored configs);
- ``process_groups``: external programs a process runs, and all they start, ended with them;
- ``descendants``: this process's descendants in Linux's ``/proc``, and the subreaper switch.
"""
