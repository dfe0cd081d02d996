"""The cache entries' file format: a stored (uncompressed) .npz whose members are read
straight into arrays, or mapped, and written without chunked copies; the XXH3-128
checksum of the arrays and the entry's own key ride along as two more members."""

from __future__ import annotations

import concurrent.futures
import contextlib
import math
import mmap
import struct
import weakref
import zipfile
from pathlib import Path

import numpy as np
import xxhash

CHECKSUM_KEY = "__xxh3_128__"
ENTRY_KEY = "__key__"  # the member holding the entry's own key (what the entry is)


def arrays_checksum(arrays: dict[str, np.ndarray]) -> str:
    """XXH3-128 over each array's name, dtype, shape and bytes, in name order."""
    digest = xxhash.xxh3_128()
    for name in sorted(arrays):
        arr = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}\0{arr.dtype.str}\0{arr.shape}\0".encode())
        digest.update(arr.reshape(-1).view(np.uint8))  # the bytes, without a copy
    return digest.hexdigest()


def read_member(fh, info: zipfile.ZipInfo, mapped: bool = False) -> np.ndarray | None:
    """One stored .npy member, read straight into an array of its own (aligned and
    writable, one copy from the page cache), or with ``mapped`` a read-only map of the
    file's bytes; None when it is not a plain .npy."""
    fh.seek(info.header_offset)
    local = fh.read(30)
    if local[:4] != b"PK\x03\x04":
        raise ValueError("bad local header")
    name_len, extra_len = struct.unpack("<HH", local[26:30])
    start = info.header_offset + 30 + name_len + extra_len
    fh.seek(start)
    version = np.lib.format.read_magic(fh)
    if version not in ((1, 0), (2, 0)):
        return None
    read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                   else np.lib.format.read_array_header_2_0)
    shape, fortran, dtype = read_header(fh)
    if dtype.hasobject:
        raise ValueError("object arrays are never cached")
    nbytes = math.prod(shape) * dtype.itemsize
    if fh.tell() - start + nbytes != info.file_size:
        raise ValueError("member size does not match its header")
    if mapped and nbytes:
        arr = np.memmap(fh.name, dtype, "r", fh.tell(), shape, "F" if fortran else "C")
        _MAPS.append(weakref.ref(arr._mmap))
        return arr
    raw = np.empty(nbytes, np.uint8)
    if fh.readinto(raw) != nbytes:
        raise ValueError("truncated member")
    return raw.view(dtype).reshape(shape, order="F" if fortran else "C")


#: the maps of the members read mapped, while they live
_MAPS: list[weakref.ref] = []


def release_mapped_pages() -> None:
    """Drop every mapped member's pages from this process's resident memory (madvise
    MADV_DONTNEED): the file's pages stay in the page cache, where the kernel may reclaim
    them, and a later read maps them back without a disk read while they remain. A
    search that swept a deep table touched most of its pages; without this they count
    against the process until it exits."""
    alive = []
    for ref in _MAPS:
        mapping = ref()
        if mapping is None or mapping.closed:
            continue
        with contextlib.suppress(OSError, ValueError, AttributeError):
            mapping.madvise(mmap.MADV_DONTNEED)
        alive.append(ref)
    _MAPS[:] = alive


def read_npz(path: Path, mapped: bool = False) -> dict[str, np.ndarray]:
    """The arrays of a .npz: its stored members read directly (np.load decompresses and
    CRCs through a stream, several times slower; the caller checks the hash anyway), or
    with ``mapped`` mapped read-only; anything else by np.load."""
    with zipfile.ZipFile(path) as zf, open(path, "rb") as fh:
        arrays: dict[str, np.ndarray] = {}
        for info in zf.infolist():
            arr = None
            if info.compress_type == zipfile.ZIP_STORED and info.filename.endswith(".npy"):
                arr = read_member(fh, info, mapped and info.filename != f"{CHECKSUM_KEY}.npy"
                                   and info.filename != f"{ENTRY_KEY}.npy")
            if arr is None:
                with np.load(path, allow_pickle=False) as data:
                    return {name: data[name] for name in data.files}
            arrays[info.filename[:-4]] = arr
    return arrays


def write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """What ``np.savez(path, **arrays, __xxh3_128__=checksum)`` writes, without its chunked
    copies, and with the checksum hashed in a thread while the arrays are written (both
    xxhash and the zip's CRC release the GIL on large buffers)."""
    with concurrent.futures.ThreadPoolExecutor(1) as pool:
        checksum = pool.submit(arrays_checksum, arrays)
        with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
            for name, arr in arrays.items():
                with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                    write_member(fh, np.asanyarray(arr))
            with zf.open(f"{CHECKSUM_KEY}.npy", "w", force_zip64=True) as fh:
                write_member(fh, np.array(checksum.result()))


def write_member(fh, arr: np.ndarray) -> None:
    if not arr.flags.c_contiguous or arr.dtype.hasobject:
        np.lib.format.write_array(fh, arr, allow_pickle=False)
        return
    header = np.lib.format.header_data_from_array_1_0(arr)
    try:
        np.lib.format.write_array_header_1_0(fh, header)
    except ValueError:  # too long a header for format 1.0, as np.save would find
        np.lib.format.write_array_header_2_0(fh, header)
    fh.write(arr.reshape(-1).view(np.uint8))

__all__ = ["CHECKSUM_KEY", "ENTRY_KEY", "arrays_checksum", "read_member", "read_npz",
           "release_mapped_pages", "write_member", "write_npz"]
