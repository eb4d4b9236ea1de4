"""Render a multiblock file (``.vtm``) on MPI ranks, each rank reading only its own blocks.

A ``.vtm`` file is an index: ``<DataSet index=.. name=.. file=..>`` entries, nested in
``<Block>``s, each naming one leaf file (``name/name_0.vti``). Here

1. rank 0 parses the index (:func:`vtm_leaves`) and deals the leaves to the ranks in
   contiguous runs in file order, balanced by their point counts read from each
   leaf's header (:func:`assign_leaves`, :func:`leaf_points`);
2. each rank reads its own leaf files with VTK's XML reader, and only those;
3. the blocks' origins, spacings and sizes are gathered on every rank: image blocks on
   one lattice whose points tile their union box are pieces of one volume
   (:func:`lattice_pieces`: a :class:`~pv_hdrvol.raycast.grid.VolumePiece` per block,
   owning its whole extent; blocks share their faces);
4. each rank renders each of its blocks as a piece (``GridPlan.execute(piece=...)``),
   and rank 0 composites all pieces of all ranks in depth order
   (:func:`~pv_hdrvol.parallel.pieces.composite_pieces`).

That is the serial ``pv_hdrvol.render(pyvista.read(FILE.vtm))``, which gathers such
blocks into one volume (:func:`~pv_hdrvol.data.blocks.gather_images`), to rounding:
pieces composited one after another instead of sample by sample. The default transfer
function reads every value of the whole volume (its columns along each axis): rank 0
gathers the blocks' values once to choose it, as the serial render does; give a
transfer function (``--tf``) to keep the values where they are.

Anything else a ``.vtm`` may hold (leaves that are not image data, blocks on different
lattices, blocks that leave holes in or overlap within their union box, cell data) is
refused with a :class:`MultiblockError` naming it: render such files serially.
"""
from __future__ import annotations

import pathlib
import re
import time
import xml.etree.ElementTree as ElementTree
from typing import NamedTuple

import numpy as np

#: what the refusals tell the user to do instead
SERIAL_HINT = "render it serially with: pv-hdrvol render {file}"


class MultiblockError(ValueError):
    """A ``.vtm`` file this parallel renderer cannot render as the serial one does."""


class VtmLeaf(NamedTuple):
    """One leaf of a ``.vtm`` index: its block path (``"Block-00"``, names joined by
    ``/``; ``"block i"`` where a block has no name) and its file."""

    path: str
    file: pathlib.Path


class BlockInfo(NamedTuple):
    """What every rank learns of one block: path, file, first point (x, y, z), spacing
    and points per axis (x, y, z)."""

    path: str
    file: str
    origin: tuple
    spacing: tuple
    dims: tuple


def vtm_leaves(path):
    """The leaves of the ``.vtm`` file ``path`` in block order (depth first), as
    :class:`VtmLeaf`; entries without a file (empty blocks) are left out, as the serial
    render leaves empty blocks out."""
    path = pathlib.Path(path)
    try:
        root = ElementTree.parse(path).getroot()
    except (ElementTree.ParseError, OSError) as exc:
        raise MultiblockError(f"cannot read {str(path)!r}: {exc}") from None
    kind = root.get("type")
    node = root.find(kind) if kind else None
    if root.tag != "VTKFile" or kind != "vtkMultiBlockDataSet" or node is None:
        raise MultiblockError(f"{str(path)!r} is not a VTK multiblock index (<VTKFile type=\"vtkMultiBlockDataSet\">)")
    leaves = []

    def walk(element, prefix):
        for i, child in enumerate(element):
            label = child.get("name") or f"block {child.get('index', i)}"
            where = f"{prefix}/{label}" if prefix else label
            if child.tag == "DataSet":
                if child.get("file"):
                    leaves.append(VtmLeaf(where, path.parent / child.get("file")))
            else:  # <Block>, <Piece>: nested blocks
                walk(child, where)

    walk(node, "")
    return leaves


_EXTENT = re.compile(rb'WholeExtent="\s*(-?\d+)\s+(-?\d+)\s+(-?\d+)\s+(-?\d+)\s+(-?\d+)\s+(-?\d+)\s*"')


def leaf_points(file):
    """Points of an image leaf from its header (``WholeExtent``, in the first 64 KiB),
    without reading its data; 1 where the header does not say (a weight only)."""
    try:
        with open(file, "rb") as f:
            head = f.read(65536)
    except OSError:
        return 1
    m = _EXTENT.search(head)
    if m is None:
        return 1
    e = [int(v) for v in m.groups()]
    return max(1, (e[1] - e[0] + 1) * (e[3] - e[2] + 1) * (e[5] - e[4] + 1))


def assign_leaves(weights, ranks):
    """The rank of each leaf: contiguous runs in leaf order, each rank's run holding
    about ``1 / ranks`` of the total weight (a leaf goes to the rank whose share holds
    its weight's midpoint). Ranks beyond the leaves may get none.

    >>> assign_leaves([1] * 8, 3).tolist()
    [0, 0, 0, 1, 1, 2, 2, 2]
    """
    w = np.asarray(weights, dtype=np.float64).reshape(-1)
    if w.size == 0:
        return np.zeros(0, dtype=np.int64)
    middle = np.cumsum(w) - 0.5 * w
    return np.minimum((middle / w.sum() * ranks).astype(np.int64), ranks - 1)


def read_leaf(leaf, vtm):
    """The ``vtkImageData`` of an image leaf (``.vti``), read with VTK's XML reader; a
    :class:`MultiblockError` for any other kind of leaf or an unreadable file."""
    suffix = leaf.file.suffix.lower()
    hint = SERIAL_HINT.format(file=vtm)
    if suffix != ".vti":
        kinds = {".vtr": "rectilinear grid", ".vts": "curvilinear (structured) grid", ".vtu": "unstructured grid",
                 ".vtp": "polygonal surface", ".vtm": "multiblock file"}
        kind = kinds.get(suffix, f"{suffix or 'extension-less'} file")
        raise MultiblockError(f"block {leaf.path!r} ({leaf.file.name}) is a {kind}: python -m pv_hdrvol.parallel "
                              f"renders .vtm files of image blocks (.vti) only; {hint}")
    if not leaf.file.is_file():
        raise MultiblockError(f"block {leaf.path!r}: file not found: {str(leaf.file)!r}")
    from vtkmodules.vtkIOXML import vtkXMLImageDataReader

    reader = vtkXMLImageDataReader()
    reader.SetFileName(str(leaf.file))
    reader.Update()
    data = reader.GetOutput()
    if data is None or reader.GetErrorCode():
        raise MultiblockError(f"block {leaf.path!r}: VTK's reader found no image data in {str(leaf.file)!r}")
    return data


def lattice_pieces(infos, vtm):
    """A :class:`~pv_hdrvol.raycast.grid.VolumePiece` per block (:class:`BlockInfo`, all
    ranks' in block order): the blocks as pieces of their union's volume, each owning
    its whole extent. Raises :class:`MultiblockError` unless the blocks are on one
    lattice (:func:`~pv_hdrvol.data.blocks.lattice_offsets`, the serial render's test)
    and tile their union box (no holes, no overlap beyond shared faces)."""
    from ..data.blocks import lattice_offsets
    from ..raycast.grid import VolumePiece
    from .pieces import check_tiling

    hint = SERIAL_HINT.format(file=vtm)

    class _At(NamedTuple):
        path: str
        origin: np.ndarray
        spacing: np.ndarray

    flat = [b.path for b in infos if min(b.dims) < 2]
    if flat:
        raise MultiblockError(f"block {flat[0]!r} has one point along an axis: python -m pv_hdrvol.parallel renders "
                              f"blocks of at least one cell per axis; {hint}")
    offsets, reason = lattice_offsets([_At(b.path, np.asarray(b.origin, float), np.asarray(b.spacing, float))
                                       for b in infos])
    if offsets is None:
        raise MultiblockError(f"the image blocks are not on one lattice ({reason}): python -m pv_hdrvol.parallel "
                              f"renders blocks of one lattice; {hint}")
    shapes = np.array([b.dims for b in infos], dtype=np.int64)
    lo = offsets.min(axis=0)
    dims = (offsets + shapes).max(axis=0) - lo
    # the union's first point as gather_images places it: a block's own first point where it starts the union
    first = np.array([infos[int(np.argmin(offsets[:, a]))].origin[a] for a in range(3)], dtype=np.float64)
    whole = tuple(int(d) for d in dims)
    pieces = []
    for off, shape in zip(offsets - lo, shapes):
        o = tuple(int(v) for v in off)
        pieces.append(VolumePiece(tuple(first.tolist()), whole, o, o, tuple(int(v + n - 1) for v, n in zip(off, shape))))
    cells = np.prod(shapes - 1, axis=1)
    whole_cells = int(np.prod(dims - 1))
    if int(cells.sum()) < whole_cells:
        raise MultiblockError(f"the image blocks leave holes in their union box ({whole} points): they hold "
                              f"{int(cells.sum())} of its {whole_cells} cells; python -m pv_hdrvol.parallel renders "
                              f"blocks that tile one box; {hint}")
    try:
        check_tiling(pieces)
    except ValueError:
        lo_, hi_ = offsets - lo, offsets - lo + shapes - 1
        for i in range(len(infos)):
            inner = (np.minimum(hi_[i], hi_[i + 1:]) > np.maximum(lo_[i], lo_[i + 1:])).all(axis=1)
            if inner.any():
                j = i + 1 + int(np.argmax(inner))
                raise MultiblockError(f"blocks {infos[i].path!r} and {infos[j].path!r} overlap beyond a shared face "
                                      f"(ghost layers?): python -m pv_hdrvol.parallel renders blocks that tile one "
                                      f"box; {hint}") from None
        raise
    return pieces


def render_leaf_pieces(blocks, pieces, tf, camera, size, *, comm, precision="float32"):
    """Render this rank's ``blocks`` (GridVolumes), each as its ``piece``, and composite
    all ranks' on rank 0 (SPMD; every rank calls it, with no blocks too). Returns
    ``(image or None, stats)``: the HDRImage on rank 0, and this rank's stats."""
    from ..rays.camera import as_size
    from ..raycast.grid import GridPlan
    from .pieces import allgather_or_raise, composite_pieces

    size = as_size(size)
    rays = camera.rays(size)
    parts = []
    error = None
    t = time.perf_counter()
    try:
        for volume, piece in zip(blocks, pieces):
            image = GridPlan(volume, tf, precision=precision).execute(camera, size, piece=piece, progress_bar=False)
            parts.append((image, piece.world_box(volume.spacing)))
    except Exception as exc:  # every rank learns of it before the gather
        error = exc
    t_render = time.perf_counter() - t
    allgather_or_raise(comm, None, error)
    gathered = comm.gather(parts, root=0)
    t = time.perf_counter()
    out = None
    if gathered is not None and comm.rank == 0:
        flat = [p for batch in gathered for p in batch]
        out = composite_pieces([p[0] for p in flat], [p[1] for p in flat], rays)
    return out, {"render_seconds": t_render, "composite_seconds": time.perf_counter() - t}


__all__ = ["BlockInfo", "MultiblockError", "VtmLeaf", "assign_leaves", "lattice_pieces", "leaf_points", "read_leaf",
           "render_leaf_pieces", "vtm_leaves"]
