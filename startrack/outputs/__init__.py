"""What a solved frame becomes: the solution record (JSON, table, CSV), the WCS header, the
annotated PNG, the correspondence table, the side files and progress lines.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "SideOutputs", "error_record", "frame_record", "progress", "solution_record", "wcs_header",
    "write_annotated", "write_corr", "write_wcs",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "SideOutputs": "_side_files",
    "error_record": "_records",
    "frame_record": "_records",
    "progress": "_progress",
    "solution_record": "_records",
    "wcs_header": "_wcs",
    "write_annotated": "_annotate",
    "write_corr": "_corr",
    "write_wcs": "_wcs",
})
