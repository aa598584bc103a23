"""The GMM proximity paper (Wang et al. 2022, [W]): the three controllers' nominal outcomes and
claims W1-W10 (``claims``, ``report``), and the paper's Figs 4-5 (``figures``)."""
