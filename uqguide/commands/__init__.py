"""The application commands behind ``cli`` and ``api``, above ``papers``.

- ``run_and_write``: a whole run as the command line makes it (budget, lock, run, write);
- ``replay``: one sample of a result run again with its full time histories;
- ``compile_kernels``: every study's kernel compiled up front (``uqguide compile``);
- ``strict``: ``--strict``'s check of withheld PCE statistics.

The engine they drive is ``driver``; what they print is ``report``.
"""
