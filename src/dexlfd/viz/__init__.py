"""Figures, videos and reports (matplotlib, Agg); nothing in dexlfd imports this package."""
