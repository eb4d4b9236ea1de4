"""OpenEXR and numpy storage of HDR images."""
from __future__ import annotations

import errno
import json
import os
import pathlib

import numpy as np

EXR_TYPES = ("float32", "float16")
#: The first four bytes of every OpenEXR file.
EXR_MAGIC = b"\x76\x2f\x31\x01"


def check_writable(path):
    """Raise the ``OSError`` that writing ``path`` would meet, naming the file or folder.

    ``FileNotFoundError`` when the folder does not exist, ``NotADirectoryError`` when
    it is a file, ``IsADirectoryError`` when ``path`` is a folder, ``PermissionError``
    when the folder (or an existing file) is not writable. Nothing is created.
    OpenEXR reports these as ``RuntimeError``; this check lets every format, and the
    command line before a long render, report them as Python does.
    """
    path = pathlib.Path(os.fspath(path))
    folder = path.parent
    if not folder.exists():
        raise FileNotFoundError(errno.ENOENT, f"cannot write {str(path)!r}: no such folder", str(folder))
    if not folder.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, f"cannot write {str(path)!r}: not a folder", str(folder))
    if path.is_dir():
        raise IsADirectoryError(errno.EISDIR, "cannot write an image over a folder", str(path))
    if path.exists() and not os.access(path, os.W_OK):
        raise PermissionError(errno.EACCES, "cannot write: the file is read-only", str(path))
    if not path.exists() and not os.access(folder, os.W_OK | os.X_OK):
        raise PermissionError(errno.EACCES, f"cannot write {str(path)!r}: the folder is not writable", str(folder))


def openexr_module():
    """The ``OpenEXR`` module, or an ``ImportError`` that says how to install it."""
    try:
        import OpenEXR
    except ImportError:  # pragma: no cover - depends on the environment
        raise ImportError("reading/writing .exr needs the OpenEXR package (pip install OpenEXR)") from None
    return OpenEXR


def write_exr(path, rgba, depth, metadata, pixel_type="float32", value=None):
    """Write RGBA (float32 or half) and a float32 ``Z`` channel; metadata as header strings.

    ``value`` (a projection's scalar per pixel) goes to a float32 ``V`` channel. Row 0
    is the top row (OpenEXR's convention too).
    """
    if pixel_type not in EXR_TYPES:
        raise ValueError(f"pixel_type must be one of {list(EXR_TYPES)}; got {pixel_type!r}")
    OpenEXR = openexr_module()
    dtype = np.float16 if pixel_type == "float16" else np.float32
    with np.errstate(over="ignore"):
        rgba_out = np.ascontiguousarray(rgba, dtype=dtype)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header["pv_hdrvol"] = json.dumps(metadata, default=str)
    channels = {"RGBA": rgba_out, "Z": np.ascontiguousarray(depth, dtype=np.float32)}
    if value is not None:
        channels["V"] = np.ascontiguousarray(value, dtype=np.float32)
    check_writable(path)
    try:
        with OpenEXR.File(header, channels) as f:
            f.write(os.fspath(path))
    except RuntimeError as exc:  # OpenEXR's errors, e.g. a full disk
        raise OSError(f"cannot write {os.fspath(path)!r}: {exc}") from None


def read_exr(path):
    """Return ``(rgba float32 (rows, cols, 4), depth or None, metadata dict, value or None)``.

    Raises
    ------
    FileNotFoundError, IsADirectoryError, PermissionError
        As ``open(path)`` does.
    ValueError
        The file is not a readable OpenEXR image (another format, truncated, corrupt)
        or has no RGB(A) channels.
    """
    OpenEXR = openexr_module()
    with open(path, "rb") as f:  # Python's own errors for missing files, folders, permissions
        magic = f.read(4)
    if magic != EXR_MAGIC:
        raise ValueError(f"{os.fspath(path)!r} is not a readable OpenEXR image: it does not start with the OpenEXR "
                         f"magic number (another format, or empty)")
    try:
        with OpenEXR.File(os.fspath(path)) as f:
            header = dict(f.header())
            ch = {name: np.asarray(c.pixels, dtype=np.float32) for name, c in f.channels().items()}
    except (RuntimeError, ValueError) as exc:  # OpenEXR: "Invalid part index '0': file has 0 parts." and the like
        raise ValueError(f"{os.fspath(path)!r} is not a readable OpenEXR image (truncated or corrupt): {exc}") \
            from None
    if "RGBA" in ch:
        rgba = ch["RGBA"]
    elif "RGB" in ch:
        rgba = np.concatenate([ch["RGB"], np.ones(ch["RGB"].shape[:2] + (1,), np.float32)], axis=2)
    else:
        raise ValueError(f"{os.fspath(path)!r}: no RGB(A) channels (found {sorted(ch)})")
    depth, value = ch.get("Z"), ch.get("V")
    meta = {}
    raw = header.get("pv_hdrvol")
    if isinstance(raw, (bytes, str)):
        try:
            meta = json.loads(raw)
        except ValueError:
            meta = {"pv_hdrvol": raw}
    return rgba, depth, meta, value


def write_npy(path, rgba, depth):
    """``.npy``: one (rows, cols, 5) array, RGBA then depth, in the image's dtype."""
    stack = np.concatenate([rgba, depth[..., None].astype(rgba.dtype)], axis=2)
    np.save(os.fspath(path), stack)


def read_npy(path):
    """``(rgba, depth or None)`` of a file written by :func:`write_npy`; ``ValueError`` if it is not one."""
    try:
        arr = np.load(os.fspath(path), allow_pickle=False)
    except (ValueError, EOFError) as exc:  # not a .npy file (numpy talks of pickles), or an empty one
        raise ValueError(f"{os.fspath(path)!r} is not a readable .npy image: {exc}") from None
    if arr.ndim != 3 or arr.shape[2] not in (4, 5):
        raise ValueError(f"{path}: expected a (rows, cols, 4 or 5) array; got {arr.shape}")
    depth = arr[..., 4].astype(np.float64) if arr.shape[2] == 5 else None
    return np.ascontiguousarray(arr[..., :4]), depth


def write_png(target, rgb_u8):
    """Write ``rgb_u8`` ((rows, cols, 3 or 4) uint8, row 0 at the top) as a PNG to a path
    or a binary file object: a minimal writer (zlib, 8-bit RGB or RGBA), no imaging
    library needed."""
    import struct
    import zlib

    rgb_u8 = np.ascontiguousarray(rgb_u8, dtype=np.uint8)
    h, w, c = rgb_u8.shape
    color_type = {3: 2, 4: 6}[c]
    raw = b"".join(b"\x00" + rgb_u8[r].tobytes() for r in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, color_type, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b"")
    if hasattr(target, "write"):
        target.write(png)
    else:
        with open(os.fspath(target), "wb") as f:
            f.write(png)
