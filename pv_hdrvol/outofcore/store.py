"""Multiresolution stores in OME-Zarr: written with bounded memory, read chunk by chunk.

The format (``FORMAT`` = 1), an OME-Zarr 0.5 image (NGFF multiscales on zarr v3):

- arrays ``0, 1, ...``: level ``L`` has ``ceil(n / 2)`` points per axis of level
  ``L - 1``'s ``n``, from the 2x2x2 mean (NaN ignored; the last plane repeated on an odd
  axis) or mode (label volumes); down to the first level that fits one chunk. Inner
  chunks of ``chunk`` points a side (``pv_hdrvol.chunk``; default ``CHUNK`` = 64) in
  shards of at most ``SHARD_BYTES`` (one read per chunk, few files), blosc-zstd level
  3 with byte shuffle, then a crc32c checksum (a damaged chunk fails to read rather
  than decoding to wrong numbers); every chunk is written (``write_empty_chunks``), so
  a missing shard file is damage, not zeros.
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

import concurrent.futures
import dataclasses
import errno
import math
import os
import shutil

import numpy as np

from .._validate import as_int

FORMAT = 1
CHUNK = 64
#: Points a side of the groups whose value ranges ``pv_hdrvol/groups`` keeps (level 0).
GROUP = 8
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
    out = np.empty((-(-nz // chunk), -(-ny // chunk), -(-nx // chunk), 2))
    floating = np.issubdtype(block.dtype, np.floating)
    for k in range(out.shape[0]):
        for j in range(out.shape[1]):
            for i in range(out.shape[2]):
                part = block[k * chunk:(k + 1) * chunk, j * chunk:(j + 1) * chunk, i * chunk:(i + 1) * chunk]
                if floating:
                    part = part[~np.isnan(part)]
                out[k, j, i] = (float(part.min()), float(part.max())) if part.size else (np.inf, -np.inf)
    return out


def group_ranges(block, group=None):
    """(gz, gy, gx, 2) min and max (NaN ignored; ``+inf, -inf`` for none) of each
    ``group``-cube of points of ``block`` (default :data:`GROUP`), as float64. Works in
    the block's dtype (a partial group at a far edge repeats the edge: no value changes)."""
    group = GROUP if group is None else group
    g = [-(-n // group) for n in block.shape]
    pad = [(0, gi * group - n) for gi, n in zip(g, block.shape)]
    b = np.pad(block, pad, mode="edge") if any(p[1] for p in pad) else np.ascontiguousarray(block)
    parts = b.reshape(g[0], group, g[1], group, g[2], group)
    lo = np.fmin.reduce(np.fmin.reduce(np.fmin.reduce(parts, axis=5), axis=3), axis=1).astype(np.float64)
    hi = np.fmax.reduce(np.fmax.reduce(np.fmax.reduce(parts, axis=5), axis=3), axis=1).astype(np.float64)
    none = np.isnan(lo)  # fmin/fmax give NaN only where every value is NaN
    lo[none] = np.inf
    hi[none] = -np.inf
    return np.stack([lo, hi], axis=-1)


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
    with np.errstate(invalid="ignore", divide="ignore"):  # inf + -inf: NaN, as numpy's mean gives
        total = np.where(valid, parts, 0.0).sum(axis=(1, 3, 5))
        count = valid.sum(axis=(1, 3, 5))
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
    dtype: np.dtype  # native byte order: the store's level-0 dtype
    read: object  # read(box) -> array of the box's shape and of ``dtype`` (never the caller's memory)
    spacing: tuple  # x, y, z
    origin: tuple
    name: str


def _real_dtype(what, dtype):
    """``dtype`` as a native-order numpy dtype of integers or floats (TypeError otherwise)."""
    try:
        dt = np.dtype(dtype)
    except TypeError:
        raise TypeError(f"dtype must be a numpy dtype of integers or floats; got {dtype!r}") from None
    if dt == np.bool_ or not (np.issubdtype(dt, np.integer) or np.issubdtype(dt, np.floating)):
        raise TypeError(f"{what} must hold real numbers (integers or floats); got dtype {dt}")
    return dt.newbyteorder("=")


def _shape3(what, shape):
    if isinstance(shape, (str, bytes)) or not hasattr(shape, "__len__") or len(shape) != 3:
        raise ValueError(f"{what} must be 3 sizes (nz, ny, nx); got {shape!r}")
    return tuple(as_int(what, n, low=1) for n in shape)


def _vector3(what, value, positive):
    try:
        v = tuple(float(x) for x in value)
    except (TypeError, ValueError):
        raise TypeError(f"{what} must be 3 numbers (x, y, z); got {value!r}") from None
    if len(v) != 3:
        raise ValueError(f"{what} must be 3 numbers (x, y, z); got {len(v)}: {value!r}")
    if positive and not all(math.isfinite(x) and x > 0 for x in v):
        raise ValueError(f"{what} must be finite and > 0 on every axis; got {v}")
    if not all(math.isfinite(x) for x in v):
        raise ValueError(f"{what} must be finite; got {v}")
    return v


def _box_slices(box):
    return tuple(slice(a, b) for a, b in box)


def _raw_memmap(path, shape, dtype):
    """A read-only ``np.memmap`` of the raw file ``path`` (z, y, x; x fastest)."""
    if shape is None or dtype is None:
        raise ValueError(f"a .raw file holds no shape or dtype: give shape=(nz, ny, nx) and dtype= for {path!r}")
    shp = _shape3("shape", shape)
    dt = _real_dtype("a .raw file", dtype)
    dt = np.dtype(dtype)  # the file's byte order, as given ('>f4' reads big-endian)
    want = math.prod(shp) * dt.itemsize
    size = os.path.getsize(path)
    if size != want:
        raise ValueError(f"{path!r} has {size} bytes; shape {shp} of {dt} needs {want} "
                         f"({' x '.join(map(str, shp))} x {dt.itemsize} bytes)")
    return np.memmap(path, dtype=dt, mode="r", shape=shp)


def _read_file(path, shape, dtype, scalars):
    """The array (z, y, x), spacing, origin and name of a volume file: ``.raw`` (with
    ``shape`` and ``dtype``) or one that :mod:`pv_hdrvol.data.files` reads."""
    p = os.fspath(path)
    if not os.path.exists(p):
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), p)
    if p.lower().endswith(".raw"):
        if scalars is not None:
            raise ValueError(f"scalars names an array of a dataset; a .raw file has one: got {scalars!r}")
        return _raw_memmap(p, shape, dtype), None, None, os.path.splitext(os.path.basename(p))[0]
    if shape is not None or dtype is not None:
        raise ValueError(f"shape and dtype describe a .raw file or a function source; {p!r} has its own")
    from ..data.grid import image_array
    from ..data.kinds import as_renderable
    from ..data.files import IMAGE_FORMATS, READABLE, read_dataset

    dataset = read_dataset(p, READABLE)
    if getattr(dataset, "GetClassName", lambda: "")() in ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid"):
        # the file's own dtype (a GridVolume may hold a float32 copy of integers)
        arr, spacing, origin, name = image_array(dataset, scalars, "point")
        return arr, spacing, origin, name
    volume = as_renderable(dataset, scalars=scalars)
    from ..data.grid import GridVolume

    if not isinstance(volume, GridVolume):
        raise ValueError(f"{p!r} holds a {type(volume).__name__}; a multiresolution store is made of an image "
                         f"volume ({', '.join(IMAGE_FORMATS)} or .raw)")
    if volume.axes is not None:
        raise ValueError(f"{p!r} holds a rectilinear grid; a multiresolution store holds uniform grids "
                         f"(resample it first)")
    return volume.values, volume.spacing, volume.origin, volume.name


def _as_source(source, shape, dtype, spacing, origin, name, scalars=None):
    """What :func:`write_multiscale` reads: shape, dtype, a reader of boxes, geometry."""
    from ..data.grid import GridVolume, image_array

    default_spacing, default_origin, default_name = (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), ""
    if isinstance(source, (str, os.PathLike)):
        arr, sp, org, default_name = _read_file(source, shape, dtype, scalars)
        if sp is not None:
            default_spacing, default_origin = sp, org
        shape = dtype = None
        kind = f"the file {os.fspath(source)!r}"
    elif callable(source) and not hasattr(source, "shape"):
        if shape is None or dtype is None:
            raise ValueError("a function source fills boxes of a volume it does not describe: give "
                             "shape=(nz, ny, nx) and dtype=")
        arr, kind = None, "a function source"
    elif isinstance(source, GridVolume):
        if source.axes is not None:
            raise ValueError("a multiresolution store holds uniform grids; resample a rectilinear grid first")
        arr, default_spacing, default_origin, default_name = (source.values, source.spacing, source.origin,
                                                              source.name)
        kind = "a GridVolume"
    elif hasattr(source, "shape") and hasattr(source, "dtype") and hasattr(source, "__getitem__"):
        arr, kind = source, f"the {type(source).__name__} source"  # numpy, np.memmap, a zarr array: sliced lazily
    elif hasattr(source, "GetClassName"):  # pyvista.ImageData, vtkImageData
        if getattr(source, "GetClassName")() in ("vtkRectilinearGrid",):
            raise ValueError("a multiresolution store holds uniform grids; resample a rectilinear grid first")
        arr, sp, org, default_name = image_array(source, scalars, "point")
        default_spacing, default_origin = tuple(sp), tuple(org)
        kind = f"a {type(source).__name__}"
    else:
        raise TypeError(f"source must be an array (numpy, np.memmap, zarr), image data, a GridVolume, a volume "
                        f"file's path or a function f(box); got {type(source).__name__}")
    if scalars is not None and not (isinstance(source, (str, os.PathLike)) or hasattr(source, "GetClassName")):
        raise ValueError(f"scalars names an array of a dataset or file; {kind} has one: got {scalars!r}")
    sp = _vector3("spacing", default_spacing if spacing is None else spacing, positive=True)
    org = _vector3("origin", default_origin if origin is None else origin, positive=False)
    vname = default_name if name is None else str(name)

    if arr is None:
        shp = _shape3("shape", shape)
        dt = _real_dtype("dtype", dtype)

        def read(box):
            want = tuple(b - a for a, b in box)
            block = np.asarray(source(box))
            if block.shape != want:
                raise ValueError(f"the source function returned shape {block.shape} for the box {box}; "
                                 f"expected {want}")
            if not np.can_cast(block.dtype, dt, "same_kind"):
                raise TypeError(f"the source function returned dtype {block.dtype} for the box {box}; expected "
                                f"{dt} (or one that casts to it: same kind)")
            return block.astype(dt, copy=False)

        return _Source(shp, dt, read, sp, org, vname)

    if shape is not None and tuple(shape) != tuple(arr.shape):
        raise ValueError(f"shape={tuple(shape)} does not match {kind}'s shape {tuple(arr.shape)} (give neither)")
    if dtype is not None and np.dtype(dtype) != np.dtype(arr.dtype):
        raise ValueError(f"dtype={np.dtype(dtype)} does not match {kind}'s dtype {np.dtype(arr.dtype)} "
                         f"(give neither)")
    if len(arr.shape) != 3:
        raise ValueError(f"{kind} must be 3-D (z, y, x); got shape {tuple(arr.shape)}")
    if min(arr.shape) < 1:
        raise ValueError(f"{kind} must not be empty; got shape {tuple(arr.shape)}")
    dt = _real_dtype(kind, arr.dtype)

    def read(box):
        # np.array: a copy (or a fresh array from zarr), in native order: the caller's memory is never
        # handed on to be changed
        return np.array(arr[_box_slices(box)], dtype=dt)

    return _Source(tuple(int(n) for n in arr.shape), dt, read, sp, org, vname)


def _level_dtype(dtype, level, downsample):
    """Level 0 keeps the source's dtype; coarser means of integers are float32."""
    if level == 0 or downsample == "mode" or np.issubdtype(dtype, np.floating):
        return np.dtype(dtype)
    return np.dtype(np.float32)


def write_multiscale(source, path, *, shape=None, dtype=None, spacing=None, origin=None, name=None, scalars=None,
                     downsample="mean", chunk=CHUNK, overwrite=False, progress_bar=None, threads=None):
    """Write a multiresolution OME-Zarr store (see the module's notes for the format).

    Parameters
    ----------
    source : array, np.memmap, zarr array, dataset, GridVolume, file path or function
        The level-0 values, (z, y, x). A path names a ``.raw`` file (x fastest, read
        through a read-only ``np.memmap``; needs ``shape`` and ``dtype``) or a file that
        :mod:`pv_hdrvol.data.files` reads (``.vti``, ``.vtk``, ``.nrrd``, ...;
        an image's array keeps its dtype). A function ``f(box)`` returns the values of
        ``box = ((z0, z1), (y0, y1), (x0, x1))`` (procedural data, never held whole); it
        needs ``shape`` and ``dtype`` and may return any dtype of the same kind (cast).
        The source is only read: its values are never changed.
    path : str or os.PathLike
        The store's directory (``*.ome.zarr`` by convention).
    shape : 3 ints (nz, ny, nx), dtype : numpy dtype
        For a function or a ``.raw`` file (a ``.raw`` dtype may name a byte order:
        ``">f4"``; the store is native).
    spacing, origin : 3 floats (x, y, z)
        World geometry of level 0 (default: the dataset's, else 1 and 0).
    scalars : str, optional
        The array of a dataset or file (default: its active scalars).
    downsample : "mean" or "mode"
        How each level is made from the previous one: the 2x2x2 mean (NaN ignored) or,
        for label volumes, the most frequent value.
    chunk : int
        Points a side of an inner chunk (a power of two, 8 to 512; default 64): what a
        renderer reads at once.
    overwrite : bool
        Replace an existing store at ``path`` (default: refuse). Only a zarr store is
        replaced: any other file or folder there is refused.
    progress_bar : bool or None
        A tqdm bar over the shards written (None: when stderr is a terminal).
    threads : int or None
        Shards made and compressed at once (default: the machine's cores). A function
        source is called from that many threads at a time: pass ``threads=1`` if it is
        not safe to call concurrently.

    Memory: one shard of the level being written (at most ``SHARD_BYTES``), zarr's
    encoding of it, and the float64 work on one chunk of the level below, whatever the
    volume's size.

    Returns
    -------
    MultiscaleStore
        The finished store, opened.

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is False (or it is not a zarr store).
    TypeError, ValueError
        A source, option or returned box that is not allowed; the message names it.
    """
    zarr = _zarr()
    src, chunk = _open_source(source, shape, dtype, spacing, origin, name, scalars, downsample, chunk, progress_bar)
    workers = (os.cpu_count() or 1) if threads is None else as_int("threads", threads, low=1)  # before any removal
    path = os.fspath(path)
    _remove_old_store(path, overwrite)
    shapes, edges, dtypes = _plan_levels(src, chunk, downsample)
    bar = _shards_bar(progress_bar, sum(len(_boxes(s, e)) for s, e in zip(shapes, edges)))

    group = zarr.open_group(store=path, mode="w-", zarr_format=3)
    meta = {"format": FORMAT, "chunk": chunk, "downsample": downsample, "spacing": list(src.spacing),
            "origin": list(src.origin), "name": src.name, "complete": False}
    group.attrs.update({"pv_hdrvol": meta})
    reduce = downsample_mean if downsample == "mean" else downsample_mode
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=workers, thread_name_prefix="pv_hdrvol-writer")
    try:
        arr, rng, finite = _write_level0(group, src, shapes[0], edges[0], dtypes[0], chunk, pool, workers, bar)
        arrays, ranges = [arr], [rng]
        for level in range(1, len(shapes)):
            arr, rng = _write_coarser_level(group, level, shapes[level], edges[level], dtypes[level], chunk,
                                            arrays[-1], ranges[-1], reduce, pool, workers, bar)
            arrays.append(arr)
            ranges.append(rng)
        _finish_metadata(group, meta, src, ranges, downsample, finite)
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        if bar is not None:
            bar.close()
    return MultiscaleStore(path)


def _open_source(source, shape, dtype, spacing, origin, name, scalars, downsample, chunk, progress_bar):
    """Check :func:`write_multiscale`'s options and open its source: the :class:`_Source`
    and the chunk edge as an int. Every check runs here, before an old store is removed."""
    if downsample not in DOWNSAMPLE:
        raise ValueError(f"downsample must be one of {DOWNSAMPLE}; got {downsample!r}")
    chunk = as_int("chunk", chunk, low=8, high=512)
    if chunk & (chunk - 1):
        raise ValueError(f"chunk must be a power of two (8 to 512); got {chunk}")
    src = _as_source(source, shape, dtype, spacing, origin, name, scalars)
    if downsample == "mode" and not np.issubdtype(src.dtype, np.integer):
        raise ValueError(f"downsample='mode' is for label volumes (integers); got dtype {src.dtype}")
    from ..raycast.frame import check_progress_bar

    check_progress_bar(progress_bar)
    return src, chunk


def _remove_old_store(path, overwrite):
    """Remove the zarr store at ``path`` when ``overwrite`` allows it; refuse anything else there."""
    if os.path.lexists(path):
        if not overwrite:
            raise FileExistsError(f"{path} exists; pass overwrite=True to replace it")
        if not (os.path.isdir(path) and os.path.isfile(os.path.join(path, "zarr.json"))):
            # overwrite replaces a store, never a folder of other things or the source file
            raise FileExistsError(f"{path} exists and is not a zarr store; overwrite=True replaces only a store: "
                                  f"remove it yourself or choose another path")
        shutil.rmtree(path)


def _plan_levels(src, chunk, downsample):
    """Each level's shape, shard edge and dtype, from level 0 to the one that fits a chunk."""
    shapes = level_shapes(src.shape, chunk)
    dtypes = [_level_dtype(src.dtype, L, downsample) for L in range(len(shapes))]
    edges = [shard_edge(dt.itemsize, chunk) for dt in dtypes]
    return shapes, edges, dtypes


def _shards_bar(progress_bar, total):
    """A tqdm bar over ``total`` shards, or None (``progress_bar`` None: when stderr is a terminal)."""
    from ..raycast.frame import auto_bar_wanted

    if progress_bar or (progress_bar is None and auto_bar_wanted()):
        try:
            from tqdm.auto import tqdm

            return tqdm(total=total, desc="Writing levels", unit="shards")
        except ImportError:
            if progress_bar:
                raise ImportError("progress_bar=True needs tqdm (pip install tqdm)") from None
    return None


def _create_level_array(group, level, shape, edge, dtype, chunk):
    """The zarr array of one level: inner chunks of ``chunk`` points, shards of ``edge``."""
    from zarr.codecs import BloscCodec, Crc32cCodec

    # crc32c after blosc: a damaged chunk fails to read instead of decoding to wrong numbers
    return group.create_array(
        name=str(level), shape=shape, dtype=dtype, chunks=(chunk,) * 3,
        shards=tuple(min(edge, chunk * -(-n // chunk)) for n in shape),
        compressors=(BloscCodec(cname="zstd", clevel=3, shuffle="shuffle"), Crc32cCodec()),
        fill_value=np.nan if np.issubdtype(dtype, np.floating) else 0,
        dimension_names=("z", "y", "x"), config={"write_empty_chunks": True})


def _empty_ranges(shape, chunk):
    """Zeros for the ``_RANGE_FIELDS`` of every chunk of a level of ``shape``."""
    return np.zeros(tuple(-(-n // chunk) for n in shape) + (5,))


def _put_chunk_ranges(rng, box, r, chunk):
    """Copy a shard's chunk minima and maxima ``r`` into its level's ``rng``."""
    c = [a // chunk for a, _ in box]
    rng[c[0]:c[0] + r.shape[0], c[1]:c[1] + r.shape[1], c[2]:c[2] + r.shape[2], :2] = r


def _run_shards(pool, workers, write_shard, boxes):
    """Yield ``write_shard(box)`` for every box as it completes on ``pool``.

    Shards run on ``workers`` threads (compression and numpy release the GIL), at most
    two per thread in flight: memory stays a few shards whatever the volume.
    """
    boxes = iter(boxes)
    pending = set()
    while True:
        for box in boxes:
            pending.add(pool.submit(write_shard, box))
            if len(pending) >= 2 * workers:
                break
        if not pending:
            break
        done, pending = concurrent.futures.wait(pending, return_when=concurrent.futures.FIRST_COMPLETED)
        for future in done:
            yield future.result()


def _write_level0(group, src, shape, edge, dtype, chunk, pool, workers, bar):
    """Write level 0 from the source, shard by shard, with the value ranges of its groups.

    Returns the array, its chunk ranges and the finite range ``(low, high)`` of its
    values (``(inf, -inf)`` for none).
    """
    from zarr.codecs import BloscCodec

    arr = _create_level_array(group, 0, shape, edge, dtype, chunk)
    rng = _empty_ranges(shape, chunk)
    gshape = tuple(-(-n // GROUP) for n in shape) + (2,)
    groups = group.create_array(name="pv_hdrvol/groups", shape=gshape, dtype="float64",
                                chunks=tuple(min(edge // GROUP, n) for n in gshape[:3]) + (2,),
                                compressors=BloscCodec(cname="zstd", clevel=3, shuffle="shuffle"),
                                fill_value=np.nan, attributes={"group": GROUP, "fields": ["min", "max"]})

    def write_shard(box):
        block = src.read(box)
        arr[_box_slices(box)] = block
        # the shard's own region of the groups array: no other thread writes it
        groups[tuple(slice(a // GROUP, -(-b // GROUP)) for a, b in box)] = group_ranges(block)
        r = _chunk_ranges(block, chunk)
        finite = (float(r[..., 0].min()), float(r[..., 1].max()))
        if not np.isfinite(finite).all():  # the rare shard holding +-inf
            kept = block[np.isfinite(block)]
            finite = (float(kept.min()), float(kept.max())) if kept.size else (np.inf, -np.inf)
        return box, r, finite

    finite_lo, finite_hi = np.inf, -np.inf
    for box, r, finite in _run_shards(pool, workers, write_shard, _boxes(shape, edge)):
        finite_lo, finite_hi = min(finite_lo, finite[0]), max(finite_hi, finite[1])
        _put_chunk_ranges(rng, box, r, chunk)
        if bar is not None:
            bar.update(1)
    return arr, rng, (finite_lo, finite_hi)


def _write_coarser_level(group, level, shape, edge, dtype, chunk, below, below_ranges, reduce, pool, workers, bar):
    """Write level ``level`` by reducing each 2x2x2 group of ``below`` (the level under it).

    Returns the array and its chunk ranges; the error of every chunk of ``below``
    against its parents goes into ``below_ranges``.
    """
    arr = _create_level_array(group, level, shape, edge, dtype, chunk)
    rng = _empty_ranges(shape, chunk)

    def write_shard(box):
        errors = []
        block = np.empty(tuple(b - a for a, b in box), dtype)
        # one fine chunk at a time (half a chunk of this level): the float64 work stays small
        for sub in _boxes(block.shape, chunk // 2):
            fbox = tuple((2 * (o + a), min(2 * (o + b), n)) for (o, _), (a, b), n in zip(box, sub, below.shape))
            fine = np.asarray(below[_box_slices(fbox)])
            coarse = reduce(fine).astype(dtype)
            block[_box_slices(sub)] = coarse
            errors.append((tuple(a // chunk for a, _ in fbox), _parent_error(fine, coarse)))
        arr[_box_slices(box)] = block
        return box, _chunk_ranges(block, chunk), errors

    for box, r, errors in _run_shards(pool, workers, write_shard, _boxes(shape, edge)):
        _put_chunk_ranges(rng, box, r, chunk)
        for index, err in errors:
            below_ranges[index + (2,)] = err
        if bar is not None:
            bar.update(1)
    return arr, rng


def _finish_metadata(group, meta, src, ranges, downsample, finite):
    """Write every level's chunk ranges and the OME metadata, and mark the store complete
    (last: a store without ``complete`` is refused)."""
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
    finite_lo, finite_hi = finite
    group.attrs.update({"ome": _ome_metadata(src, len(ranges), downsample),
                        "pv_hdrvol": dict(meta, complete=True, finite_range=[float(finite_lo), float(finite_hi)]
                                          if finite_lo <= finite_hi else None)})


def _parent_error(fine, coarse):
    """The largest ``|fine - parent|`` (NaN ignored; 0 for none) of the points of ``fine``
    against the ``coarse`` point whose 2x2x2 group holds them."""
    f = _pad_even(fine.astype(np.float64))
    nz, ny, nx = f.shape
    # the repeated planes of an odd axis are copies of real points: they change no maximum
    with np.errstate(invalid="ignore"):  # inf - inf: NaN, ignored
        diff = np.abs(f.reshape(nz // 2, 2, ny // 2, 2, nx // 2, 2)
                      - coarse.astype(np.float64)[:, None, :, None, :, None])
    diff = diff[~np.isnan(diff)]
    return float(diff.max()) if diff.size else 0.0


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
        self._attrs = ours
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
        """Minimum and maximum of the finite level-0 points (NaN and +-inf ignored; ``(0, 0)``
        when there is none), as a GridVolume's: the renderer reads +-inf as these."""
        finite = self._attrs.get("finite_range", "absent")
        if finite == "absent":  # a store written before the finite range was recorded
            r = self.levels[0].ranges
            lo, hi = float(r[..., 0].min()), float(r[..., 1].max())
            return (lo, hi) if lo <= hi else (0.0, 0.0)
        return (0.0, 0.0) if finite is None else (float(finite[0]), float(finite[1]))

    def chunk_path(self, level, index):
        """The file that holds chunk ``index`` (z, y, x) of ``level`` (its shard)."""
        arr = self._arrays[level]
        shard = arr.shards or arr.chunks
        s = [i * self.chunk // e for i, e in zip(index, shard)]
        return os.path.join(self.path, str(level), "c", *(str(v) for v in s))

    def read_chunk(self, level, index):
        """The points of chunk ``index = (cz, cy, cx)`` of ``level`` (at most ``chunk`` a
        side; smaller at the far edges). Raises ``OSError`` naming the chunk and its file
        when the file is missing or cannot be decoded: never zeros or NaN in its place;
        ``IndexError`` for a level or index outside the store."""
        if not 0 <= level < len(self.levels):
            raise IndexError(f"level must be 0 to {len(self.levels) - 1}; got {level!r}")
        grid = self.levels[level].chunks
        if len(index) != 3 or not all(isinstance(i, (int, np.integer)) and 0 <= i < n for i, n in zip(index, grid)):
            # not "missing": a chunk outside the level is the caller's mistake, not damage
            raise IndexError(f"chunk index {tuple(index)} is outside level {level}'s chunks {grid} (z, y, x)")
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

    def group_ranges(self):
        """Level 0's ``(gz, gy, gx, 2)`` min and max per cube of :data:`GROUP` points (float64;
        read once, then kept), or ``None`` for a store written without them. They bound
        every level's values too: a coarse point is a mean (or mode) of level-0 points."""
        if not hasattr(self, "_groups"):
            try:
                arr = self._group["pv_hdrvol/groups"]
            except KeyError:
                self._groups = None
            else:
                self._groups = np.asarray(arr[...])
        return self._groups

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
