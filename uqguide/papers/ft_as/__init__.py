"""The FT-AS paper (Wei et al. 2024): the five-controller comparison as report rows (``report``,
claims C1-C6 and a prototype's reference values) and the paper's Figs 5-13 (``figures``)."""
