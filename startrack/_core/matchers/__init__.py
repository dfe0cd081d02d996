"""The compiled kernels of startrack.matchers."""
