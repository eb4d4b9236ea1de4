"""Ray casting of tetrahedral meshes into an HDRImage (kernels in ``_tet_kernels.py``).

The host side: validate, build the tables, find each pixel's boundary crossings, then
march. See :func:`render_tets`.
"""
from __future__ import annotations

import math
import time
from typing import NamedTuple

import numpy as np

from ..data.grid import content_digest
from ..data.tets import as_tetmesh
from ..data.transfer import SCALE_CODES, scale_inverse
from ..image.upsample import DepthLayers
from .._validate import as_int, as_real, as_size
from ..params import PRECISION_CODES
from ..rays.camera import Camera, as_camera, ray_box_spans
from ..rays.clip import ray_spans, with_clip
from ..settings import settings_metadata
from . import _layer_kernels as LK
from . import _tet_kernels as TK
from .grid import ranges_visible, cached, empty_render_reason, resolve_render_options, warn_empty
from .frame import (MARKERS, TILE, FrameBuffers, FramePlan, check_far, check_progress_bar, frame_metadata, pixel_rows,
                    tile_lanes)
from .memory import check_memory
from .shading import shading_arrays, shading_metadata

#: extinction columns whose active-cell masks a mesh keeps
_ACTIVE_CACHE = 4
#: largest optical depth of one integration piece (see _tet_kernels: the emission of a
#: piece is exact for constant extinction or constant colour, else off by O(tau^3))
TAU_MAX = 0.25
#: most pieces one segment is cut into
MAX_PIECES = 256


def render_tets(mesh, tf=None, camera=None, size=(512, 512), options=None, *, scalars=None, preference="point",
                tau_max=TAU_MAX, upsample=1, progress=None, progress_bar=None, cmap=None, clim=None, opacity=None,
                scale=None, **option_kwargs):
    r"""Ray cast a tetrahedral mesh into an :class:`~pv_hdrvol.HDRImage`.

    Parameters
    ----------
    mesh : pyvista.UnstructuredGrid, vtkUnstructuredGrid or TetMesh
        Tetrahedra (other 3-D cells are split, with a warning). The prepared mesh is
        cached, so the next render of the same, unmodified mesh skips the preparation.
    tf : TransferFunction, optional
        Default: :func:`default_transfer_function` of the mesh's values.
    cmap, clim, opacity, scale : optional
        Instead of ``tf``: replace single choices of the default, as in
        :func:`render_volume`.
    camera : Camera, view name, pyvista.Plotter, pyvista.Camera or vtkCamera, optional
        Default ``"iso"``, i.e. ``Camera.fit(mesh, "iso")``. Must be outside the mesh: rays start at
        their first entry through the boundary.
    size : int or (width, height)
    options : RenderOptions, optional
        ``precision``, ``global_alpha``, ``opacity_unit_distance`` (default: a typical
        cell size, :meth:`TetMesh.default_unit_distance`), the shading options (each
        cell lit by its constant gradient), ``termination`` and
        ``depth_threshold`` apply; ``step`` does not (segments are integrated exactly)
        and ``blending`` must be ``"composite"``.
    scalars, preference
        Which array of the mesh (point or cell data).
    tau_max : float
        Largest optical depth of one integration piece, in (0, 1]. A piece's emission
        takes its colour as linear in optical depth (exact for a constant extinction
        or a constant colour); smaller is more accurate where both vary and cuts dense
        segments into more pieces (docs/tetrahedra.md measures the trade).
    upsample : int
        ``f > 1``: render at ``1/f`` of the size, peel the boundary's depth layers at
        full size and upsample with the joint bilateral filter (Callahan & Silva
        2009; see :func:`~pv_hdrvol.upsample`). The size must be a multiple of ``f``.
        The metadata gives the time of each part.
    progress, progress_bar
        As :func:`render_volume`.

    Returns
    -------
    HDRImage
        Premultiplied linear RGBA, depth (distance along the ray to where the opacity
        first reaches ``depth_threshold``), metadata with cells and pieces integrated.

    Notes
    -----
    The scalar is linear inside each tetrahedron, so along a ray it is piecewise
    linear, with a kink at every face. Each cell's segment is integrated with the
    transfer function's piecewise-linear extinction and colour: the optical depth is
    exact, the emission :math:`\int c\,\sigma\,e^{-\tau}` is exact where extinction or
    colour is constant along a piece of optical depth at most ``tau_max`` and within
    a few 1e-6 of the colour range otherwise (see ``_tet_kernels``),
    and the pieces are composited front to back in ``precision`` as for image volumes.
    Rays that leave a non-convex mesh re-enter it at the next boundary face they cross.
    """
    mesh = as_tetmesh(mesh, scalars=scalars, preference=preference)
    upsample = as_int("upsample", upsample, low=1)
    keywords = dict(cmap=cmap, clim=clim, opacity=opacity, scale=scale)
    if upsample > 1:
        tf, options = resolve_render_options(mesh, tf, options, **keywords, **option_kwargs)
        return _render_upsampled(mesh, tf, camera, size, options, upsample, tau_max, progress, progress_bar)
    plan = TetPlan(mesh, tf, options, tau_max=tau_max, **keywords, **option_kwargs)
    return plan.execute(camera, size, progress=progress, progress_bar=progress_bar)


class TetPlan(FramePlan):
    """A tetrahedral render validated and prepared once, executed many times (the
    counterpart of :class:`~pv_hdrvol.raycast.grid.GridPlan`).

    Construction validates the options and the transfer function, builds the table
    and the kernel parameters and finds the cells the transfer function can see;
    :meth:`execute` renders for any camera and size (and warns when no cell is
    visible).
    ``render_tets`` without ``upsample`` is ``TetPlan(...).execute(...)``; the pixels
    are the same.

    Parameters
    ----------
    mesh : TetMesh, pyvista.UnstructuredGrid or vtkUnstructuredGrid
    tf, options, tau_max, cmap, clim, opacity, scale, **option_kwargs
        As :func:`render_tets`.
    scalars, preference
        Which array of a dataset.
    """

    def __init__(self, mesh, tf=None, options=None, *, tau_max=TAU_MAX, scalars=None, preference="point",
                 cmap=None, clim=None, opacity=None, scale=None, **option_kwargs):
        mesh = as_tetmesh(mesh, scalars=scalars, preference=preference)
        default_tf = tf is None
        tf, opts = resolve_render_options(mesh, tf, options, cmap=cmap, clim=clim, opacity=opacity, scale=scale,
                                          **option_kwargs)
        if opts.blending != "composite":
            raise ValueError(f"tetrahedral meshes support blending='composite' only; got {opts.blending!r}")
        if opts.gradient_opacity is not None:
            raise ValueError("gradient_opacity is not supported for tetrahedral meshes")
        self.tau_max = as_real("tau_max", tau_max, low=0.0, high=1.0, low_open=True)
        if opts.tolerance is not None and self.tau_max != TAU_MAX:
            raise ValueError(f"tolerance= chooses tau_max: leave it at its default or drop tolerance; got "
                             f"tau_max={tau_max!r}")
        prec = opts.precision
        self.mesh, self.tf, self.options = mesh, tf, opts
        self.unit = opts.opacity_unit_distance if opts.opacity_unit_distance is not None \
            else mesh.default_unit_distance()
        self.table, sigma = _table(tf, prec, opts.global_alpha, self.unit)
        a0, a1 = tf.axis_range
        self.params = TK.TetParams(
            PRECISION_CODES[prec], SCALE_CODES[tf.scale], float(a0), float(1.0 / (a1 - a0)), float(tf.linthresh),
            1.0 - opts.termination if opts.termination > 0 else math.inf, float(opts.depth_threshold),
            float(mesh.scale), self.tau_max, MAX_PIECES, int(4 * mesh.n_cells + 64), int(opts.shade),
        )
        self.active = _active_cells(mesh, sigma, self.params)
        # said by each execution (after its own checks), as by a one-off render
        self._empty_reason = empty_render_reason(mesh.value_range, _any_finite_cell(mesh), tf,
                                                 visible=bool(self.active.any()), default_tf=default_tf, what="mesh")

    with_clip = with_clip

    def execute(self, camera=None, size=(512, 512), *, progress=None, progress_bar=None, chunk_seconds=None,
                far=None, piece=None, near=None):
        """Render the plan for ``camera`` and ``size`` (as :func:`render_tets`); an
        :class:`~pv_hdrvol.HDRImage`. ``chunk_seconds`` and ``far``: as
        :meth:`~pv_hdrvol.raycast.grid.GridPlan.execute`.

        ``piece``: a :class:`MeshPiece` -- the plan's mesh holds every cell of a mesh
        spread over processes that meets the box this process owns, and this render
        composites the cell segments of each ray whose midpoints lie in that box, each
        whole and with the arithmetic of the whole mesh's render (cutting them at the
        box's faces changed the integration's rounding of colour by up to 1e-4). The
        pieces' images composited in depth order
        (:func:`pv_hdrvol.parallel.pieces.composite_pieces`) are the whole render to
        rounding; the default camera frames the whole mesh."""
        return self.execute_with_view(camera, size, progress=progress, progress_bar=progress_bar,
                                      chunk_seconds=chunk_seconds, far=far, piece=piece, near=near)[0]

    def execute_with_view(self, camera=None, size=(512, 512), *, progress=None, progress_bar=None, view=None,
                          chunk_seconds=None, far=None, piece=None, near=None):
        """:meth:`execute`, and the boundary's ``_view`` for this camera (reused when
        ``view`` was made for it): ``(image, view)``. ``near`` (as ``far``: rows x cols,
        world distances): where each ray starts compositing -- the mesh between the
        boxes of a scene's grid blocks (``raycast/blocks.py``)."""
        mesh, tf, opts, params, table, active = self.mesh, self.tf, self.options, self.params, self.table, self.active
        if opts.tolerance is not None:
            if near is not None:
                raise ValueError("near= and tolerance= do not go together: tolerance= chooses the knobs on a pilot "
                                 "of the whole rays; give tau_max= and termination=")
            if piece is not None:
                raise ValueError("tolerance= chooses the knobs per render; a piece of a distributed mesh needs the "
                                 "whole render's: choose them once (metadata['tolerance'] of a render of the whole) "
                                 "and give tau_max=, termination= and precision=")
            from .tolerance import execute_mesh

            return execute_mesh(self, camera, size, progress=progress, progress_bar=progress_bar, view=view,
                                chunk_seconds=chunk_seconds, far=far)
        if piece is not None and not isinstance(piece, MeshPiece):
            raise TypeError(f"piece must be a MeshPiece; got {type(piece).__name__}")
        camera = as_camera(camera, mesh.bounds if piece is None else piece.bounds())
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a Camera, a view name or a PyVista/VTK camera (not Rays: a tetrahedral "
                            f"render makes its own rays); got {type(camera).__name__}")
        check_progress_bar(progress_bar)
        width, height = as_size(size)
        far = check_far(far, width, height)
        if near is not None:
            near = check_far(near, width, height, "near")
        span = ray_spans(camera, (width, height), opts, far, near)  # clip planes, crop box, far (rays/clip.py)
        own = np.empty((0, 2))
        if piece is not None:  # the span of each ray in the owned box
            lo, hi = piece.world_box()
            near, box_far = ray_box_spans(camera.rays((width, height)), lo, hi, piece.closed())
            own = np.ascontiguousarray(np.column_stack([near, np.where(np.isfinite(near), box_far, -np.inf)]))
        prec = opts.precision
        check_memory(render_bytes(mesh, prec, width, height), _MEMORY_ADVICE.format(width=width, height=height))
        if piece is None:  # a piece may well be empty where the whole is not
            warn_empty(self._empty_reason)

        # rays are made in the kernels, in the mesh's normalised frame; t scales back by mesh.scale
        cam = camera_array(camera, mesh, width, height)
        t0 = time.perf_counter()
        view = _view(mesh, cam, view)
        hits = boundary_crossings(mesh, camera, (width, height), cam, view)
        t_hits = time.perf_counter() - t0
        has = hits.offsets[1:] > hits.offsets[:-1]
        inside = int(np.count_nonzero(~hits.entering[hits.offsets[:-1][has]]))
        if inside:
            raise ValueError(f"the camera is inside the mesh: {inside} rays start inside it (their first boundary "
                             f"crossing leaves the mesh); place the camera outside the mesh's boundary")

        n_pix = width * height
        out = FrameBuffers(width, height, prec)  # counts: the cells each ray crossed
        pieces = np.zeros(n_pix, dtype=np.int64)
        guard = np.zeros(n_pix, dtype=np.bool_)
        lanes = tile_lanes()
        cells_i, cells_f = _cell_records(mesh)
        # a cell's gradient is constant: its light depends only on the ray's direction
        grads = cell_gradients(mesh) if opts.shade else np.zeros((1, 3))
        shading, lights = shading_arrays(opts, (mesh.default_unit_distance(),) * 3)

        def cast(tile_rows):
            rows = np.ascontiguousarray(tile_rows)
            TK.render_tiles(MARKERS[opts.precision], mesh.points, cells_i, cells_f, active,
                            mesh.boundary, mesh.boundary_cell, mesh.boundary_face, table, grads, shading, lights,
                            hits.offsets,
                            hits.t, hits.face, hits.entering, cam, own, span, width, height, TILE, rows, lanes,
                            params, out.rgba, out.depth, out.counts, pieces, guard)
            return pixel_rows(tile_rows, height)

        def on_device(runner):
            return runner.tet_frame(prec, mesh, cells_i, cells_f, active, table, grads, shading, lights, hits, cam,
                                    own, span, width, height, params, out.rgba, out.depth, out.counts, pieces, guard)

        t1 = time.perf_counter()
        device_meta = self.run_frame(cast, height, progress, progress_bar, chunk_seconds, opts.device, on_device)
        elapsed = time.perf_counter() - t1
        settings = settings_metadata(tf, camera, (width, height), opts, {"tau_max": self.tau_max})
        meta = frame_metadata("pv_hdrvol tetrahedral ray caster", mesh.name, tf, camera, opts, self.unit, settings,
                              elapsed, association=mesh.association, cells_in_mesh=mesh.n_cells)
        meta.update({
            "boundary_seconds": t_hits,
            "cells": int(out.counts.sum()),
            "pieces": int(pieces.sum()),
            "tau_max": self.tau_max,
            "stopped_rays": int(guard.sum()),
        })
        if opts.shade:
            meta["shading"] = shading_metadata(opts)
        if device_meta is not None:
            meta["device"] = device_meta
        if piece is not None:
            meta["piece"] = {"owned_lo": list(piece.owned_lo), "owned_hi": list(piece.owned_hi)}
        return out.image(meta), view


class MeshPiece(NamedTuple):
    """The box of a tetrahedral mesh spread over processes that one process renders
    (``TetPlan.execute(piece=...)``), in world coordinates: ``owned_lo``/``owned_hi``
    its box, ``whole_lo``/``whole_hi`` the box of all of them (the mesh's bounds or
    more). The owned boxes share faces and do not overlap (a k-d split, as VTK's
    ``vtkRedistributeDataSetFilter`` cuts); a ray in a face two boxes share belongs to
    the box above it, one on the whole box's far faces to the box below."""

    owned_lo: tuple
    owned_hi: tuple
    whole_lo: tuple
    whole_hi: tuple

    def bounds(self):
        """The whole box as ``(xmin, xmax, ymin, ymax, zmin, zmax)``."""
        return tuple(float(v) for pair in zip(self.whole_lo, self.whole_hi) for v in pair)

    def world_box(self):
        """``(lo, hi)``: the owned box."""
        return np.asarray(self.owned_lo, dtype=np.float64), np.asarray(self.owned_hi, dtype=np.float64)

    def closed(self):
        """Per axis, whether the owned box reaches the whole box's far face."""
        return np.asarray(self.owned_hi, dtype=np.float64) >= np.asarray(self.whole_hi, dtype=np.float64)


def _table(tf, prec, global_alpha, unit):
    """``(table, sigma)``: the renderer's table (``TABLE_COLUMNS``) and its extinction
    column, built for each render. (Kept on the mesh, it would save about 1 ms, but a
    kept table is out of cache when the ray walk reads it, and the walk lost as much:
    measured on the FEA bracket at 128² and 256², and again on 2026-12-02 with the
    table kept per transfer function: render(upsample=8) new/old 0.88-1.10 on the four
    meshes, same process, no consistent sign.)"""
    table_size = 256 if prec == "uint8" else tf.table_size
    rgb, sigma = tf.table(np.float64, global_alpha, unit, table_size)
    if prec == "uint8":
        # an 8-bit table: colour and the opacity of one unit distance in 256 levels
        rgb = np.round(np.clip(rgb, 0, 1) * 255) / 255
        alpha = np.round(-np.expm1(-sigma * unit) * 255) / 255
        sigma = -np.log1p(-np.minimum(alpha, 1 - 1e-12)) / unit
    a0, a1 = tf.axis_range
    table = np.empty((table_size, TK.TABLE_COLUMNS))
    table[:, :3] = rgb
    table[:, 3] = sigma
    knots = scale_inverse(np.linspace(a0, a1, table_size), tf.scale, tf.linthresh)
    knots[0], knots[-1] = tf.vmin, tf.vmax
    table[:, 8] = np.maximum.accumulate(knots)  # monotone despite rounding of the inverse axis
    TK.cumulative_tables(table)
    return table, sigma


def _render_upsampled(mesh, tf, camera, size, options, factor, tau_max, progress, progress_bar):
    """``render_tets(upsample=factor)``: low-resolution render (I), full-resolution
    reference layers (R), joint bilateral upsampling (U)."""
    from ..image.upsample import upsample

    width, height = as_size(size)
    if width % factor or height % factor:
        raise ValueError(f"size {width}x{height} must be a multiple of upsample={factor}")
    camera = as_camera(camera, mesh.bounds)
    # the low render checks its own arrays; these are the full-size layers and output
    out_item = 8 if options.precision == "float64" else 4
    check_memory({"full-size thickness guide and upsampled image": width * height * (16 + 32 + 4 * out_item + 8)},
                 _MEMORY_ADVICE.format(width=width, height=height))
    t0 = time.perf_counter()
    low, view = TetPlan(mesh, tf, options, tau_max=tau_max).execute_with_view(
        camera, (width // factor, height // factor), progress=progress, progress_bar=progress_bar)
    t1 = time.perf_counter()
    # the thickness guides the filter: no layers are kept. The boundary's view-plane
    # table is the low render's (the camera array is the same for one aspect ratio)
    layers = mesh_layers(mesh, (width, height), *boundary_layers(mesh, camera, (width, height), 0, view=view), t1)
    t2 = time.perf_counter()
    out = upsample(low, layers, factor)
    t3 = time.perf_counter()
    # the settings of the whole render, not of its low-resolution part
    out.metadata["settings"] = {**low.metadata["settings"], "size": [width, height],
                                "keywords": {**low.metadata["settings"]["keywords"], "upsample": factor}}
    if "tolerance" in low.metadata:  # the knobs chosen for the low render
        out.metadata["tolerance"] = low.metadata["tolerance"]
    out.metadata.update({"low_render_seconds": t1 - t0, "reference_seconds": t2 - t1, "upsample_seconds": t3 - t2,
                         "reference_layers": layers.n_layers, "layers_needed": layers.layers_needed})
    return out


_MEMORY_ADVICE = "try a smaller size (now {width}x{height}) or a part of the mesh (e.g. mesh.clip_box(...))"


def render_bytes(mesh, precision, width, height):
    """``{what: bytes}``: what a full-resolution :func:`render_tets` allocates, not
    counting what ``mesh.cache`` already holds; the boundary crossings are counted as
    two per pixel (one entry, one exit), their true number is known only after they
    are found."""
    n_pix = width * height
    out_item = 8 if precision == "float64" else 4
    parts = {"image": n_pix * (4 * out_item + 8 + 8 + 8 + 1),  # rgba, depth, cells, pieces, guard
             "boundary crossings": n_pix * (8 + 8) + 8 + 2 * n_pix * (8 + 8 + 1),
             "boundary faces in view": len(mesh.boundary) * (3 * 2 * 8 + 8 * LK.FACE_FIELDS + 4 * 8)}
    if "cell_records" not in mesh.cache:
        small = max(len(mesh.points), 4 * mesh.n_cells + 3) <= INT32_RECORDS
        parts["cell records"] = mesh.n_cells * (8 if small else 12) * 8 + 64
    return parts


class BoundaryHits:
    """Per pixel, the boundary faces its ray crosses, sorted by distance.

    ``offsets`` (pixels + 1,): pixel ``i``'s crossings are ``[offsets[i], offsets[i+1])``
    of ``t`` (distance in the mesh's normalised units), ``face`` (index into
    ``TetMesh.boundary``) and ``entering`` (True where the ray goes into the mesh).
    """

    def __init__(self, offsets, t, face, entering, width, height):
        self.offsets, self.t, self.face, self.entering = offsets, t, face, entering
        self.width, self.height = width, height

    def counts(self):
        return np.diff(self.offsets).reshape(self.height, self.width)


def camera_array(camera, mesh, width, height):
    """What ``_tet_kernels.pixel_ray`` needs to make the camera's rays (as ``Camera.rays``)
    in the mesh's normalised frame."""
    return np.concatenate([camera.kernel_array((width, height)), mesh.center, [mesh.scale]])


def view_faces(mesh, cam):
    """``(faces, corners)``: ``face_setup``'s table of the boundary faces and their
    corners' view-plane coordinates (``face_view``) for ``cam`` (``camera_array``).
    Neither depends on the image's size, and ``cam`` is the same for every size of one
    aspect ratio, so a low-resolution render and its full-resolution layers share them."""
    tri = mesh.boundary
    corners = np.empty((len(tri), 3, 2))
    LK.face_view(mesh.points, tri, cam, corners)
    faces = np.empty((len(tri), LK.FACE_FIELDS))
    LK.face_setup(mesh.points, tri, _boundary_normals(mesh), corners, cam, faces)
    return faces, corners


def _view(mesh, cam, view=None):
    """``(cam, faces, corners)``: ``view`` when it was made for ``cam`` (another size of
    the same camera array), else ``view_faces`` made now."""
    if view is not None and np.array_equal(view[0], cam):
        return view
    return (cam, *view_faces(mesh, cam))


def _face_table(mesh, cam, width, height, view=None):
    """``(geometry, bands, lanes)``: what the boundary rasteriser (``_layer_kernels``)
    reads for this view and size, ``geometry`` being ``(faces, boxes, band_offsets,
    band_members, points, tri, normals)``: ``view_faces`` (``view``'s, see ``_view``),
    the faces' pixel boxes, the faces of each band of rows, and the mesh's points,
    boundary faces and their normals (for the Plücker test of the rays it leaves to
    it)."""
    _, faces, corners = _view(mesh, cam, view)
    boxes = np.empty((len(faces), 4), dtype=np.int64)
    LK.face_boxes(corners, cam, width, height, boxes)
    bands, lanes = _bands(height)
    offsets, members = LK.band_faces(boxes, height, bands)
    return (faces, boxes, offsets, members, mesh.points, mesh.boundary, _boundary_normals(mesh)), bands, lanes


def boundary_crossings(mesh, camera, size, cam=None, view=None):
    """:class:`BoundaryHits` of the camera's rays (``cam``: ``camera_array``; ``view``:
    a ``_view`` to reuse, see there).

    The boundary faces are rasterised twice with the edge functions of the depth layers
    (``_layer_kernels.rasterize_hits``): once to count each pixel's crossings, once to
    write them where the counts leave room. The same decisions both times, so the
    lists fit exactly, and the renderer covers exactly the pixels whose layers
    :func:`~pv_hdrvol.depth_layers` finds."""
    width, height = size
    cam, geometry, bands, lanes = _boundary_setup(mesh, camera, size, cam, view)
    n_pix = width * height
    counts = np.empty(n_pix, dtype=np.int64)
    empty_f = np.empty(0)
    empty_i = np.empty(0, dtype=np.int64)
    empty_b = np.empty(0, dtype=np.bool_)
    LK.rasterize_hits(*geometry, cam, width, height, bands, lanes, True, empty_i, counts, empty_f, empty_i, empty_b)
    offsets = np.zeros(n_pix + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    total = int(offsets[-1])
    t = np.empty(total)
    face = np.empty(total, dtype=np.int64)
    entering = np.empty(total, dtype=np.bool_)
    LK.rasterize_hits(*geometry, cam, width, height, bands, lanes, False, offsets, counts, t, face, entering)
    return BoundaryHits(offsets, t, face, entering, width, height)


def _boundary_setup(mesh, camera, size, cam=None, view=None):
    """``(cam, geometry, bands, lanes)`` of the boundary rasterisers: the camera array
    (``camera_array``, made here when not given) and the face table for it
    (``_face_table``, reusing ``view`` when it was made for this camera)."""
    width, height = size
    if cam is None:
        cam = camera_array(camera, mesh, width, height)
    geometry, bands, lanes = _face_table(mesh, cam, width, height, view)
    return cam, geometry, bands, lanes


def mesh_layers(mesh, size, counts, t, thickness, t0):
    """:class:`~pv_hdrvol.image.upsample.DepthLayers` of :func:`boundary_layers`' flat ``counts``, layers ``t``
    (k, pixels) and ``thickness`` of ``mesh`` at ``size``, begun at ``t0``
    (``time.perf_counter``)."""
    width, height = size
    return DepthLayers(t.reshape(len(t), height, width), counts.reshape(height, width), time.perf_counter() - t0,
                       f"boundary of {mesh.n_cells} tets", thickness=thickness.reshape(height, width))


def boundary_layers(mesh, camera, size, k, cam=None, view=None):
    """``(counts, t, thickness)``: per pixel the number of boundary crossings
    (``width * height``), the ``k`` nearest crossing distances in order
    (``(k, width * height)``, ``inf`` past the count) and the length of the ray inside
    the mesh (the sum of its exit distances minus its entry distances, at least 0), in
    world units; in one pass and without the lists of :func:`boundary_crossings`.

    The faces are rasterised with the edge functions that give the ray caster its
    entry faces (``_layer_kernels``), so the layers and the render cover the same
    pixels. ``cam``: ``camera_array`` (made here when not given); ``view``: a
    ``_view`` to reuse, see there."""
    width, height = size
    cam, geometry, bands, lanes = _boundary_setup(mesh, camera, size, cam, view)
    n_pix = width * height
    counts = np.empty(n_pix, dtype=np.int64)
    layers = np.empty((k, n_pix))
    thickness = np.empty(n_pix)
    LK.rasterize_layers(*geometry, cam, width, height, bands, lanes, float(mesh.scale), counts, layers, thickness)
    return counts, layers, thickness


def _bands(height):
    """``(bands, lanes)`` of the boundary kernels: bands of at least 16 rows (a face
    that reaches into several bands is set up in each), at most 32 per thread, and one
    lane per thread, so each thread takes every n-th band."""
    import numba

    threads = numba.get_num_threads()
    bands = max(1, min(32 * threads, height // 16))
    return bands, min(threads, bands)


#: the largest point index or neighbour code (``4 cell + 3``) of int32 cell records
INT32_RECORDS = 2**31 - 1


def _cell_records(mesh):
    """``(cells_i, cells_f)``: one record per cell, kept on the mesh, which is all the
    ray walk reads of a cell but its fourth corner's point. Two views of one buffer: the
    integer view (int32, or int64 where an index would not fit) holds the corners
    (``TK.CORNER_COL``) and the neighbour codes ``4 cell + face`` (-1 on the boundary;
    ``TK.NEIGHBOR_COL``), the float64 view ends with the four corner values
    (``TK._value_col``). With int32 a record is 64 bytes, aligned to a cache line: one
    line a cell visited, where separate arrays of corners, neighbours, their faces and
    values cost four.
    """
    if "cell_records" not in mesh.cache:
        n = mesh.n_cells
        small = max(len(mesh.points), 4 * n + 3) <= INT32_RECORDS
        itype = np.int32 if small else np.int64
        value_col = 4 if small else 8  # float64 slots of the 8 ints (4 or 8 bytes each)
        row = value_col + 4  # then the 4 values
        raw = np.zeros(n * row * 8 + 64, dtype=np.uint8)
        skip = (-raw.ctypes.data) % 64  # records start on a cache line
        cells_f = raw[skip:skip + n * row * 8].view(np.float64).reshape(n, row)
        cells_i = cells_f.view(itype)
        cells_i[:, TK.CORNER_COL:TK.CORNER_COL + 4] = mesh.tets
        codes = np.where(mesh.neighbors >= 0, 4 * mesh.neighbors + mesh.neighbor_faces, -1)
        cells_i[:, TK.NEIGHBOR_COL:TK.NEIGHBOR_COL + 4] = codes
        cells_f[:, value_col:value_col + 4] = mesh.values
        mesh.cache["cell_records"] = (cells_i, cells_f)
    return mesh.cache["cell_records"]


def cell_gradients(mesh):
    """The gradient of each cell's linear interpolant, world units, (cells, 3) float64;
    cached on the mesh.

    Solves ``(p_i - p_0) . g = v_i - v_0`` for the corners ``i = 1, 2, 3``. A degenerate
    cell (no volume) or one with a non-finite corner value gets 0: it is not lit.
    """
    if "cell_gradients" not in mesh.cache:
        p = mesh.world_points()[mesh.tets]  # (cells, 4, 3)
        edges = p[:, 1:] - p[:, :1]
        dv = mesh.values[:, 1:] - mesh.values[:, :1]
        det = np.linalg.det(edges)
        size = np.einsum("cij,cij->c", edges, edges) ** 1.5 / 27.0
        ok = (np.abs(det) > 1e-12 * size) & np.all(np.isfinite(dv), axis=1)
        grads = np.zeros((len(p), 3))
        if ok.any():
            grads[ok] = np.linalg.solve(edges[ok], dv[ok][..., None])[..., 0]
        mesh.cache["cell_gradients"] = np.ascontiguousarray(grads)
    return mesh.cache["cell_gradients"]


def _boundary_normals(mesh):
    """Outward (unnormalised) normals of the boundary faces, kept on the mesh."""
    if "boundary_normals" not in mesh.cache:
        pts, tri = mesh.points, mesh.boundary
        a, b, c = (pts[tri[:, i]] for i in range(3))
        mesh.cache["boundary_normals"] = np.ascontiguousarray(np.cross(b - a, c - a))
    return mesh.cache["boundary_normals"]


def _any_finite_cell(mesh):
    """Whether any cell has four finite corner values (after ``_active_cells``)."""
    return bool(np.isfinite(mesh.cache["cell_ranges"][0]).any())


def _active_cells(mesh, sigma, params):
    """1 for cells whose corner values can meet a non-zero extinction, else 0 (skipped):
    the grid's block test (``grid._visible``) on each cell's value range. A cell with a
    non-finite corner value is empty.

    The value ranges are computed once per mesh, and the mask is kept on the mesh for the
    last few extinction columns (``grid.cached``), so a render that changes only the
    camera pays neither."""
    if "cell_ranges" not in mesh.cache:
        finite = np.all(np.isfinite(mesh.values), axis=1)
        mesh.cache["cell_ranges"] = (np.where(finite, mesh.values.min(axis=1), np.nan),
                                     np.where(finite, mesh.values.max(axis=1), np.nan))
    lo, hi = mesh.cache["cell_ranges"]
    key = (params.scale, params.axis_lo, params.axis_inv_range, params.linthresh, content_digest(sigma))
    # the tet kernel interpolates the table in every precision (no nearest-entry rule)
    return cached(mesh.cache, "active_cells", key,
                  lambda: ranges_visible(lo, hi, sigma, params._replace(precision=PRECISION_CODES["float64"])),
                  _ACTIVE_CACHE)

