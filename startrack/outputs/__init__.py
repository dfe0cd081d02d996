"""What a solved frame becomes: the solution record (JSON, table, CSV), the WCS header, the
annotated PNG, the correspondence table, the side files and progress lines.
"""

from startrack._lazy import lazy_exports

__all__ = [
    "CSV_HEADER", "csv_rows", "error_record", "EXIT_CODES", "format_table", "frame_record",
    "iterate", "progress", "SideOutputs", "sip_order_for", "solution_record",
    "solved_wcs_header", "wcs_header", "write_annotated", "write_corr", "write_wcs",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "CSV_HEADER": "_records",
    "csv_rows": "_records",
    "error_record": "_records",
    "EXIT_CODES": "_records",
    "format_table": "_records",
    "frame_record": "_records",
    "iterate": "_progress",
    "progress": "_progress",
    "SideOutputs": "_side_files",
    "sip_order_for": "_wcs",
    "solution_record": "_records",
    "solved_wcs_header": "_wcs",
    "wcs_header": "_wcs",
    "write_annotated": "_annotate",
    "write_corr": "_corr",
    "write_wcs": "_wcs",
})
