"""The compiled kernels of startrack.tracking."""
