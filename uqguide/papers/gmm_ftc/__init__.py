"""The GMM-FTC paper (Chen et al. 2020, [C]): claims C1-C7 of the nominal scenario (``report``)
and the paper's Figs 6-12 (``figures``)."""
