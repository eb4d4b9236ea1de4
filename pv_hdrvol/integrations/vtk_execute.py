"""How :class:`~pv_hdrvol.integrations.vtk_algorithm.HDRVolumeRenderer` executes: one
path for every kind of input.

:func:`execute` is the algorithm's ``RequestData``. :func:`route` names the kind of
render this execution is (a :class:`Kind`, from :data:`KINDS`):

- ``"whole"``: piece 0 renders all of the input (image data, a rectilinear,
  curvilinear or tetrahedral grid, a composite dataset) through a
  :class:`~pv_hdrvol.raycast.grid.GridPlan` or :class:`~pv_hdrvol.raycast.tets.TetPlan`
  (:func:`plan_for`; blocks gather onto one volume or merge into one mesh,
  :func:`pv_hdrvol.data.kinds.as_renderable`);
- ``"store"``: a level of a multiresolution store renders the whole store out of core
  (:class:`~pv_hdrvol.outofcore.render.MultiscalePlan`);
- ``"grid piece"``, ``"mesh piece"``: under MPI each process renders the piece of image
  data (or rectilinear grid) or of a mesh it holds, and piece 0 composites them
  (:mod:`pv_hdrvol.parallel.pieces`; :mod:`~pv_hdrvol.integrations.vtk_pieces`).

Every kind then runs the same steps: ``share`` (what the processes agree on before any
renders: collective, an error is raised on every process), ``prepare`` (this process's
:class:`Job`: a plan, a camera and the plan's execute keywords), the render
(``plan.execute`` with the one progress and abort closure, :func:`progress_of`),
``finish`` (piece 0 composites the pieces: collective, if any process failed all raise;
or the image as it is) and the output (the image, or an empty output: an aborted render,
a piece other than 0).

An execution reads the algorithm's settings through its getters and three hooks of
the class (``_scalars_to_render``: the array chosen, ``_transfer_function``: the
function set or made of a lookup table, ``_should_abort``), reports through
``UpdateProgress``/``SetProgressText``, and keeps what survives executions (plans,
volumes, moved cells, open stores, the last camera) in the algorithm's
:class:`ExecutionState`. A new kind of input is a new entry of :data:`KINDS` (and a
branch of :func:`route`), not a copy of these steps.
"""
from __future__ import annotations

import contextlib
import dataclasses
import time
from typing import Callable, NamedTuple

from vtkmodules.vtkCommonCore import vtkOutputWindow
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkImageData
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

from ..data.kinds import BLOCKS, IMAGE_CLASSES, MESH, SUPPORTED, as_renderable, data_kind
from ..data.transfer import TransferFunction, default_transfer_function_keyword
from ..rays.camera import Camera, as_camera, fit_camera
from . import VolumeCache, _content_key
from .vtk_base import request_whole_extent
from .vtk_pieces import (ControllerComm, Distribution, mesh_summary, output_piece, piece_extent, points_owned,
                         redistribute, share_cores, tet_grid_of_structured, whole_axes)

_SDDP = vtkStreamingDemandDrivenPipeline


class ExecutionState:
    """What an :class:`~pv_hdrvol.integrations.vtk_algorithm.HDRVolumeRenderer` keeps
    between executions: what is prepared (kept while its inputs are unchanged, so that a
    new camera or size re-renders only) and what the last execution chose."""

    def __init__(self):
        # bricks survive re-executions for a new camera or TF; keyed by the arrays, not
        # by the input object, which ParaView hands over as a new shallow copy each time
        self.volumes = VolumeCache(dataset_mtime=False)
        self.plan = None  # (key, GridPlan or TetPlan): kept while data, tf and options are unchanged
        self.default_tf = None  # (data, keywords, the data's default transfer function)
        self.shared_tf = None  # (dict, TransferFunction): piece 0's, as last received
        self.moved = None  # a mesh piece: (key, summary, (box, the cells moved to it, points) or None)
        self.tet_piece = None  # a curvilinear piece: (key, its tetrahedra as a vtkUnstructuredGrid)
        self.stores = {}  # store path -> MultiscaleVolume (its chunk cache stays between renders)
        self.store_plan = None  # (key, MultiscalePlan)
        self.last_camera = None
        self.last_tolerance = None
        self.last_piece = None

    def close_stores(self):
        """Close the stores opened for out-of-core renders (and drop their plan)."""
        self.store_plan = None
        for volume in self.stores.values():
            volume.close()
        self.stores.clear()


class Job(NamedTuple):
    """One process's render: ``plan.execute(camera, size, progress=..., **keywords)``,
    and what :attr:`Kind.finish` needs besides the image to composite it (a piece's
    box or lattice, and its rays)."""

    plan: object
    camera: Camera
    keywords: dict
    composite: tuple = ()


class Kind(NamedTuple):
    """The parts of an execution that depend on what is rendered; :func:`execute` runs
    them in order (see the module's docstring)."""

    #: whether the processes render together (an error is then sent to all of them)
    collective: bool
    #: ``(algorithm, inp, context) -> shared``: what every process must agree on first
    share: Callable
    #: ``(algorithm, inp, shared) -> Job``
    prepare: Callable
    #: ``(algorithm, inp, shared, job, image, error) -> HDRImage or None``
    finish: Callable
    #: ``shared -> "<what>"``: what numba compiles for it, named the first time
    compiles: Callable


# -- the one path ------------------------------------------------------------------------
def execute(algorithm, inInfo, outInfo):
    """Render the input of ``algorithm`` into its output (its ``RequestData``)."""
    inp = vtkDataObject.GetData(inInfo[0])
    out = vtkImageData.GetData(outInfo)
    name, context = route(algorithm, inInfo, outInfo, inp)
    image = None if name is None else _run(algorithm, KINDS[name], inp, context)
    if image is None:
        out.Initialize()  # an aborted render, or a piece other than 0, leaves no output
    else:
        out.ShallowCopy(image.to_vtk())
    return 1


def _run(algorithm, kind, inp, context):
    state = algorithm._state
    shared = kind.share(algorithm, inp, context)
    state.last_tolerance = None
    image = error = job = None
    with progress_of(algorithm, kind.compiles(shared)) as progress:
        try:
            # a plan (validated options, tables, skip structures) is made once and
            # executed for each camera and size: rotating the view re-renders only
            job = kind.prepare(algorithm, inp, shared)
            # progress goes to VTK's ProgressEvent (PyVista's and ParaView's bars), not tqdm
            image = job.plan.execute(job.camera, algorithm.GetImageSize(), progress=progress, progress_bar=False,
                                     **job.keywords)
        except Exception as e:
            if kind.collective:
                error = e  # every process learns of it in finish; none waits forever
            elif isinstance(e, RuntimeError) and algorithm._should_abort():
                return None  # an aborted render leaves no output
            else:
                raise
    image = kind.finish(algorithm, inp, shared, job, image, error)
    if image is not None:
        state.last_tolerance = image.metadata.get("tolerance")
    return image


@contextlib.contextmanager
def progress_of(algorithm, compiles):
    """The progress and abort closure of an execution: ``progress(fraction)`` reports to
    VTK (``UpdateProgress``: ``ProgressEvent``) and returns ``False`` once the execution
    is to stop (``AbortExecute``). The first render of ``compiles`` in a process (numba
    compiles its kernels, or loads them from its cache) says so in the progress text and
    the output window, with the time it took."""
    first = _first_use(compiles, algorithm.GetOptions())
    if first:
        # said before numba blocks the thread: ParaView's status bar shows it while it compiles
        algorithm.SetProgressText(f"compiling the {first} ray caster (first use)")
        algorithm.UpdateProgress(0.0)
        _display_text(f"pv_hdrvol: first {first} render in this process: compiling the ray caster, or loading "
                      f"it from numba's cache ({_numba_cache_dir()}); the first time this takes about a minute")
    started = time.perf_counter()

    def progress(fraction):
        if first and fraction > 0:
            algorithm.SetProgressText("rendering")
        algorithm.UpdateProgress(fraction)
        return not algorithm._should_abort()

    try:
        yield progress
    finally:
        if first:
            _display_text(f"pv_hdrvol: first {first} render took {time.perf_counter() - started:.1f} s")


def route(algorithm, inInfo, outInfo, inp):
    """``(name of the Kind, its context)`` of this execution, or ``(None, None)`` when
    this process outputs nothing (piece 0 renders the whole image)."""
    distribution = distribution_of(algorithm, inInfo, outInfo)
    if distribution is not None:
        return ("mesh piece" if distribution.whole is None else "grid piece"), distribution
    if output_piece(outInfo) != 0:  # piece 0 renders the whole image (request_update_extent)
        return None, None
    kind = inp.GetClassName() if inp is not None else None
    try:
        what = None if inp is None else data_kind(inp)
    except TypeError:
        what = None
    if what is None or inp.GetNumberOfPoints() == 0:
        raise ValueError(f"HDRVolumeRenderer needs a non-empty volume on input port 0 ({SUPPORTED}); got "
                         f"{'nothing' if inp is None else kind}")
    if kind not in IMAGE_CLASSES and (algorithm.GetLens() is not None or algorithm.GetLabels()[0] is not None
                                      or algorithm.GetCull() is not None):
        raise ValueError(f"SetLens, SetLabels and SetCull apply to image data only, not to a {kind}")
    scalars, preference = algorithm._scalars_to_render()
    store = store_input(algorithm, inp, scalars, preference)
    if store is not None:
        return "store", store[0]
    return "whole", (scalars, preference, what == MESH or (what == BLOCKS and _blocks_are_meshes(inp)))


# -- the kinds ---------------------------------------------------------------------------
def _nothing_to_share(algorithm, inp, context):
    return context


def _as_rendered(algorithm, inp, shared, job, image, error):
    return image


def _camera_setting(algorithm):
    """The camera set, fields made into a :class:`Camera` (checked together now)."""
    camera = algorithm.GetCamera()
    return Camera(**camera) if isinstance(camera, dict) else camera


def _prepare_whole(algorithm, inp, shared):
    scalars, preference, mesh = shared
    # a view name frames the input's bounds (its rendered blocks'), as hv.render frames it
    camera = fit_camera(inp, _camera_setting(algorithm), scalars=scalars, preference=preference)
    algorithm._state.last_camera = camera
    tf = algorithm._transfer_function()
    plan = plan_for(algorithm, inp, scalars, preference, tf)
    keywords = {} if mesh else {"lens": algorithm.GetLens(), "cull": algorithm.GetCull()}
    return Job(plan, camera, keywords)


def _prepare_store(algorithm, inp, volume):
    """The store out of core, with the transfer function and options the in-memory
    render would use."""
    if algorithm.GetLabels()[0] is not None or algorithm.GetCull() is not None:
        raise ValueError("SetLabels and SetCull are not supported for a multiresolution store rendered out "
                         "of core; SetOutOfCore(False) renders the level in memory")
    from ..outofcore.render import MultiscalePlan

    state = algorithm._state
    tf = algorithm._transfer_function()
    options, words = algorithm.GetOptions(), _tf_words(algorithm)
    key = (volume, tf, options, _tf_meanings(words))
    old = None if state.store_plan is None else state.store_plan[0]
    # the volume and the transfer function by identity, the rest by value
    if old is None or old[0] is not volume or old[1] is not tf or old[2:] != key[2:]:
        state.store_plan = None
        given = {} if tf is not None else words
        state.store_plan = (key, MultiscalePlan(volume, tf, options, **given))
    camera = fit_camera(volume, _camera_setting(algorithm))
    state.last_camera = camera
    return Job(state.store_plan[1], camera,
               {"screen_error": algorithm.GetScreenError(), "wait": True, "lens": algorithm.GetLens()})


class _GridShare(NamedTuple):
    distribution: Distribution
    tf: TransferFunction
    whole_axes: object  # tuple of 3 arrays, an exception to raise, or None (image data)


def _share_grid_piece(algorithm, inp, distribution):
    tf = shared_transfer_function(algorithm, distribution.comm)
    share_cores(distribution.comm)
    return _GridShare(distribution, tf, whole_axes(inp, distribution))  # collective


def _prepare_grid_piece(algorithm, inp, shared):
    """This process's piece of the image (or rectilinear grid): sampled on the whole
    volume's lattice where it owns the midpoints."""
    import numpy as np

    from ..raycast.grid import VolumePiece

    distribution, owned = shared.distribution, shared.distribution.owned
    if owned[1] <= owned[0] or owned[3] <= owned[2] or owned[5] <= owned[4]:
        raise ValueError(f"the image of extent {distribution.whole} has too few cells for "
                         f"{distribution.comm.size} processes: process {distribution.comm.rank} owns "
                         f"{owned}; render it on fewer processes")
    if isinstance(shared.whole_axes, Exception):
        raise shared.whole_axes
    kind = inp.GetClassName() if inp is not None else None
    if kind not in ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid", "vtkRectilinearGrid"):
        raise ValueError(f"HDRVolumeRenderer renders a distributed vtkImageData or vtkRectilinearGrid; "
                         f"process {distribution.comm.rank} got {'nothing' if inp is None else kind}")
    scalars, preference = algorithm._scalars_to_render()
    data = algorithm._state.volumes.get(inp, scalars, preference)
    if data.values.shape[::-1] != tuple(e[1] - e[0] + 1 for e in np.reshape(inp.GetExtent(), (3, 2))):
        raise ValueError(f"a distributed volume is rendered from a point array; "
                         f"{data.name or 'the active scalars'!r} is a cell array (apply Cell Data to Point "
                         f"Data, or render it on one process)")
    spacing = data.spacing
    options = None
    if shared.whole_axes is not None:  # a rectilinear piece samples the whole grid's lattice
        axes = shared.whole_axes
        start = np.asarray(inp.GetExtent()[0::2]) - np.asarray(distribution.whole[0::2])
        local = tuple(a[o:o + n] for a, o, n in zip(axes, start, data.values.shape[::-1]))
        if data.axes is None:  # even within the piece, uneven in the whole
            data = dataclasses.replace(data, axes=local, cache={})
        piece = VolumePiece.from_rectilinear(axes, start, np.asarray(owned[0::2]) -
                                             np.asarray(distribution.whole[0::2]),
                                             np.asarray(owned[1::2]) - np.asarray(distribution.whole[0::2]))
        options = piece.options_for(algorithm.GetOptions(), data)
    else:
        piece = VolumePiece.from_extents(inp.GetOrigin(), inp.GetSpacing(), distribution.whole,
                                         inp.GetExtent(), owned)
    camera = as_camera(_camera_setting(algorithm), piece.bounds(spacing))
    algorithm._state.last_camera = camera
    rays = camera.rays(algorithm.GetImageSize())
    plan = plan_for(algorithm, inp, scalars, preference, shared.tf, data=data if options else None,
                    options=options)
    return Job(plan, camera, {"piece": piece}, (piece, spacing, rays))


def _composite_grid_pieces(algorithm, inp, shared, job, image, error):
    """Piece 0 composites the partial images in depth order
    (:func:`pv_hdrvol.parallel.pieces.gather_pieces`: if any process failed, all raise,
    the others naming it)."""
    from ..parallel.pieces import gather_pieces

    algorithm._state.last_piece = inp
    piece, spacing, rays = (None, None, None) if job is None else job.composite
    return gather_pieces(image, piece, spacing, rays, comm=shared.distribution.comm, root=0, error=error)


class _MeshShare(NamedTuple):
    comm: ControllerComm
    everyone: list  # every process's mesh_summary
    scalars: str
    preference: str
    tf: TransferFunction
    piece: object  # this process's MeshPiece
    part: object  # the cells moved to its box (vtkUnstructuredGrid)
    points: int  # the whole mesh's distinct points
    diagonal: float  # of the whole mesh's bounds


def _share_mesh_piece(algorithm, inp, distribution):
    """A tetrahedral mesh spread over processes: cut its bounds into one box per process
    (k-d, at quantiles of the cell centres: about equal cells each) and move to each
    process every cell that meets its box (``vtkRedistributeDataSetFilter`` with these
    cuts; cells on a cut go to both sides); the moved cells are kept while no process's
    piece changed."""
    import numpy as np

    from ..parallel.pieces import allgather_or_raise, split_bounds
    from ..raycast.tets import MeshPiece

    state, comm = algorithm._state, distribution.comm
    scalars, preference = algorithm._scalars_to_render()
    summary = error = None
    try:
        if inp is not None and inp.GetClassName() == "vtkStructuredGrid":
            key = (_content_key(inp), tuple(inp.GetExtent()))
            if state.tet_piece is None or state.tet_piece[0] != key:
                state.tet_piece = (key, tet_grid_of_structured(inp))
            inp = state.tet_piece[1]
        kind = inp.GetClassName() if inp is not None else None
        if kind != "vtkUnstructuredGrid":
            raise ValueError(f"HDRVolumeRenderer renders a distributed vtkUnstructuredGrid; process {comm.rank} "
                             f"got {'nothing' if inp is None else kind}")
        if scalars is None and inp.GetNumberOfCells():
            active = inp.GetPointData().GetScalars()
            scalars = active.GetName() if active is not None else None
        key = (scalars, _content_key(inp))
        if state.moved is None or state.moved[0] != key:
            state.moved = (key, mesh_summary(inp, scalars), None)
        summary = dict(state.moved[1], changed=state.moved[2] is None)
    except Exception as e:  # said to every process before the collective redistribution
        error = e
    everyone = allgather_or_raise(comm, summary, error)
    held = [s for s in everyone if s["cells"]]
    if not held:
        raise ValueError("HDRVolumeRenderer needs a non-empty vtkUnstructuredGrid: no process holds a cell")
    names = [s["scalars"] for s in held if s["scalars"]]
    scalars = scalars if scalars is not None else (names[0] if names else None)
    lo = np.min([s["bounds"][0::2] for s in held], axis=0)
    hi = np.max([s["bounds"][1::2] for s in held], axis=0)
    bounds = tuple(float(v) for pair in zip(lo, hi) for v in pair)
    # each process's sample stands for its cells: a k-d split of equal cells
    boxes = split_bounds(bounds, comm.size, np.concatenate([s["centres"] for s in held]),
                         np.concatenate([np.full(len(s["centres"]), s["cells"] / len(s["centres"])) for s in held]))
    tf = shared_transfer_function(algorithm, comm)
    share_cores(comm)
    mine = MeshPiece(tuple(boxes[comm.rank][0]), tuple(boxes[comm.rank][1]), tuple(lo), tuple(hi))
    if any(s["changed"] for s in everyone) or state.moved[2] is None or state.moved[2][0] != mine:
        # no process's piece changed (a new camera, size or colour map): keep the
        # moved cells, whose TetMesh is then kept too
        part = redistribute(inp, boxes, comm)
        # the whole mesh's distinct points, each counted by the one box that owns it
        points = sum(comm.allgather(points_owned(part, mine)))
        state.moved = (state.moved[0], state.moved[1], (mine, part, points))
    _, part, points = state.moved[2]
    return _MeshShare(comm, everyone, scalars, preference, tf, mine, part, points, float(np.linalg.norm(hi - lo)))


def _prepare_mesh_piece(algorithm, inp, shared):
    """The span of each ray in this process's box (``TetPlan.execute(piece=...)``)."""
    from ..raycast.tets import TetPlan

    state, piece = algorithm._state, shared.piece
    camera = as_camera(_camera_setting(algorithm), piece.bounds())
    state.last_camera = camera
    rays = camera.rays(algorithm.GetImageSize())
    options = algorithm.GetOptions()
    if options.opacity_unit_distance is None:
        # the whole mesh's (TetMesh.default_unit_distance), not this piece's
        options = dataclasses.replace(options, opacity_unit_distance=shared.diagonal / shared.points ** (1.0 / 3.0)
                                      if shared.diagonal > 0 else 1.0)
    if not shared.part.GetNumberOfCells():
        return Job(_NothingHere(options), camera, {}, (piece.world_box(), rays))
    data = state.volumes.get(shared.part, shared.scalars, shared.preference)
    key = (data, shared.tf, options)  # kept while the piece, the function and the options are unchanged
    if state.plan is None or state.plan[0][:2] != (data, shared.tf) or state.plan[0][2] != options:
        state.plan = None
        state.plan = (key, TetPlan(data, shared.tf, options))
    return Job(state.plan[1], camera, {"piece": piece}, (piece.world_box(), rays))


class _NothingHere:
    """The plan of a box that holds no cell of the mesh: a transparent image."""

    def __init__(self, options):
        self.options = options

    def execute(self, camera, size, **_):
        import numpy as np

        from ..image.hdr import HDRImage

        w, h = size
        dtype = np.float64 if self.options.precision == "float64" else np.float32
        return HDRImage(np.zeros((h, w, 4), dtype=dtype), np.full((h, w), np.inf))


def _composite_mesh_boxes(algorithm, inp, shared, job, image, error):
    """Piece 0 composites the boxes' images in depth order
    (:func:`pv_hdrvol.parallel.pieces.gather_boxes`)."""
    from ..parallel.pieces import gather_boxes

    box, rays = (None, None) if job is None else job.composite
    whole = gather_boxes(image, box, rays, comm=shared.comm, root=0, error=error)
    if whole is not None:
        whole.metadata["cells_per_process"] = [s["cells"] for s in shared.everyone]
    algorithm._state.last_piece = shared.part
    return whole


#: The kinds of execution, by the name :func:`route` gives.
KINDS = {
    "whole": Kind(False, _nothing_to_share, _prepare_whole, _as_rendered,
                  lambda shared: "tetrahedral mesh" if shared[2] else "image volume"),
    "store": Kind(False, _nothing_to_share, _prepare_store, _as_rendered, lambda shared: "multiresolution store"),
    "grid piece": Kind(True, _share_grid_piece, _prepare_grid_piece, _composite_grid_pieces,
                       lambda shared: "image volume"),
    "mesh piece": Kind(True, _share_mesh_piece, _prepare_mesh_piece, _composite_mesh_boxes,
                       lambda shared: "tetrahedral mesh"),
}


# -- what the kinds share ------------------------------------------------------------------
def _tf_words(algorithm):
    """The default transfer function's keywords as set (``cmap``, ``clim``, ``opacity``, ``scale``)."""
    return {"cmap": algorithm.GetCmap(), "clim": algorithm.GetClim(), "opacity": algorithm.GetOpacity(),
            "scale": algorithm.GetScale()}


def _tf_meanings(words):
    """The keywords by meaning (an opacity may be an array), comparable."""
    return tuple((name, None if value is None else default_transfer_function_keyword(name, value))
                 for name, value in words.items())


def plan_for(algorithm, inp, scalars, preference, tf, data=None, options=None):
    """The :class:`GridPlan` or :class:`TetPlan` of this input, transfer function and
    options, made again only when one of them changed; the default transfer function
    of the data is kept while the data and its keywords are unchanged (it reads every
    value: 0.6 s for engine). The same pixels as ``render_volume``/``render_tets``,
    which resolve the transfer function, make a plan and execute it once."""
    from ..data.tets import TetMesh
    from ..raycast.grid import resolve_render_options

    state = algorithm._state
    opts = algorithm.GetOptions() if options is None else options
    if data is not None:  # prepared by the caller (a rectilinear piece)
        pass
    elif inp.IsA("vtkCompositeDataSet"):  # gathered onto one volume or merged into one mesh, cached
        data = as_renderable(inp, scalars=scalars, preference=preference)
    else:
        data = state.volumes.get(inp, scalars, preference)
    words = _tf_words(algorithm)
    keywords = _tf_meanings(words)
    made = state.default_tf
    if tf is None and made is not None and made[0] is data and made[1] == keywords:
        tf = made[2]  # the data's default function, kept
    else:  # as every front end: a transfer function and a keyword are the same TypeError
        given = tf
        tf, opts = resolve_render_options(data, tf, opts, **words)
        if given is None:
            state.default_tf = (data, keywords, tf)
    label_name, label_styles = algorithm.GetLabels()
    labels = None if label_name is None else (label_name, id(label_styles))
    if state.plan is not None:
        old = state.plan[0]  # the data and the transfer function by identity, the rest by value
        if old[0] is data and old[1] is tf and old[2:] == (opts, labels):
            return state.plan[1]
        unclipped = opts.replace(clip_planes=(), crop_box=None)
        if old[0] is data and old[1] is tf and old[3] == labels \
                and old[2].replace(clip_planes=(), crop_box=None) == unclipped:
            # only the clip changed (a plane dragged): the plan's tables and arrays stay
            plan = state.plan[1].with_clip(opts.clip_planes, opts.crop_box)
            state.plan = ((data, tf, opts, labels), plan)
            return plan
    state.plan = None  # drop the old plan (and its arrays) before making the new one
    if isinstance(data, TetMesh):
        from ..raycast.tets import TetPlan

        plan = TetPlan(data, tf, opts)
    else:
        from ..data.grid import labels_from_dataset
        from ..raycast.grid import GridPlan

        label_array = None if label_name is None else labels_from_dataset(inp, label_name, preference)
        plan = GridPlan(data, tf, opts, labels=label_array, label_styles=label_styles)
    state.plan = ((data, tf, opts, labels), plan)
    return plan


def shared_transfer_function(algorithm, comm):
    """Piece 0's transfer function, on every process (collective). In a symmetric
    batch run each process has its own colour map, which ParaView rescales to the
    data it sees: a process that holds no data kept [0, 1] and rendered its piece
    with it (seen with 2 ranks). Piece 0's is the one a script or the GUI shows. The
    same function received again is the same object, so plans are kept."""
    state = algorithm._state
    local = None
    if comm.rank == 0:
        try:
            local = algorithm._transfer_function()
        except (TypeError, ValueError) as e:  # every process raises it
            local = e
    received = comm.bcast(None if local is None else (local if isinstance(local, Exception)
                                                      else local.to_dict()), root=0)
    if isinstance(received, Exception):
        raise received
    if state.shared_tf is None or state.shared_tf[0] != received:
        state.shared_tf = (received, TransferFunction.from_dict(received))
    return state.shared_tf[1]


def store_input(algorithm, inp, scalars, preference):
    """``(MultiscaleVolume, level)`` when ``inp`` is a MultiscaleReader's level that
    is still that level (its array chosen, its geometry) and out of core is on, else
    ``None``: data changed on its way (another array, a cut) renders in memory as any
    other. The store is opened once per path (:func:`pv_hdrvol.open_multiscale`) and
    kept between executions."""
    if not algorithm.GetOutOfCore() or inp is None or inp.GetClassName() not in IMAGE_CLASSES:
        return None
    from .vtk_multiscale import store_of

    found = store_of(inp)
    if found is None:
        return None
    path, level, name = found
    active = inp.GetPointData().GetScalars()
    chosen = scalars if scalars is not None else (None if active is None else active.GetName())
    if chosen != name or (scalars is not None and preference == "cell"):
        return None
    stores = algorithm._state.stores
    volume = stores.get(path)
    if volume is None:
        from ..outofcore.render import open_multiscale

        cache_bytes = algorithm.GetCacheBytes()
        kwargs = {} if cache_bytes is None else {"cache_bytes": cache_bytes}
        volume = stores[path] = open_multiscale(path, **kwargs)
    store = volume.store
    if not 0 <= level < store.n_levels:
        return None
    import numpy as np

    spacing, origin = store.level_geometry(level)
    if tuple(inp.GetDimensions()) != tuple(store.levels[level].dims) \
            or not np.allclose(inp.GetSpacing(), spacing, rtol=1e-9, atol=0) \
            or not np.allclose(inp.GetOrigin(), origin, rtol=1e-9, atol=1e-12 * float(np.abs(spacing).max())):
        return None
    return volume, level


# -- pieces: who renders what ------------------------------------------------------------
def distribution_of(algorithm, inInfo, outInfo):
    """The :class:`~pv_hdrvol.integrations.vtk_pieces.Distribution` of this execution
    when the data is rendered where it lives, else ``None`` (piece 0 renders all of
    it). Decided from the pipeline's information and the filter's settings only, never
    from a piece's data, so that every process decides alike (they then exchange
    images)."""
    info = outInfo.GetInformationObject(0)
    n = info.Get(_SDDP.UPDATE_NUMBER_OF_PIECES()) if info.Has(_SDDP.UPDATE_NUMBER_OF_PIECES()) else 1
    in_info = inInfo[0].GetInformationObject(0)
    data = in_info.Get(vtkDataObject.DATA_OBJECT()) if in_info.Has(vtkDataObject.DATA_OBJECT()) else None
    # image data and rectilinear grids: each process renders its piece of the extent
    structured = in_info.Has(_SDDP.WHOLE_EXTENT()) and (
        data is None or data.GetClassName() in IMAGE_CLASSES + ("vtkRectilinearGrid",))
    # a curvilinear grid's pieces are rendered as the tetrahedra a whole grid's render
    # makes of them, as a mesh's pieces
    mesh = not structured and data is not None and data.GetClassName() in ("vtkUnstructuredGrid",
                                                                            "vtkStructuredGrid")
    if algorithm.GetOutOfCore() and data is not None \
            and data.GetFieldData().GetAbstractArray("pv_hdrvol_store") is not None:
        return None  # a store's level: piece 0 renders the store out of core
    options = algorithm.GetOptions()
    if n < 2 or not algorithm.DISTRIBUTED or not (structured or mesh) or algorithm.GetLens() is not None \
            or algorithm.GetLabels()[0] is not None or algorithm.GetCull() is not None \
            or options.tolerance is not None:
        return None  # a tolerance's knobs are chosen on a pilot of the whole image
    try:
        if algorithm._scalars_to_render()[1] == "cell" or algorithm._transfer_function() is None:
            return None  # a cell array; the default function reads every value of the whole volume
    except (TypeError, ValueError):
        return None  # piece 0 reports it
    comm = algorithm.GetCommunicator()
    comm = comm if comm is not None else ControllerComm.world()
    piece = output_piece(outInfo)
    if comm is None or comm.size != n or comm.rank != piece:
        return None
    if mesh:  # the pieces the reader gives; cut into boxes and exchanged by the mesh piece's share
        if not isinstance(comm, ControllerComm):
            return None  # vtkRedistributeDataSetFilter needs VTK's processes
        return Distribution(comm, None, None, None, 0)
    whole = tuple(in_info.Get(_SDDP.WHOLE_EXTENT()))
    ghosts = 1 if (options.shade or options.gradient_opacity is not None) else 0
    return Distribution(comm, whole, piece_extent(whole, piece, n, 0), piece_extent(whole, piece, n, ghosts),
                        ghosts)


def request_update_extent(algorithm, inInfo, outInfo):
    """What the algorithm asks of its input (its ``RequestUpdateExtent``).

    Distributed (:func:`distribution_of`): each process asks for its piece of the
    extent. Otherwise a ray may cross any part of the volume: piece 0 asks for all of it
    (the whole extent of an image; piece 0 of 1 of a mesh) and renders alone, the other
    pieces leave the request as it is and output an empty image."""
    info = inInfo[0].GetInformationObject(0)
    plan = distribution_of(algorithm, inInfo, outInfo)
    if plan is not None and plan.whole is None:
        if info.Has(_SDDP.WHOLE_EXTENT()):  # a curvilinear grid: its piece of the extent, as an image's
            whole = tuple(info.Get(_SDDP.WHOLE_EXTENT()))
            info.Set(_SDDP.UPDATE_EXTENT(), piece_extent(whole, output_piece(outInfo), plan.comm.size, 0), 6)
            info.Set(_SDDP.UPDATE_PIECE_NUMBER(), 0)
            info.Set(_SDDP.UPDATE_NUMBER_OF_PIECES(), 1)
            info.Set(_SDDP.UPDATE_NUMBER_OF_GHOST_LEVELS(), 0)
        return 1  # a mesh: each process takes the piece its reader gives
    if plan is not None:
        # the extent itself, ghost points included, as "piece 0 of 1": XML image
        # readers cut their own pieces from the piece number and a ghost level, with
        # another split than the extent translator's (ParaView 5.11, 3 processes)
        info.Set(_SDDP.UPDATE_EXTENT(), plan.extent, 6)
        info.Set(_SDDP.UPDATE_PIECE_NUMBER(), 0)
        info.Set(_SDDP.UPDATE_NUMBER_OF_PIECES(), 1)
        info.Set(_SDDP.UPDATE_NUMBER_OF_GHOST_LEVELS(), 0)
        return 1
    if output_piece(outInfo) != 0:
        return 1
    request_whole_extent(info)
    info.Set(_SDDP.UPDATE_PIECE_NUMBER(), 0)
    info.Set(_SDDP.UPDATE_NUMBER_OF_PIECES(), 1)
    return 1


def _blocks_are_meshes(data):
    """Whether the volumetric blocks of a composite dataset are meshes (rendered by the
    tetrahedral ray caster), not grids."""
    from ..data.blocks import classify, flatten

    kinds = classify(flatten(data)[0])
    return bool(kinds["mesh"]) and not (kinds["image"] or kinds["rectilinear"])


# -- the first render of a process: numba compiles ---------------------------------------
#: (what, precision) of the renders done in this process
_RENDERED = set()


def _first_use(what, options):
    """``"<precision> [shaded] <what>"`` (``"float32 image volume"``, ``"float32 shaded
    tetrahedral mesh"``) the first time a process renders that variant (when numba
    compiles its kernels or loads them from its cache), else ``""``. The variants
    named are those numba compiles apart and a user switches between: the precision
    (a tolerance's is float64) and shading."""
    precision = _compiled_precision(options)
    key = (what, precision, bool(options.shade))
    if key in _RENDERED:
        return ""
    _RENDERED.add(key)
    return f"{precision} {'shaded ' if options.shade else ''}{what}"


def _compiled_precision(options):
    """The precision whose kernels a render with ``options`` runs: a tolerance's is
    chosen (float64, :mod:`pv_hdrvol.raycast.tolerance`), not the option's default."""
    return "float64" if options.tolerance is not None else options.precision


def _numba_cache_dir():
    from numba.core import config

    return config.CACHE_DIR or "__pycache__ beside pv_hdrvol's source"


def _display_text(text):
    vtkOutputWindow.GetInstance().DisplayText(text + "\n")


__all__ = ["ExecutionState", "Job", "KINDS", "Kind", "distribution_of", "execute", "plan_for", "progress_of",
           "request_update_extent", "route", "shared_transfer_function", "store_input"]
