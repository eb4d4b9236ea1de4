"""OpenEXR and numpy storage of HDR images."""
from __future__ import annotations

import json
import os

import numpy as np

EXR_TYPES = ("float32", "float16")


def _openexr():
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
    OpenEXR = _openexr()
    dtype = np.float16 if pixel_type == "float16" else np.float32
    with np.errstate(over="ignore"):
        rgba_out = np.ascontiguousarray(rgba, dtype=dtype)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header["pv_hdrvol"] = json.dumps(metadata, default=str)
    channels = {"RGBA": rgba_out, "Z": np.ascontiguousarray(depth, dtype=np.float32)}
    if value is not None:
        channels["V"] = np.ascontiguousarray(value, dtype=np.float32)
    with OpenEXR.File(header, channels) as f:
        f.write(os.fspath(path))


def read_exr(path):
    """Return ``(rgba float32 (rows, cols, 4), depth or None, metadata dict, value or None)``."""
    OpenEXR = _openexr()
    with OpenEXR.File(os.fspath(path)) as f:
        ch = f.channels()
        header = dict(f.header())
        if "RGBA" in ch:
            rgba = np.asarray(ch["RGBA"].pixels, dtype=np.float32)
        elif "RGB" in ch:
            rgb = np.asarray(ch["RGB"].pixels, dtype=np.float32)
            rgba = np.concatenate([rgb, np.ones(rgb.shape[:2] + (1,), np.float32)], axis=2)
        else:
            raise ValueError(f"{path}: no RGB(A) channels (found {sorted(ch)})")
        depth = np.asarray(ch["Z"].pixels, dtype=np.float32) if "Z" in ch else None
        value = np.asarray(ch["V"].pixels, dtype=np.float32) if "V" in ch else None
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
    arr = np.load(os.fspath(path), allow_pickle=False)
    if arr.ndim != 3 or arr.shape[2] not in (4, 5):
        raise ValueError(f"{path}: expected a (rows, cols, 4 or 5) array; got {arr.shape}")
    depth = arr[..., 4].astype(np.float64) if arr.shape[2] == 5 else None
    return np.ascontiguousarray(arr[..., :4]), depth
