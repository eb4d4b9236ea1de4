"""Render a composite dataset (multiblock, partitioned) as one scene.

:func:`~pv_hdrvol.data.blocks.prepare_blocks` turns the dataset into one of three
scenes, each rendered here:

- image blocks on one lattice, gathered into one volume over their union box: one
  grid render (:func:`~pv_hdrvol.raycast.grid.render_volume`), the render of the
  unsplit volume bit for bit when the blocks tile it;
- image blocks on different lattices (or too sparse to gather): each block rendered
  alone with the same transfer function, world step and opacity unit, and the
  partial images composited per pixel, front to back in the order the pixel's ray
  enters the blocks' boxes (exact for boxes that meet at most at faces; see
  :func:`render_image_blocks`);
- mesh blocks (unstructured, curvilinear) merged into one tetrahedral mesh: one
  :func:`~pv_hdrvol.raycast.tets.render_tets`;
- grid and mesh blocks together: each grid block alone, and the mesh once per gap
  between the grids' boxes along each ray, cut to it; all composited per pixel in
  depth order (:func:`render_mixed_blocks`).
"""
from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np

from ..data.blocks import prepare_blocks
from ..data.transfer import auto_transfer_function
from ..rays.camera import Rays, as_camera, fit_camera, ray_box_spans
from .._validate import as_size
from .grid import GridPlan, collected_warnings, render_volume, resolve_render_options, warn_empty
from .compositing import composite_in_order
from .frame import check_progress_bar, tqdm_bar
from .tets import TetPlan, render_tets


def render_blocks(data, tf=None, camera=None, size=(512, 512), options=None, *, scalars=None, preference="point",
                  progress_bar=None, progress=None, cmap=None, clim=None, opacity=None, scale=None, **option_kwargs):
    """Render all blocks of a composite dataset as one scene into an :class:`~pv_hdrvol.HDRImage`.

    Parameters
    ----------
    data : pyvista.MultiBlock, vtkMultiBlockDataSet, vtkPartitionedDataSetCollection or vtkPartitionedDataSet
        Nested in any order. Its leaves are grids (``vtkImageData``; rectilinear
        rectilinear grids) and meshes (``vtkUnstructuredGrid``, ``vtkStructuredGrid``),
        in any mix; empty and ``None`` blocks are left out
        silently (``metadata["blocks"]["empty"]`` lists them), surface blocks
        (``vtkPolyData``) with a warning.
    tf, cmap, clim, opacity, scale
        As :func:`~pv_hdrvol.render`; the default transfer function is chosen from
        the values of all blocks, one for the whole scene.
    camera, size, options, progress, progress_bar, **option_kwargs
        As :func:`~pv_hdrvol.render`; a view name frames all blocks.
    scalars, preference
        The array to render and its association, chosen over all blocks (the rules of
        a single dataset: the name, else the blocks' active scalars, else their only
        array). Blocks without it are skipped with a warning naming them.

    Returns
    -------
    HDRImage
        ``metadata["blocks"]``: how the scene was rendered (``kind``: ``"grid"``,
        ``"grid blocks"``, ``"mesh"`` or ``"mixed"``), the blocks rendered and those left out, by
        their paths (``"Block-00/piece 1"``: a block's name where it has one).

    Raises
    ------
    ValueError
        No block to render; grid blocks rendered one by one whose boxes overlap, or a
        mesh inside a grid block's box; options that a scene rendered part by part
        cannot keep (see Notes); an error of one block, named by its path.
    TypeError
        AMR datasets (their levels overlap) and leaves that are not grids, meshes or
        surfaces.
    ScalarsError
        No block has the scalars (the message lists the arrays of the blocks).

    Notes
    -----
    Image blocks on one lattice (same spacing to 1e-9 relative, first points on the
    first block's lattice to 1e-6 of a spacing), or rectilinear blocks whose
    coordinates are contiguous runs of their union's, whose union box holds at most 4
    times their points are gathered: points no block has are NaN (empty space; the
    faces of such a gap are then placed to within a step, first order in the step,
    as in any volume with NaN). Otherwise
    each block is rendered alone and the images composited per pixel in the order the
    ray enters each block's box, premultiplied, in float64:

    .. math:: C = C_\\mathrm{front} + (1 - A_\\mathrm{front})\\, C_\\mathrm{back}

    That is exact when the boxes overlap at most at shared faces (refused otherwise);
    each block samples its own segment of the ray, at the step ``step`` times the
    narrowest cell of all blocks, with the same opacity unit (that width, unless
    ``opacity_unit_distance`` is given). Blending other than
    ``"composite"``, gradient opacity, shading and ``tolerance=`` need one volume and
    are refused there; a gathered scene takes every option a single volume does.

    Examples
    --------
    >>> import numpy as np, pyvista as pv
    >>> image = pv.ImageData(dimensions=(9, 9, 9))
    >>> image.point_data["f"] = np.linspace(0.0, 1.0, image.n_points)
    >>> halves = pv.MultiBlock([image.extract_subset((0, 4, 0, 8, 0, 8)), image.extract_subset((4, 8, 0, 8, 0, 8))])
    >>> split = render_blocks(halves, size=(16, 16), precision="float64")
    >>> bool(np.array_equal(split.rgba, render_volume(image, size=(16, 16), precision="float64").rgba))
    True
    >>> split.metadata["blocks"]
    {'kind': 'grid', 'rendered': ['Block-00', 'Block-01']}
    """
    scene = prepare_blocks(data, scalars=scalars, preference=preference)
    camera = fit_camera(data, camera, scalars=scalars, preference=preference)  # the rendered blocks' bounds
    keywords = dict(cmap=cmap, clim=clim, opacity=opacity, scale=scale)
    if scene.kind == "mesh":
        image = render_tets(scene.mesh, tf, camera, size, options, progress=progress, progress_bar=progress_bar,
                            **keywords, **option_kwargs)
    elif scene.kind == "grid":
        image = render_volume(scene.volume, tf, camera, size, options, progress=progress, progress_bar=progress_bar,
                              **keywords, **option_kwargs)
    elif scene.kind == "mixed":
        image = render_mixed_blocks(scene.blocks, scene.mesh, tf, camera, size, options, name=scene.scalars,
                                    progress=progress, progress_bar=progress_bar, **keywords, **option_kwargs)
    else:
        image = render_image_blocks(scene.blocks, tf, camera, size, options, name=scene.scalars, progress=progress,
                                    progress_bar=progress_bar, **keywords, **option_kwargs)
    image.metadata["blocks"] = scene.describe()
    return image


def render_image_blocks(blocks, tf=None, camera=None, size=(512, 512), options=None, *, name="", progress=None,
                        progress_bar=None, cmap=None, clim=None, opacity=None, scale=None, **option_kwargs):
    """Render image blocks one by one and composite them per pixel (see
    :func:`render_blocks`' Notes).

    ``blocks``: :class:`~pv_hdrvol.data.blocks.ImageBlock` (path, values (z, y, x),
    origin, spacing), whose boxes may share faces but not overlap.
    """
    volumes = [b.volume(name) for b in blocks]
    boxes = [(np.array(v.bounds[0::2]), np.array(v.bounds[1::2])) for v in volumes]
    _check_disjoint(blocks, boxes)
    unit_spacing = min(_cell_width(v) for v in volumes)
    lo = np.min([b[0] for b in boxes], axis=0)
    hi = np.max([b[1] for b in boxes], axis=0)
    bounds = tuple(float(x) for pair in zip(lo, hi) for x in pair)
    tf, opts = resolve_render_options(_BlockUnion(volumes, bounds, unit_spacing), tf, options, cmap=cmap, clim=clim,
                                      opacity=opacity, scale=scale, **option_kwargs)
    _check_part_by_part(opts, "these grid blocks are rendered one by one (not on one lattice, or too sparse to "
                              "gather)", "resample the blocks onto one lattice")
    unit = opts.opacity_unit_distance if opts.opacity_unit_distance is not None else unit_spacing
    camera = as_camera(camera, bounds)
    rays = camera if isinstance(camera, Rays) else camera.rays(as_size(size))
    check_progress_bar(progress_bar)
    weights = np.array([v.values.size for v in volumes], dtype=np.float64)
    start = np.concatenate([[0.0], np.cumsum(weights)]) / weights.sum()
    bar = tqdm_bar(progress_bar, 1000) if progress_bar else None
    images = []
    try:
        with collected_warnings() as reasons:
            for i, volume in enumerate(volumes):
                report = _block_progress(progress, bar, start[i], start[i + 1])
                images.append(_render_block(volume, tf, opts, unit_spacing, unit, camera, size, report))
    finally:
        if bar is not None:
            bar.close()
    image = composite_in_order(images, np.stack([ray_box_spans(rays, lo, hi)[0] for lo, hi in boxes]))
    image.metadata.pop("settings", None)  # the first block's alone: they would not re-render the scene
    image.metadata["opacity_unit_distance"] = unit
    image.metadata["step_world"] = opts.step * unit_spacing
    image.metadata["step_voxels"] = opts.step
    if len(reasons) == len(volumes):  # every block is bound to be empty: say why once
        warn_empty(str(reasons[0]))
    return image


def render_mixed_blocks(blocks, mesh, tf=None, camera=None, size=(512, 512), options=None, *, name="", progress=None,
                        progress_bar=None, cmap=None, clim=None, opacity=None, scale=None, **option_kwargs):
    """Render grid blocks and a mesh as one scene (see :func:`render_blocks`' Notes).

    ``blocks``: :class:`~pv_hdrvol.data.blocks.ImageBlock` (boxes that may share faces
    but not overlap); ``mesh``: the :class:`~pv_hdrvol.TetMesh` of the mesh blocks,
    which may touch the boxes but not enter them. Each grid block is rendered alone;
    along each pixel's ray the boxes it crosses, sorted by entry, leave gaps between
    them (before the first, between two, after the last), and the mesh is rendered
    once per gap with the ray cut to it (``TetPlan.execute(near=, far=)``, exact inside
    a cell). The partial images composited in the order of their entries are the
    scene: a ray may pass mesh, grid, mesh, grid, mesh. Gaps no pixel has are not
    rendered.
    """
    volumes = [b.volume(name) for b in blocks]
    boxes = [(np.array(v.bounds[0::2]), np.array(v.bounds[1::2])) for v in volumes]
    _check_disjoint(blocks, boxes)
    _check_outside(mesh, blocks, boxes)
    unit_spacing = min(_cell_width(v) for v in volumes)
    lo = np.minimum(np.min([b[0] for b in boxes], axis=0), np.asarray(mesh.bounds[0::2]))
    hi = np.maximum(np.max([b[1] for b in boxes], axis=0), np.asarray(mesh.bounds[1::2]))
    bounds = tuple(float(x) for pair in zip(lo, hi) for x in pair)
    tf, opts = resolve_render_options(_BlockUnion(volumes, bounds, unit_spacing, mesh), tf, options, cmap=cmap,
                                      clim=clim, opacity=opacity, scale=scale, **option_kwargs)
    _check_part_by_part(opts, "this scene of grid and mesh blocks is rendered part by part",
                        "each part alone (hv.render(dataset[...]))")
    unit = opts.opacity_unit_distance if opts.opacity_unit_distance is not None else unit_spacing
    camera = as_camera(camera, bounds)
    if isinstance(camera, Rays):
        raise TypeError("a scene of grid and mesh blocks needs a Camera (the mesh makes its own rays); got Rays")
    width, height = as_size(size)
    rays = camera.rays((width, height))
    spans = [ray_box_spans(rays, b[0], b[1]) for b in boxes]
    enter = np.stack([s[0] for s in spans])
    leave = np.stack([np.where(np.isfinite(s[0]), s[1], np.inf) for s in spans])
    order = np.argsort(enter, axis=0, kind="stable")
    enter_sorted = np.take_along_axis(enter, order, axis=0)
    leave_sorted = np.take_along_axis(leave, order, axis=0)
    # gap j: from the exit of the j-th box crossed (0 for j = 0) to the entry of the next (inf after the last)
    starts = np.concatenate([np.zeros((1, enter.shape[1])), leave_sorted])
    ends = np.concatenate([enter_sorted, np.full((1, enter.shape[1]), np.inf)])
    open_gaps = (ends > starts) & np.isfinite(starts)
    gaps = [j for j in range(len(boxes) + 1) if open_gaps[j].any()]
    check_progress_bar(progress_bar)
    weights = np.array([v.values.size for v in volumes] + [mesh.n_cells] * len(gaps), dtype=np.float64)
    start = np.concatenate([[0.0], np.cumsum(weights)]) / weights.sum()
    bar = tqdm_bar(progress_bar, 1000) if progress_bar else None
    images, entries = [], []
    try:
        with collected_warnings() as reasons:
            for i, volume in enumerate(volumes):
                report = _block_progress(progress, bar, start[i], start[i + 1])
                images.append(_render_block(volume, tf, opts, unit_spacing, unit, camera, (width, height), report))
                entries.append(enter[i])
            plan = TetPlan(mesh, tf, dataclasses.replace(opts, opacity_unit_distance=unit))
            for k, j in enumerate(gaps):
                near = np.where(open_gaps[j], starts[j], 0.0).reshape(height, width)
                far = np.where(open_gaps[j], ends[j], 0.0).reshape(height, width)
                report = _block_progress(progress, bar, start[len(volumes) + k], start[len(volumes) + k + 1])
                images.append(plan.execute(camera, (width, height), near=near, far=far, progress=report,
                                           progress_bar=False))
                entries.append(np.where(open_gaps[j], starts[j], np.inf))
    finally:
        if bar is not None:
            bar.close()
    image = composite_in_order(images, np.stack(entries))
    image.metadata.pop("settings", None)  # one part's alone: they would not re-render the scene
    image.metadata["opacity_unit_distance"] = unit
    image.metadata["step_world"] = opts.step * unit_spacing
    image.metadata["mesh_passes"] = len(gaps)
    if len(reasons) == len(images):
        warn_empty(str(reasons[0]))
    return image


def _check_outside(mesh, blocks, boxes):
    """Raise ``ValueError`` naming a grid block whose box holds part of the mesh (a ray
    would cross both at once: no order to composite them in)."""
    centres = mesh.world_points()[mesh.tets].mean(axis=1)
    for block, (lo, hi) in zip(blocks, boxes):
        slack = 1e-9 * (hi - lo)
        inside = np.all((centres > lo + slack) & (centres < hi - slack), axis=1)
        if inside.any():
            raise ValueError(f"{int(inside.sum())} tetrahedra of the mesh blocks lie inside the box of grid block "
                             f"{block.path!r} ({tuple(lo.tolist())}..{tuple(hi.tolist())}); grid and mesh blocks are "
                             f"composited along each ray in depth order and may share faces only: remove the overlap")


def _check_part_by_part(opts, how, instead):
    """Raise ``ValueError`` for the options a scene rendered part by part (``how``)
    cannot keep: they need one volume; ``instead`` says what to do."""
    refused = [what for what, on in (("tolerance=", opts.tolerance is not None),
                                     (f"blending={opts.blending!r}", opts.blending != "composite"),
                                     ("gradient_opacity=", opts.gradient_opacity is not None),
                                     ("shade=True", opts.shade)) if on]
    if refused:
        raise ValueError(f"{', '.join(refused)} need{'s' if len(refused) == 1 else ''} one volume; {how}: render "
                         f"without {' and '.join(refused)}, or {instead}")


def _render_block(volume, tf, opts, unit_spacing, unit, camera, size, report):
    """One grid block of a scene rendered alone, at the scene's world step and opacity
    unit (``opts.step`` is in voxels of the finest block, ``unit_spacing`` wide)."""
    block_opts = dataclasses.replace(opts, step=opts.step * unit_spacing / _cell_width(volume),
                                     opacity_unit_distance=unit)
    return GridPlan(volume, tf, block_opts).execute(camera, size, progress=report, progress_bar=False)


def _cell_width(volume):
    """The narrowest cell of a block (world units): its step and opacity unit are in it."""
    axes = getattr(volume, "axes", None)
    return float(volume.spacing.min()) if axes is None else float(min(np.diff(a).min() for a in axes))


def _block_progress(progress, bar, lo, hi):
    """A block's ``progress(fraction)`` as the whole render's, between ``lo`` and ``hi``."""
    if progress is None and bar is None:
        return None
    last = [lo]

    def report(fraction):
        done = lo + (hi - lo) * fraction
        if bar is not None:
            bar.update(int(round(1000 * done)) - int(round(1000 * last[0])))
        last[0] = done
        return None if progress is None else progress(done)

    return report


def _check_disjoint(blocks, boxes):
    """Raise ``ValueError`` naming two blocks whose boxes overlap in volume (compositing
    them in order would count the overlap twice)."""
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            overlap = np.minimum(boxes[i][1], boxes[j][1]) - np.maximum(boxes[i][0], boxes[j][0])
            if np.all(overlap > 1e-9 * (boxes[i][1] - boxes[i][0] + boxes[j][1] - boxes[j][0])):
                raise ValueError(
                    f"the boxes of image blocks {blocks[i].path!r} and {blocks[j].path!r} overlap "
                    f"({tuple(boxes[i][0].tolist())}..{tuple(boxes[i][1].tolist())} and "
                    f"{tuple(boxes[j][0].tolist())}..{tuple(boxes[j][1].tolist())}); blocks on different lattices "
                    f"are composited in depth order and may share faces only: remove the overlap (ghost layers) or "
                    f"resample the blocks onto one lattice")


class _BlockUnion(NamedTuple):
    """The blocks of a scene rendered part by part, as :func:`resolve_render_options`
    chooses their default transfer function: :func:`_union_transfer_function`."""

    volumes: list
    bounds: tuple
    unit_spacing: float
    mesh: object = None

    def default_transfer_function(self, **keywords):
        return _union_transfer_function(self.volumes, self.bounds, self.unit_spacing, keywords, self.mesh)


def _union_transfer_function(volumes, bounds, unit_spacing, keywords, mesh=None):
    """The default transfer function of all blocks' values together (each weighted by
    the volume of its cell, so a finely sampled block does not outweigh a coarse one; a
    mesh's values by the volume each stands for), for a ray as long as the union box's
    diagonal."""
    values = [v.values.reshape(-1) for v in volumes]
    weights = [np.full(v.values.size, float(np.prod(v.spacing))) for v in volumes]
    if mesh is not None:
        values.append(np.asarray(mesh.values, dtype=np.float64).reshape(-1))
        weights.append(np.full(values[-1].size, float(np.abs(mesh.cell_volumes()).sum()) / max(values[-1].size, 1)))
    values = np.concatenate(values)
    weights = np.concatenate(weights)
    b = np.asarray(bounds)
    diagonal = float(np.linalg.norm(b[1::2] - b[0::2]))
    integer = all(v.integer for v in volumes) and mesh is None
    if integer and keywords.get("scale") is None:
        keywords = dict(keywords, scale="linear")
    return auto_transfer_function(values, diagonal / unit_spacing, weights=weights / weights.mean(),
                                  integer=integer, **keywords)


__all__ = ["render_blocks", "render_image_blocks", "render_mixed_blocks"]
