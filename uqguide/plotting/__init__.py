"""Plots of nominal runs and propagation results (matplotlib, Agg backend)."""
