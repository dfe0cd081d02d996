"""The compiled kernels of startrack.camera."""
