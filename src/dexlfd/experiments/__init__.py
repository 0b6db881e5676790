"""Reproducible studies and the end-to-end demo, combining the stages."""
