"""Centroids: the observed stars of a frame found in its pixels, and the centroid CSV.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "bad_centroid_row", "CentroidConfig", "Centroids", "DEFAULT_SIGMA_PX", "extract_centroids",
    "FAST", "frame_sigma_px", "MAX_CENTROID_COORD_PX", "read_centroid_csv",
    "write_centroid_csv",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "bad_centroid_row": "_table",
    "CentroidConfig": "_config",
    "Centroids": "_table",
    "DEFAULT_SIGMA_PX": "_table",
    "extract_centroids": "_extract",
    "FAST": "_extract",
    "frame_sigma_px": "_table",
    "MAX_CENTROID_COORD_PX": "_table",
    "read_centroid_csv": "_table",
    "write_centroid_csv": "_table",
})
