"""The application commands behind ``cli`` and ``api``, above ``papers``: ``run_and_write`` (a
whole run as the command line makes it), ``replay``, ``compile_kernels`` and ``strict``. The
engine they drive is ``driver``; what they print is ``report``.
"""
