"""Files: images and their headers read and written, the one atomic writer, run folders, the
files shipped beside the code, and the on-disk cache.
"""

from startrack._lazy import lazy_exports

__all__ = ["RunFolder", "Writer", "announce_builds", "cache_dir", "clear_cache", "read_image"]

__getattr__, __dir__ = lazy_exports(__name__, {
    "RunFolder": "_run_folder",
    "Writer": "_writer",
    "announce_builds": "_cache",
    "cache_dir": "_cache",
    "clear_cache": "_cache",
    "read_image": "_images",
})
