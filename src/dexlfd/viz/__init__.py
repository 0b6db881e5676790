"""Figures (matplotlib, Agg), rendered videos and the HTML report.

Modules import matplotlib lazily through :func:`dexlfd.viz._mpl.pyplot`, so the
rest of dexlfd works without it.
"""
