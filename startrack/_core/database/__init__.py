"""The compiled kernels of startrack.database."""
