"""What a person reads, above ``gate``.

- ``tables``: the cost and statistics tables (console, CSV, Markdown);
- ``document``: the Markdown report of a result, with its figures and the gate's verdict;
- ``plots``: statistics over time, scalar distributions, cost;
- ``figures``: the one way a figure is made and written (no ``pyplot``);
- ``describe``: text descriptions of models and methods for the command line.
"""
