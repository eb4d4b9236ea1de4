"""Radiance ``.hdr`` (RGBE) files: read and write linear RGB images.

A Radiance picture stores each pixel in four bytes: three 8-bit mantissas and one
shared exponent (Ward 1991). The file is a text header (``#?RADIANCE``, ``NAME=value``
lines, a blank line), a resolution string such as ``-Y 480 +X 640`` and the scanlines,
each either flat (4 bytes a pixel) or run-length encoded one component at a time.

Encoding a pixel whose largest component is ``v = m 2**e`` (``0.5 <= m < 1``) stores
``floor(c 2**(8 - e))`` for each component ``c`` and ``e + 128``; pixels with
``v < 1e-32`` are stored as four zero bytes. Decoding follows Radiance's own
``colr_color``: the centre of the mantissa bin, ``c = (byte + 0.5) 2**(E - 136)``, and
0 where ``E == 0``. So every component comes back within half a mantissa step,
``2**(e - 9)``, of the value written. (Bruce Walter's ``rgbe.c``, used by OpenCV,
decodes ``byte 2**(E - 136)`` without the half step: its values are lower than ours by
exactly ``2**(E - 137)`` per component.)

The run-length coding is the "new" Radiance scheme: a scanline of width 8 to 32767
starts with the bytes ``2, 2, width >> 8, width & 255``; then the R, G, B and E bytes of
the scanline follow one component after another, as packets ``(128 + n, value)`` for a
run of ``n <= 127`` equal bytes and ``(n, n bytes)`` for ``n <= 128`` literal bytes.
Narrower or wider scanlines are stored flat. Kernels are private numba functions in
this module; the public functions validate, allocate and raise.

References
----------
.. [1] G. Ward, "Real Pixels", in Graphics Gems II, J. Arvo (ed.), Academic Press,
   1991, pp. 80-83.
.. [2] G. Ward, "The RADIANCE Picture File Format", Radiance reference manual
   (``ray/src/common/color.c``: ``fwritecolrs``, ``freadcolrs``, ``colr_color``).
.. [3] B. Walter, ``rgbe.c`` (1995), the reference RLE writer followed here.
"""
from __future__ import annotations

import json
import math
import os
import re

import numpy as np

from .._jit import kernel as _kernel

__all__ = ["read_hdr", "write_hdr"]

#: The only pixel format read and written.
FORMAT_RGBE = "32-bit_rle_rgbe"
#: Scanline widths outside this range cannot be run-length encoded.
_RLE_MIN_WIDTH, _RLE_MAX_WIDTH = 8, 0x7FFF
#: Largest component value an RGBE pixel can hold is just below 2**127 (exponent 255).
_MAX_VALUE = 2.0 ** 127
_MAGICS = (b"#?RADIANCE", b"#?RGBE")
_METADATA_KEY = "PV_HDRVOL="

# kernel status codes (returned, since kernels raise nothing)
_OK, _TRUNCATED, _BAD_RUN, _BAD_WIDTH, _NO_PREVIOUS = 0, 1, 2, 3, 4

# -- kernels ---------------------------------------------------------------------------
@_kernel
def _rle_component(data, n, out, pos):
    """Run-length encode ``data[:n]`` (one component of a scanline) into ``out[pos:]``.

    A port of Walter's ``RGBE_WriteBytes_RLE``: runs of at least 4 equal bytes become
    run packets, as does a run of 2 or 3 that directly precedes one; everything else
    becomes literal packets of at most 128 bytes. Returns the new ``pos``.
    """
    cur = 0
    while cur < n:
        beg_run = cur
        run_count = 0
        old_run_count = 0
        while run_count < 4 and beg_run < n:
            beg_run += run_count
            old_run_count = run_count
            run_count = 1
            while beg_run + run_count < n and run_count < 127 and data[beg_run] == data[beg_run + run_count]:
                run_count += 1
        if old_run_count > 1 and old_run_count == beg_run - cur:
            out[pos] = 128 + old_run_count
            out[pos + 1] = data[cur]
            pos += 2
            cur = beg_run
        while cur < beg_run:
            count = min(beg_run - cur, 128)
            out[pos] = count
            pos += 1
            for i in range(count):
                out[pos + i] = data[cur + i]
            pos += count
            cur += count
        if run_count >= 4:
            out[pos] = 128 + run_count
            out[pos + 1] = data[beg_run]
            pos += 2
            cur += run_count
    return pos


@_kernel
def _encode(rgb, rle, out):
    """Write the scanlines of ``rgb`` (rows, cols, 3) float64 into ``out``; return the length.

    ``rgb`` holds finite values in ``[0, 2**127)``; ``out`` has room for
    ``rows * (4 + 8 * cols)`` bytes, the worst case of the run-length coding.
    """
    rows = rgb.shape[0]
    cols = rgb.shape[1]
    line = np.empty((4, cols), np.uint8)
    use_rle = rle and cols >= 8 and cols <= 0x7FFF
    pos = 0
    for r in range(rows):
        for c in range(cols):
            red = rgb[r, c, 0]
            green = rgb[r, c, 1]
            blue = rgb[r, c, 2]
            v = max(red, max(green, blue))
            if v < 1e-32:
                line[0, c] = 0
                line[1, c] = 0
                line[2, c] = 0
                line[3, c] = 0
            else:
                m, e = math.frexp(v)
                # m * 256 / v is exactly 2**(8 - e), so each byte is floor(c 2**(8 - e)) <= 255
                scale = m * 256.0 / v
                line[0, c] = int(red * scale)
                line[1, c] = int(green * scale)
                line[2, c] = int(blue * scale)
                line[3, c] = e + 128
        if use_rle:
            out[pos] = 2
            out[pos + 1] = 2
            out[pos + 2] = cols >> 8
            out[pos + 3] = cols & 255
            pos += 4
            for k in range(4):
                pos = _rle_component(line[k], cols, out, pos)
        else:
            for c in range(cols):
                for k in range(4):
                    out[pos + k] = line[k, c]
                pos += 4
    return pos


@_kernel
def _decode(data, rows, cols, flip, scales, out):
    """Decode the scanlines in ``data`` into ``out`` (rows, cols, 3) float32.

    Each scanline is new-style run-length encoded when it starts with ``2, 2`` and a
    width byte below 128, otherwise flat (with Radiance's old run coding: a pixel
    ``1, 1, 1, n`` repeats the previous pixel ``n << shift`` times, ``shift`` growing
    by 8 for each such pixel in a row). ``flip``: the first scanline is the bottom
    row. ``scales[E]`` is ``2**(E - 136)``. Returns ``(status, scanline index)``.
    """
    n = data.shape[0]
    line = np.empty((4, cols), np.uint8)
    pos = 0
    for y in range(rows):
        if (cols >= 8 and cols <= 0x7FFF and pos + 4 <= n and data[pos] == 2 and data[pos + 1] == 2
                and data[pos + 2] < 128):
            if (int(data[pos + 2]) << 8 | int(data[pos + 3])) != cols:
                return _BAD_WIDTH, y
            pos += 4
            for k in range(4):
                c = 0
                while c < cols:
                    if pos >= n:
                        return _TRUNCATED, y
                    count = int(data[pos])
                    if count > 128:
                        count -= 128
                        if count > cols - c:
                            return _BAD_RUN, y
                        if pos + 2 > n:
                            return _TRUNCATED, y
                        value = data[pos + 1]
                        for i in range(count):
                            line[k, c + i] = value
                        pos += 2
                    else:
                        # a literal of 0 bytes is a no-op, as in Radiance's freadcolrs
                        if count > cols - c:
                            return _BAD_RUN, y
                        if pos + 1 + count > n:
                            return _TRUNCATED, y
                        for i in range(count):
                            line[k, c + i] = data[pos + 1 + i]
                        pos += 1 + count
                    c += count
        else:
            c = 0
            shift = 0
            while c < cols:
                if pos + 4 > n:
                    return _TRUNCATED, y
                if data[pos] == 1 and data[pos + 1] == 1 and data[pos + 2] == 1:
                    if shift > 24:
                        return _BAD_RUN, y
                    count = int(data[pos + 3]) << shift
                    if count > cols - c:
                        return _BAD_RUN, y
                    if c == 0 and y == 0 and count > 0:
                        return _NO_PREVIOUS, y
                    # at c == 0 the previous pixel is the last one of the previous scanline,
                    # still in the buffer
                    p = c - 1 if c > 0 else cols - 1
                    for i in range(count):
                        for k in range(4):
                            line[k, c + i] = line[k, p]
                    c += count
                    shift += 8
                else:
                    for k in range(4):
                        line[k, c] = data[pos + k]
                    c += 1
                    shift = 0
                pos += 4
        r = rows - 1 - y if flip else y
        for c in range(cols):
            e = line[3, c]
            if e == 0:
                out[r, c, 0] = 0.0
                out[r, c, 1] = 0.0
                out[r, c, 2] = 0.0
            else:
                f = scales[e]
                out[r, c, 0] = (line[0, c] + 0.5) * f
                out[r, c, 1] = (line[1, c] + 0.5) * f
                out[r, c, 2] = (line[2, c] + 0.5) * f
    return _OK, rows


#: ``2**(E - 136)`` for every exponent byte E (E = 0 means a black pixel).
_SCALES = np.ldexp(1.0, np.arange(256) - 136)


# -- public functions ------------------------------------------------------------------
def write_hdr(path, rgb, metadata=None, *, rle=True):
    """Write a linear RGB image as a Radiance ``.hdr`` (RGBE) file.

    Parameters
    ----------
    path : str or os.PathLike
        File to write (overwritten).
    rgb : array_like, shape (rows, cols, 3), real numbers
        Linear light, row 0 at the top; finite, non-negative and below ``2**127``
        (about 1.7e38). Not modified.
    metadata : dict, optional
        JSON-serialisable values, written as one header line ``PV_HDRVOL=<json>`` and
        returned by :func:`read_hdr` as ``header["metadata"]``.
    rle : bool, default True
        Run-length encode the scanlines (Radiance's "new" coding). Scanlines narrower
        than 8 or wider than 32767 pixels are always written flat, as the format
        requires.

    Raises
    ------
    ValueError
        If ``rgb`` does not have shape (rows, cols, 3) with rows, cols >= 1, or holds
        NaN, infinite, negative or too large values.
    TypeError
        If ``rgb`` is not real-valued or ``metadata`` is not a JSON-serialisable dict.

    Notes
    -----
    A pixel with largest component ``v = m 2**e`` (``0.5 <= m < 1``) is stored as the
    bytes ``floor(c 2**(8 - e))`` of its components and ``e + 128``: each component
    keeps 8 bits relative to the brightest one, about 2 decimal digits. A pixel with
    ``v < 1e-32`` is stored as black. The header is ``#?RADIANCE``, the metadata
    line, ``FORMAT=32-bit_rle_rgbe``, a blank line and ``-Y rows +X cols``;
    ``FORMAT`` comes last because readers derived from Walter's ``rgbe.c`` expect
    the blank line right after it.

    Examples
    --------
    >>> import os, tempfile, numpy as np
    >>> from pv_hdrvol.image.rgbe import read_hdr, write_hdr
    >>> path = os.path.join(tempfile.mkdtemp(), "grey.hdr")
    >>> write_hdr(path, np.full((2, 3, 3), 1.99609375), {"units": "W/sr/m2"})
    >>> rgb, header = read_hdr(path)
    >>> rgb.shape, float(rgb[1, 2, 0]), header["metadata"]
    ((2, 3, 3), 1.99609375, {'units': 'W/sr/m2'})
    """
    path = os.fspath(path)
    meta_line = b""
    if metadata is not None:
        if not isinstance(metadata, dict):
            raise TypeError(f"metadata must be a dict or None; got {type(metadata).__name__}")
        try:
            text = json.dumps(metadata)
        except TypeError as err:
            raise TypeError(f"metadata must be JSON-serialisable (str keys; str, int, float, bool, None, "
                            f"list and dict values): {err}") from None
        # ensure_ascii (json's default) escapes newlines and non-ASCII: one ASCII line
        meta_line = (_METADATA_KEY + text + "\n").encode("ascii")

    arr = np.asarray(rgb)
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"rgb must hold real numbers (float or integer dtype); got dtype {arr.dtype}")
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValueError(f"rgb must have shape (rows, cols, 3); got {arr.shape}")
    rows, cols = arr.shape[:2]
    if rows < 1 or cols < 1:
        raise ValueError(f"rgb must have at least one row and one column; got shape {arr.shape}")
    # no copy when already float64 and C-contiguous: the kernel only reads it
    values = np.ascontiguousarray(arr, dtype=np.float64)
    lo, hi = values.min(), values.max()
    if not (lo >= 0.0 and hi < _MAX_VALUE):
        n_nan = int(np.isnan(values).sum())
        n_inf = int(np.isinf(values).sum())
        n_neg = int((values < 0).sum()) - int((values == -np.inf).sum())
        if n_nan or n_inf or n_neg:
            raise ValueError(f"Radiance RGBE stores finite non-negative values; rgb has {n_nan} NaN, "
                             f"{n_inf} infinite and {n_neg} negative values")
        n_big = int((values >= _MAX_VALUE).sum())
        raise ValueError(f"Radiance RGBE stores values below 2**127 (about 1.7e38); rgb has {n_big} values "
                         f"at or above it (largest {hi:.4g})")

    body = np.empty(rows * (4 + 8 * cols), np.uint8)
    size = _encode(values, bool(rle), body)
    header = b"#?RADIANCE\n" + meta_line + b"FORMAT=" + FORMAT_RGBE.encode() + b"\n\n"
    header += b"-Y %d +X %d\n" % (rows, cols)
    with open(path, "wb") as f:
        f.write(header)
        f.write(memoryview(body[:size]))


_RESOLUTION = re.compile(rb"^([-+])Y (\d+) \+X (\d+)$")
_ANY_RESOLUTION = re.compile(rb"^[-+][XY] \d+ [-+][XY] \d+$")


def read_hdr(path):
    """Read a Radiance ``.hdr`` (RGBE) file.

    Parameters
    ----------
    path : str or os.PathLike
        A file starting with ``#?RADIANCE`` or ``#?RGBE``, pixel format
        ``32-bit_rle_rgbe`` (the default when no ``FORMAT`` line is present), and the
        resolution string ``-Y rows +X cols`` (top to bottom) or ``+Y rows +X cols``
        (bottom to top); scanlines flat or run-length encoded (new or old style).

    Returns
    -------
    rgb : ndarray, shape (rows, cols, 3), float32
        Linear values as stored, row 0 at the top. ``EXPOSURE`` is *not* applied:
        divide by ``header["exposure"]`` for the values before any exposure change.
    header : dict
        ``"format"`` (str), ``"exposure"`` (float: the product of the ``EXPOSURE=``
        lines, 1.0 if none), ``"metadata"`` (the dict of the ``PV_HDRVOL=`` line,
        ``{}`` if none) and ``"lines"`` (list of str: the other header lines, without
        the ``#?`` line).

    Raises
    ------
    ValueError
        If the file is not a Radiance picture, is XYZE or another format, has an
        unsupported orientation, or its data are truncated or corrupt.

    Notes
    -----
    A component with mantissa byte ``b`` and exponent byte ``E > 0`` decodes to
    ``(b + 0.5) 2**(E - 136)``, the centre of its bin, as Radiance's ``colr_color``
    does (readers following Walter's ``rgbe.c``, OpenCV among them, omit the 0.5 and
    read values lower by ``2**(E - 137)``); ``E == 0`` decodes to 0.

    Examples
    --------
    >>> import os, tempfile, numpy as np
    >>> from pv_hdrvol.image.rgbe import read_hdr, write_hdr
    >>> path = os.path.join(tempfile.mkdtemp(), "dark.hdr")
    >>> write_hdr(path, np.zeros((4, 16, 3)))
    >>> rgb, header = read_hdr(path)
    >>> rgb.dtype, float(rgb.max()), header["exposure"], header["format"]
    (dtype('float32'), 0.0, 1.0, '32-bit_rle_rgbe')
    """
    path = os.fspath(path)
    fmt = None
    exposure = 1.0
    metadata = {}
    lines = []
    with open(path, "rb") as f:
        first = f.readline()
        if not first.startswith(_MAGICS):
            raise ValueError(f"{path!s} is not a Radiance picture: it starts with {first[:16]!r}, "
                             f"not #?RADIANCE or #?RGBE")
        while True:
            raw = f.readline()
            if not raw:
                raise ValueError(f"{path!s}: the header has no end (no blank line before the resolution)")
            text = raw.decode("latin-1").rstrip("\r\n")
            if not text:
                break
            if text.startswith("FORMAT="):
                fmt = text[len("FORMAT="):].strip()
                if fmt == "32-bit_rle_xyze":
                    raise ValueError(f"{path!s} holds XYZE pixels (FORMAT=32-bit_rle_xyze); "
                                     f"XYZE is not supported, only {FORMAT_RGBE}")
                if fmt != FORMAT_RGBE:
                    raise ValueError(f"{path!s}: unsupported FORMAT={fmt!r}; only {FORMAT_RGBE} is supported")
            elif text.startswith("EXPOSURE="):
                try:
                    exposure *= float(text[len("EXPOSURE="):])
                except ValueError:
                    raise ValueError(f"{path!s}: bad header line {text!r}: EXPOSURE must be a number") from None
            elif text.startswith(_METADATA_KEY):
                try:
                    value = json.loads(text[len(_METADATA_KEY):])
                except ValueError as err:
                    raise ValueError(f"{path!s}: bad {_METADATA_KEY} header line ({err})") from None
                if not isinstance(value, dict):
                    raise ValueError(f"{path!s}: the {_METADATA_KEY} header line holds a "
                                     f"{type(value).__name__}, not a JSON object")
                metadata.update(value)
            else:
                lines.append(text)
        resolution = f.readline(256).rstrip(b"\r\n").strip()
        match = _RESOLUTION.match(resolution)
        if match is None:
            if _ANY_RESOLUTION.match(resolution):
                raise ValueError(f"{path!s}: unsupported orientation {resolution.decode('latin-1')!r}; only "
                                 f"'-Y rows +X cols' (top to bottom) and '+Y rows +X cols' (bottom to top)")
            raise ValueError(f"{path!s}: bad resolution string {resolution[:40]!r}; expected '-Y rows +X cols'")
        rows, cols = int(match.group(2)), int(match.group(3))
        data = np.empty(max(os.fstat(f.fileno()).st_size - f.tell(), 0), np.uint8)
        data = data[:f.readinto(data)]

    rgb = np.empty((rows, cols, 3), np.float32)
    status, scanline = _decode(data, rows, cols, match.group(1) == b"+", _SCALES, rgb)
    if status != _OK:
        where = f"scanline {scanline + 1} of {rows}"
        if status == _TRUNCATED:
            raise ValueError(f"{path!s}: truncated {where}: the file ends after {data.size} bytes of pixel data")
        if status == _BAD_WIDTH:
            raise ValueError(f"{path!s}: run-length encoded {where} does not have the width {cols}")
        if status == _NO_PREVIOUS:
            raise ValueError(f"{path!s}: {where} starts with a repeat of a previous pixel, but there is none")
        raise ValueError(f"{path!s}: bad run-length data in {where} (a run longer than the scanline)")
    header = {"format": fmt or FORMAT_RGBE, "exposure": exposure, "metadata": metadata, "lines": lines}
    return rgb, header
