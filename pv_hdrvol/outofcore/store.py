"""Multiresolution stores in OME-Zarr: written with bounded memory, read chunk by chunk.

The format (``FORMAT`` = 1), an OME-Zarr 0.5 image (NGFF multiscales on zarr v3):

- arrays ``0, 1, ...``: level ``L`` has ``ceil(n / 2)`` points per axis of level
  ``L - 1``'s ``n``, from the 2x2x2 mean (NaN ignored; the last plane repeated on an odd
  axis) or mode (label volumes); down to the first level that fits one chunk. Inner
  chunks of ``CHUNK`` = 64 points a side in shards of at most ``SHARD_BYTES`` (one
  read per chunk, few files), blosc-zstd level 3 with byte shuffle; every chunk is
  written (``write_empty_chunks``), so a missing shard file is damage, not zeros.
- level ``L`` point ``j`` lies at level-0 voxel coordinate ``2**L j + (2**L - 1) / 2``
  (the centre of the points it averages): each dataset's ``scale`` is ``2**L`` times
  level 0's spacing and its ``translation`` the origin moved by ``(2**L - 1) / 2``
  spacings (HDR VolVis section 6.3, with the placement of methods.md C.4-13).
- ``pv_hdrvol/ranges/L``: per chunk of level ``L``, float64 ``(cz, cy, cx, 5)``:
  the minimum and maximum of its points (NaN ignored; ``+inf, -inf`` for no number),
  the largest ``|v - parent|`` of its points against the level-``L + 1`` point whose
  2x2x2 block holds them (0 on the coarsest level), and the minimum and maximum over
  all level-0 points below it (so a renderer knows which bricks are empty under a
  transfer function, at every level, without reading them).
- the group's attributes: ``ome`` (``version`` "0.5", ``multiscales``) and
  ``pv_hdrvol`` (``format``, ``chunk``, ``downsample``, ``spacing``, ``origin`` in
  x, y, z, ``name``, ``complete``). ``ome`` is written last, with ``complete: true``: a
  store being written, or interrupted, is refused by :class:`MultiscaleStore` and has
  no multiscales for other readers.
"""
from __future__ import annotations

import dataclasses
import math
import os
import shutil

import numpy as np

from .._validate import as_int

FORMAT = 1
CHUNK = 64
SHARD_BYTES = 16 * 2 ** 20
DOWNSAMPLE = ("mean", "mode")
_RANGE_FIELDS = ("min", "max", "error", "sub_min", "sub_max")


def _zarr():
    try:
        import zarr
    except ImportError:
        raise ImportError("multiresolution stores need zarr >= 3 (Python >= 3.11): pip install 'zarr>=3'") from None
    if int(zarr.__version__.split(".")[0]) < 3:
        raise ImportError(f"multiresolution stores need zarr >= 3 (OME-Zarr 0.5 is zarr v3); found {zarr.__version__}")
    return zarr


def level_shapes(shape, chunk=CHUNK):
    """Points (z, y, x) of every level: each ``ceil(n / 2)`` of the previous one, down
    to the first level whose every axis fits one chunk."""
    shapes = [tuple(int(n) for n in shape)]
    while max(shapes[-1]) > chunk:
        shapes.append(tuple((n + 1) // 2 for n in shapes[-1]))
    return shapes


def shard_edge(itemsize, chunk=CHUNK, limit=SHARD_BYTES):
    """Points a side of a shard: the largest ``chunk * 2**m`` whose cube of ``itemsize``-byte
    values is at most ``limit`` bytes (at least one chunk)."""
    edge = chunk
    while (2 * edge) ** 3 * itemsize <= limit:
        edge *= 2
    return edge


def _boxes(shape, edge):
    """Boxes ``((z0, z1), (y0, y1), (x0, x1))`` of ``edge`` points tiling ``shape``, z slowest."""
    ranges = [[(a, min(a + edge, n)) for a in range(0, n, edge)] for n in shape]
    return [(z, y, x) for z in ranges[0] for y in ranges[1] for x in ranges[2]]


def _chunk_ranges(block, chunk):
    """(cz, cy, cx, 2) min and max (NaN ignored) of each ``chunk``-cube of ``block``."""
    nz, ny, nx = block.shape
    cz, cy, cx = (-(-nz // chunk), -(-ny // chunk), -(-nx // chunk))
    out = np.empty((cz, cy, cx, 2))
    values = block.astype(np.float64, copy=False)
    for k in range(cz):
        for j in range(cy):
            for i in range(cx):
                part = values[k * chunk:(k + 1) * chunk, j * chunk:(j + 1) * chunk, i * chunk:(i + 1) * chunk]
                finite = part[~np.isnan(part)]
                out[k, j, i] = (finite.min(), finite.max()) if finite.size else (np.inf, -np.inf)
    return out


def _pad_even(block):
    """``block`` with its last plane repeated along every odd axis."""
    pad = [(0, n % 2) for n in block.shape]
    return np.pad(block, pad, mode="edge") if any(p[1] for p in pad) else block


def downsample_mean(block):
    """The 2x2x2 mean of ``block`` (z, y, x) in float64, NaN ignored (NaN where all 8 are);
    an odd axis repeats its last plane."""
    b = _pad_even(np.asarray(block, dtype=np.float64))
    nz, ny, nx = b.shape
    parts = b.reshape(nz // 2, 2, ny // 2, 2, nx // 2, 2)
    valid = ~np.isnan(parts)
    total = np.where(valid, parts, 0.0).sum(axis=(1, 3, 5))
    count = valid.sum(axis=(1, 3, 5))
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def downsample_mode(block):
    """The most frequent of each 2x2x2 group of ``block`` (labels; ties: the smallest)."""
    b = _pad_even(np.asarray(block))
    nz, ny, nx = b.shape
    parts = b.reshape(nz // 2, 2, ny // 2, 2, nx // 2, 2).transpose(0, 2, 4, 1, 3, 5).reshape(nz // 2, ny // 2,
                                                                                                nx // 2, 8)
    parts = np.sort(parts, axis=-1)
    counts = np.stack([(parts == parts[..., i:i + 1]).sum(axis=-1) for i in range(8)], axis=-1)
    best = np.argmax(counts, axis=-1)  # first of the largest count: the smallest value (sorted)
    return np.take_along_axis(parts, best[..., None], axis=-1)[..., 0]


@dataclasses.dataclass(frozen=True)
class _Source:
    shape: tuple  # (z, y, x)
    dtype: np.dtype
    read: object  # read(box) -> array of the box's shape
    spacing: tuple  # x, y, z
    origin: tuple
    name: str


def _as_source(source, shape, dtype, spacing, origin, name):
    """What :func:`write_multiscale` reads: shape, dtype, a reader of boxes, geometry."""
    from ..data.grid import GridVolume, as_volume

    def geometry(default_spacing=(1.0, 1.0, 1.0), default_origin=(0.0, 0.0, 0.0)):
        s = tuple(float(v) for v in (default_spacing if spacing is None else spacing))
        o = tuple(float(v) for v in (default_origin if origin is None else origin))
        if len(s) != 3 or len(o) != 3:
            raise ValueError(f"spacing and origin need 3 values (x, y, z); got {s} and {o}")
        if not all(math.isfinite(v) and v > 0 for v in s):
            raise ValueError(f"spacing must be finite and > 0 on every axis; got {s}")
        if not all(math.isfinite(v) for v in o):
            raise ValueError(f"origin must be finite; got {o}")
        return s, o

    if callable(source) and not hasattr(source, "shape"):
        if shape is None or dtype is None:
            raise ValueError("a function source fills boxes of a volume it does not describe: give shape=(nz, ny, nx) "
                             "and dtype=")
        shp = tuple(as_int("shape", n, low=1) for n in shape)
        if len(shp) != 3:
            raise ValueError(f"shape must be (nz, ny, nx); got {shape}")
        dt = np.dtype(dtype)

        def read(box):
            want = tuple(b - a for a, b in box)
            block = np.asarray(source(box))
            if block.shape != want:
                raise ValueError(f"the source function returned shape {block.shape} for the box {box}; expected {want}")
            return block

        s, o = geometry()
        return _Source(shp, dt, read, s, o, name or "")
    if not isinstance(source, np.ndarray) and hasattr(source, "shape") and hasattr(source, "dtype") \
            and not isinstance(source, GridVolume) and len(getattr(source, "shape", ())) == 3:
        arr = source  # an array-like that slices lazily: np.memmap, a zarr array
        s, o = geometry()
        return _Source(tuple(int(n) for n in arr.shape), np.dtype(arr.dtype),
                       lambda box: np.asarray(arr[box[0][0]:box[0][1], box[1][0]:box[1][1], box[2][0]:box[2][1]]),
                       s, o, name or "")
    if isinstance(source, np.ndarray):
        if source.ndim != 3:
            raise ValueError(f"a numpy source must be 3-D (z, y, x); got shape {source.shape}")
        arr = source
        s, o = geometry()
        vname = name or ""
    else:
        volume = as_volume(source)
        if volume.axes is not None:
            raise ValueError("a multiresolution store holds uniform grids; resample a rectilinear grid first")
        arr = volume.values
        s, o = geometry(volume.spacing, volume.origin)
        vname = name or volume.name
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise TypeError(f"a store holds real numbers; got dtype {arr.dtype}")
    return _Source(arr.shape, arr.dtype, lambda box: arr[box[0][0]:box[0][1], box[1][0]:box[1][1],
                                                             box[2][0]:box[2][1]], s, o, vname)


def _level_dtype(dtype, level, downsample):
    """Level 0 keeps the source's dtype; coarser means of integers are float32."""
    if level == 0 or downsample == "mode" or np.issubdtype(dtype, np.floating):
        return np.dtype(dtype)
    return np.dtype(np.float32)


def write_multiscale(source, path, *, shape=None, dtype=None, spacing=None, origin=None, name=None,
                     downsample="mean", overwrite=False, progress_bar=None):
    """Write a multiresolution OME-Zarr store (see the module's notes for the format).

    Parameters
    ----------
    source : array, np.memmap, zarr array, dataset, GridVolume or function
        The level-0 values, (z, y, x). A function ``f(box)`` returns the values of
        ``box = ((z0, z1), (y0, y1), (x0, x1))`` (procedural data, never held whole);
        it needs ``shape`` and ``dtype``.
    path : str or os.PathLike
        The store's directory (``*.ome.zarr`` by convention).
    spacing, origin : 3 floats (x, y, z)
        World geometry of level 0 (default: the dataset's, else 1 and 0).
    downsample : "mean" or "mode"
        How each level is made from the previous one: the 2x2x2 mean (NaN ignored) or,
        for label volumes, the most frequent value.
    overwrite : bool
        Replace an existing store at ``path`` (default: refuse).
    progress_bar : bool or None
        A tqdm bar over the shards written (None: when stderr is a terminal).

    Memory: one shard of the level being written and the eight of the level below
    (at most ``9 * SHARD_BYTES`` plus their float64 means), whatever the volume's size.

    Returns
    -------
    MultiscaleStore
        The finished store, opened.
    """
    zarr = _zarr()
    from zarr.codecs import BloscCodec

    if downsample not in DOWNSAMPLE:
        raise ValueError(f"downsample must be one of {DOWNSAMPLE}; got {downsample!r}")
    src = _as_source(source, shape, dtype, spacing, origin, name)
    if downsample == "mode" and not np.issubdtype(src.dtype, np.integer):
        raise ValueError(f"downsample='mode' is for label volumes (integers); got dtype {src.dtype}")
    path = os.fspath(path)
    if os.path.exists(path):
        if not overwrite:
            raise FileExistsError(f"{path} exists; pass overwrite=True to replace it")
        shutil.rmtree(path) if os.path.isdir(path) else os.remove(path)
    shapes = level_shapes(src.shape)
    from ..raycast.grid import _auto_bar_wanted, _check_progress_bar

    _check_progress_bar(progress_bar)
    edges = [shard_edge(_level_dtype(src.dtype, L, downsample).itemsize) for L in range(len(shapes))]
    total = sum(len(_boxes(s, e)) for s, e in zip(shapes, edges))
    bar = None
    if progress_bar or (progress_bar is None and _auto_bar_wanted()):
        try:
            from tqdm.auto import tqdm

            bar = tqdm(total=total, desc="Writing levels", unit="shards")
        except ImportError:
            if progress_bar:
                raise ImportError("progress_bar=True needs tqdm (pip install tqdm)") from None

    group = zarr.open_group(store=path, mode="w-", zarr_format=3)
    meta = {"format": FORMAT, "chunk": CHUNK, "downsample": downsample, "spacing": list(src.spacing),
            "origin": list(src.origin), "name": src.name, "complete": False}
    group.attrs.update({"pv_hdrvol": meta})
    arrays, ranges = [], []
    try:
        for level, (shp, edge) in enumerate(zip(shapes, edges)):
            dt = _level_dtype(src.dtype, level, downsample)
            arr = group.create_array(
                name=str(level), shape=shp, dtype=dt, chunks=(CHUNK,) * 3,
                shards=tuple(min(edge, CHUNK * -(-n // CHUNK)) for n in shp),
                compressors=BloscCodec(cname="zstd", clevel=3, shuffle="shuffle"),
                fill_value=np.nan if np.issubdtype(dt, np.floating) else 0,
                dimension_names=("z", "y", "x"), config={"write_empty_chunks": True})
            cz, cy, cx = (-(-n // CHUNK) for n in shp)
            rng = np.zeros((cz, cy, cx, 5))
            for box in _boxes(shp, edge):
                if level == 0:
                    block = src.read(box)
                else:
                    below = arrays[-1]
                    fine = below[2 * box[0][0]:min(2 * box[0][1], below.shape[0]),
                                 2 * box[1][0]:min(2 * box[1][1], below.shape[1]),
                                 2 * box[2][0]:min(2 * box[2][1], below.shape[2])]
                    coarse = downsample_mean(fine) if downsample == "mean" else downsample_mode(fine)
                    block = coarse.astype(dt)
                    # the fine chunks' largest difference to their parents (as stored)
                    parent = np.repeat(np.repeat(np.repeat(block.astype(np.float64), 2, 0), 2, 1), 2, 2)
                    parent = parent[:fine.shape[0], :fine.shape[1], :fine.shape[2]]
                    diff = np.abs(fine.astype(np.float64) - parent)
                    diff[np.isnan(diff)] = 0.0
                    c0 = [2 * b[0] // CHUNK for b in box]
                    err = _chunk_max(diff, CHUNK)
                    ranges[-1][c0[0]:c0[0] + err.shape[0], c0[1]:c0[1] + err.shape[1],
                               c0[2]:c0[2] + err.shape[2], 2] = err
                arr[box[0][0]:box[0][1], box[1][0]:box[1][1], box[2][0]:box[2][1]] = block
                c = [b[0] // CHUNK for b in box]
                r = _chunk_ranges(block, CHUNK)
                rng[c[0]:c[0] + r.shape[0], c[1]:c[1] + r.shape[1], c[2]:c[2] + r.shape[2], :2] = r
                if bar is not None:
                    bar.update(1)
            arrays.append(arr)
            ranges.append(rng)
        # the ranges over level-0 points below each chunk, from level 0 upwards
        for level, rng in enumerate(ranges):
            if level == 0:
                rng[..., 3:5] = rng[..., 0:2]
                continue
            prev = ranges[level - 1][..., 3:5]
            rng[..., 3] = _pool2(prev[..., 0], np.minimum, np.inf)[tuple(slice(0, n) for n in rng.shape[:3])]
            rng[..., 4] = _pool2(prev[..., 1], np.maximum, -np.inf)[tuple(slice(0, n) for n in rng.shape[:3])]
        for level, rng in enumerate(ranges):
            group.create_array(name=f"pv_hdrvol/ranges/{level}", data=rng, chunks=rng.shape,
                               attributes={"fields": list(_RANGE_FIELDS)})
        group.attrs.update({"ome": _ome_metadata(src, len(shapes), downsample),
                            "pv_hdrvol": dict(meta, complete=True)})
    finally:
        if bar is not None:
            bar.close()
    return MultiscaleStore(path)


def _chunk_max(values, chunk):
    nz, ny, nx = values.shape
    out = np.zeros((-(-nz // chunk), -(-ny // chunk), -(-nx // chunk)))
    for k in range(out.shape[0]):
        for j in range(out.shape[1]):
            for i in range(out.shape[2]):
                part = values[k * chunk:(k + 1) * chunk, j * chunk:(j + 1) * chunk, i * chunk:(i + 1) * chunk]
                out[k, j, i] = part.max() if part.size else 0.0
    return out


def _pool2(a, op, fill):
    """``op`` over each 2x2x2 group of ``a`` (padded with ``fill`` to even sizes)."""
    pad = [(0, n % 2) for n in a.shape]
    a = np.pad(a, pad, constant_values=fill)
    nz, ny, nx = a.shape
    return op.reduce(op.reduce(op.reduce(a.reshape(nz // 2, 2, ny // 2, 2, nx // 2, 2), axis=5), axis=3), axis=1)


def _ome_metadata(src, n_levels, downsample):
    sx, sy, sz = src.spacing
    ox, oy, oz = src.origin
    datasets = []
    for level in range(n_levels):
        f = float(2 ** level)
        shift = (f - 1.0) / 2.0
        datasets.append({"path": str(level), "coordinateTransformations": [
            {"type": "scale", "scale": [sz * f, sy * f, sx * f]},
            {"type": "translation", "translation": [oz + shift * sz, oy + shift * sy, ox + shift * sx]}]})
    return {"version": "0.5", "multiscales": [{
        "name": src.name or "volume",
        "axes": [{"name": a, "type": "space"} for a in "zyx"],
        "datasets": datasets,
        "type": downsample,
        "metadata": {"method": f"pv_hdrvol.write_multiscale (2x2x2 {downsample})"},
    }]}


@dataclasses.dataclass(frozen=True)
class Level:
    """One level of a store: ``shape`` (z, y, x) points, ``chunks`` (z, y, x) chunks,
    ``dtype``, and ``ranges`` (``(cz, cy, cx, 5)``: min, max, error, sub_min, sub_max)."""

    shape: tuple
    chunks: tuple
    dtype: np.dtype
    ranges: np.ndarray

    @property
    def dims(self):
        """Points along (x, y, z)."""
        return self.shape[::-1]


class MultiscaleStore:
    """A finished store, opened for reading (:func:`write_multiscale` writes one).

    Attributes
    ----------
    levels : list of :class:`Level`
    spacing, origin : ndarray (x, y, z)
        Level 0's geometry (level ``L``: see the module's notes).
    chunk : int
    name, downsample : str
    """

    def __init__(self, path):
        zarr = _zarr()
        self.path = os.fspath(path)
        if not os.path.isdir(self.path):
            raise FileNotFoundError(f"no multiresolution store at {self.path}")
        try:
            group = zarr.open_group(store=self.path, mode="r")
        except Exception as e:  # noqa: BLE001 - any failure to parse is "not a store"
            raise ValueError(f"{self.path} is not a zarr v3 group: {e}") from None
        attrs = dict(group.attrs)
        ours = attrs.get("pv_hdrvol")
        if not isinstance(ours, dict) or ours.get("format") != FORMAT:
            raise ValueError(f"{self.path} is not a pv_hdrvol multiresolution store (format {FORMAT}); write one with "
                             f"pv_hdrvol.write_multiscale or pv-hdrvol convert")
        if not ours.get("complete") or "ome" not in attrs:
            raise ValueError(f"{self.path} is incomplete: it is being written or its writing was interrupted "
                             f"(write it again)")
        self._group = group
        self.chunk = int(ours["chunk"])
        self.spacing = np.array(ours["spacing"], dtype=np.float64)
        self.origin = np.array(ours["origin"], dtype=np.float64)
        self.name = ours.get("name", "")
        self.downsample = ours.get("downsample", "mean")
        datasets = attrs["ome"]["multiscales"][0]["datasets"]
        self._arrays, self.levels = [], []
        for level, d in enumerate(datasets):
            arr = group[d["path"]]
            ranges = np.asarray(group[f"pv_hdrvol/ranges/{level}"][...])
            self._arrays.append(arr)
            self.levels.append(Level(tuple(arr.shape), tuple(ranges.shape[:3]), np.dtype(arr.dtype), ranges))
        self.bytes_read = [0] * len(self.levels)
        self.chunks_read = [0] * len(self.levels)

    @property
    def n_levels(self):
        return len(self.levels)

    @property
    def dtype(self):
        return self.levels[0].dtype

    @property
    def dims(self):
        """Level 0's points along (x, y, z)."""
        return self.levels[0].dims

    @property
    def bounds(self):
        """World bounds of level 0's points (xmin, xmax, ymin, ymax, zmin, zmax)."""
        hi = self.origin + (np.array(self.dims) - 1) * self.spacing
        return tuple(float(v) for pair in zip(self.origin, hi) for v in pair)

    @property
    def value_range(self):
        """Minimum and maximum of the level-0 points (NaN ignored)."""
        r = self.levels[0].ranges
        lo, hi = float(r[..., 0].min()), float(r[..., 1].max())
        return (lo, hi) if lo <= hi else (0.0, 0.0)

    def chunk_path(self, level, index):
        """The file that holds chunk ``index`` (z, y, x) of ``level`` (its shard)."""
        arr = self._arrays[level]
        shard = arr.shards or arr.chunks
        s = [i * self.chunk // e for i, e in zip(index, shard)]
        return os.path.join(self.path, str(level), "c", *(str(v) for v in s))

    def read_chunk(self, level, index):
        """The points of chunk ``index = (cz, cy, cx)`` of ``level`` (at most ``chunk`` a
        side; smaller at the far edges). Raises ``OSError`` naming the chunk and its file
        when the file is missing or cannot be decoded: never zeros or NaN in its place."""
        arr = self._arrays[level]
        c = self.chunk
        where = f"chunk {tuple(index)} of level {level} ({self.chunk_path(level, index)})"
        if not os.path.exists(self.chunk_path(level, index)):
            raise OSError(f"{self.path}: {where} is missing: the store is damaged (write it again)")
        box = tuple(slice(i * c, min((i + 1) * c, n)) for i, n in zip(index, arr.shape))
        try:
            block = np.asarray(arr[box])
        except Exception as e:  # noqa: BLE001 - zarr/numcodecs raise many kinds for bad bytes
            raise OSError(f"{self.path}: {where} cannot be read: {type(e).__name__}: {e}") from None
        self.bytes_read[level] += block.nbytes
        self.chunks_read[level] += 1
        return block

    def read_level(self, level):
        """A whole level as one array (for small levels and tests)."""
        return np.asarray(self._arrays[level][...])

    def level_geometry(self, level):
        """``(spacing, origin)`` (x, y, z) of ``level``'s points in world coordinates."""
        f = float(2 ** level)
        return self.spacing * f, self.origin + (f - 1.0) / 2.0 * self.spacing

    def __repr__(self):
        return (f"MultiscaleStore({self.path!r}, {self.n_levels} levels, level 0 {self.dims} points of "
                f"{self.dtype})")


__all__ = ["CHUNK", "FORMAT", "Level", "MultiscaleStore", "downsample_mean", "downsample_mode", "level_shapes",
           "shard_edge", "write_multiscale"]
