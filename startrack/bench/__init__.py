"""The Monte Carlo bench behind ``startrack compare``: conditions, deterministic frames,
scoring, parallel runs with resume, summaries and plots."""

__all__ = []
