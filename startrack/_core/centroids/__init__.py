"""The compiled kernels of startrack.centroids."""
