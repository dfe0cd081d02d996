"""The compiled kernels of startrack.simulate."""
