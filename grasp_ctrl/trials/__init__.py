"""Trials: run lift-and-place series, judge outcomes, write logs and summaries."""
