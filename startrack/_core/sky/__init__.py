"""The compiled kernels of startrack.sky."""
