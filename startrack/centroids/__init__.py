"""Centroids: the observed stars of a frame found in its pixels, and the centroid CSV.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "CentroidConfig", "Centroids", "extract_centroids", "frame_sigma_px", "read_centroid_csv",
    "write_centroid_csv",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "CentroidConfig": "_config",
    "Centroids": "_table",
    "extract_centroids": "_extract",
    "frame_sigma_px": "_table",
    "read_centroid_csv": "_table",
    "write_centroid_csv": "_table",
})
