"""The compiled kernels of startrack.verify."""
