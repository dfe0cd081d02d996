"""Files: images and their headers read and written, the one atomic writer, run folders, the
files shipped beside the code, and the on-disk cache.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "FILE_KIND", "SKY_KINDS", "SkySpec",
    "announce_builds", "atomic_path", "atomic_text", "build_seconds", "cache_dir", "cache_entries",
    "cache_max_bytes", "cached_arrays", "cached_file", "cached_parse", "check_pixels",
    "clear_cache", "date_obs_of", "DEFAULT_CACHE_MAX_MB", "find_sidecar", "FITS_SUFFIXES",
    "guarded_stdout", "max_image_pixels", "OutputClosed", "read_image", "read_sidecar",
    "release_mapped_pages", "resident_bytes", "shed_memory",
    "resource_path", "RunFolder", "sidecar_path_for", "STARS_COLUMNS", "TRUTH_COLUMNS",
    "with_sidecars", "write_fits", "write_png16", "Writer",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "FILE_KIND": "_sky_spec",
    "SKY_KINDS": "_sky_spec",
    "SkySpec": "_sky_spec",
    "announce_builds": "_cache",
    "atomic_path": "_writer",
    "atomic_text": "_writer",
    "build_seconds": "_cache",
    "cache_dir": "_cache",
    "cache_entries": "_cache",
    "cache_max_bytes": "_cache",
    "cached_arrays": "_cache",
    "cached_file": "_cache",
    "cached_parse": "_cache",
    "check_pixels": "_headers",
    "clear_cache": "_cache",
    "date_obs_of": "_headers",
    "DEFAULT_CACHE_MAX_MB": "_cache",
    "find_sidecar": "_sidecar",
    "FITS_SUFFIXES": "_images",
    "guarded_stdout": "_writer",
    "max_image_pixels": "_headers",
    "OutputClosed": "_writer",
    "read_image": "_images",
    "read_sidecar": "_sidecar",
    "release_mapped_pages": "_npz",
    "resident_bytes": "_memory",
    "shed_memory": "_memory",
    "resource_path": "_resources",
    "RunFolder": "_run_folder",
    "sidecar_path_for": "_sidecar",
    "STARS_COLUMNS": "_sidecar",
    "TRUTH_COLUMNS": "_sidecar",
    "with_sidecars": "_sidecar",
    "write_fits": "_images",
    "write_png16": "_images",
    "Writer": "_writer",
})
