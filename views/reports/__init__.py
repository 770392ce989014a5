"""Figures and HTML pages: what the report, identify and diagnose commands write."""
