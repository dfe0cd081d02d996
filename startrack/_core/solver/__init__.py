"""The compiled kernels of startrack.solver."""
