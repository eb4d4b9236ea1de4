"""The dispatch behind :func:`pv_hdrvol.render`, :func:`pv_hdrvol.view` and
:func:`pv_hdrvol.add_hdr_volume`: which renderer or viewer a kind of data goes to.

The package's face (``pv_hdrvol/__init__.py``) only re-exports these; nothing below the
front ends imports this module or the face.
"""
import os

import numpy as np

from .data.grid import GridVolume
from .outofcore.render import MultiscaleVolume, open_multiscale
from .proxy.proxies import ProxySet, load_proxies
from .raycast.grid import render_volume
from .raycast.tets import render_tets
from .rays.camera import fit_camera
from .settings import register_renderer


def render(data, tf=None, camera=None, size=(512, 512), *, scalars=None, preference="point", options=None,
           block_mask=None, cull=None, lens=None, labels=None, label_styles=None, progress_bar=None, progress=None,
           cmap=None, clim=None, opacity=None, scale=None, **option_kwargs):
    """Render a volume to an :class:`HDRImage` (see :func:`render_volume` for all options).

    ``data`` is a ``pyvista.ImageData``, ``vtkImageData``, a 3-D numpy array (z, y, x) or
    a :class:`GridVolume`, a :class:`MultiscaleVolume` (a store larger than memory,
    :func:`open_multiscale`; ``screen_error=`` and ``wait=`` as
    :meth:`~pv_hdrvol.outofcore.render.MultiscalePlan.execute`), or a tetrahedral mesh (``pyvista.UnstructuredGrid``,
    ``vtkUnstructuredGrid``, :class:`TetMesh`: see :func:`render_tets`), or a composite
    dataset of either (``pyvista.MultiBlock``, ``vtkMultiBlockDataSet``,
    ``vtkPartitionedDataSet(Collection)``: all blocks as one scene, see
    :func:`pv_hdrvol.raycast.blocks.render_blocks`); ``scalars``/``preference`` pick the
    array of a dataset, and ``labels`` may name another of its arrays.
    Without ``tf``, the transfer function is chosen from the data; ``cmap``, ``clim``,
    ``opacity`` (PyVista's meanings) and ``scale`` replace single choices of it
    (:func:`~pv_hdrvol.raycast.grid.resolve_render_options`, as in every front end). A
    view name (default ``"iso"``) frames the dataset's bounds
    (:func:`~pv_hdrvol.rays.camera.fit_camera`: the corners of its cells, also for cell
    data), as PyVista and ParaView frame it.
    ``block_mask``, ``cull``, ``lens``, ``labels`` and ``label_styles`` are for image
    volumes only.
    """
    tf_keywords = dict(cmap=cmap, clim=clim, opacity=opacity, scale=scale)
    if isinstance(data, MultiscaleVolume):
        for name, value in (("scalars", scalars), ("block_mask", block_mask), ("cull", cull), ("labels", labels),
                            ("label_styles", label_styles)):
            if value is not None:
                raise ValueError(f"{name}= is not supported for out-of-core volumes (MultiscaleVolume) yet")
        frame = {k: option_kwargs.pop(k) for k in ("screen_error", "wait", "occlusion") if k in option_kwargs}
        return data.render(tf, fit_camera(data, camera), size, options=options, lens=lens, progress_bar=progress_bar, progress=progress,
                           **frame, **tf_keywords, **option_kwargs)
    from .data.blocks import is_composite
    from .data.tets import as_tetmesh, is_unstructured
    from .raycast.grid import as_volume

    composite = is_composite(data)
    if composite or is_unstructured(data):
        for name, value in (("block_mask", block_mask), ("cull", cull), ("lens", lens), ("labels", labels),
                            ("label_styles", label_styles)):
            if value is not None:
                raise ValueError(f"{name}= is not supported for "
                                 f"{'multiblock datasets' if composite else 'tetrahedral meshes'}")
    if composite:
        from .raycast.blocks import render_blocks

        return render_blocks(data, tf, camera, size, options, scalars=scalars, preference=preference,
                             progress_bar=progress_bar, progress=progress, **tf_keywords, **option_kwargs)
    if is_unstructured(data):
        mesh = as_tetmesh(data, scalars=scalars, preference=preference)  # its checks before the framing's
        return render_tets(mesh, tf, fit_camera(data, camera), size, options, progress_bar=progress_bar,
                           progress=progress, **tf_keywords, **option_kwargs)
    volume = as_volume(data, scalars=scalars, preference=preference)
    camera = fit_camera(data, camera)
    if isinstance(labels, str):
        if isinstance(data, (GridVolume, np.ndarray)):
            raise TypeError(f"labels may name an array of a dataset only; got the name {labels!r} with a "
                            f"{type(data).__name__}")
        from .data.grid import labels_from_dataset

        labels = labels_from_dataset(data, labels, preference)
    return render_volume(volume, tf, camera, size, options, block_mask=block_mask, cull=cull, lens=lens, labels=labels,
                         label_styles=label_styles, progress_bar=progress_bar, progress=progress, **tf_keywords,
                         **option_kwargs)


def view(data, tf=None, **kwargs):
    """Explore ``data`` in the Qt viewer (:func:`pv_hdrvol.viewer.qt.view`: orbit, the
    transfer-function editor, tone mapping, probe, lens, saving). Needs Qt and pyvistaqt
    (``pip install 'pv_hdrvol[gui]'``).

    ``data`` is anything :func:`render` takes (blocks that gather onto one volume or
    merge into one mesh: :func:`pv_hdrvol.data.kinds.as_renderable`), or the path of a
    file ``pv-hdrvol view`` opens (``pv_hdrvol.data.files.READABLE``: ``.vti``,
    ``.vtr``, ``.vts``, ``.vtu``, ``.vtm``, ``.vtpc``, ``.vtk``, ``.nrrd``, ``.mha``,
    ``.cube``, ...), read as it reads them (:func:`pv_hdrvol.data.files.read_volume`;
    ``scalars=`` picks the array). ``tf`` is a :class:`TransferFunction` or, as
    ``pv-hdrvol view --tf``, the path of the editor's JSON, a transfer function's JSON or
    a ParaView preset file. The other keywords are :func:`render`'s, with its meanings:
    ``scalars=``, PyVista's ``cmap=``, ``clim=``, ``opacity=``, ``scale=`` (the editor
    starts from the function they make) and the render options.

    The path of a multiresolution store (a folder with a ``zarr.json``:
    :func:`write_multiscale`, ``pv-hdrvol convert``) opens it out of core
    (:func:`open_multiscale`): coarse levels while the camera moves, finer ones as
    chunks arrive; so does a :class:`MultiscaleVolume`.

    A :class:`ProxySet` or the path of a proxy folder opens the proxy viewer instead
    (:func:`pv_hdrvol.proxy.qt.view`: opacity per interval, turning, relighting,
    layers, enhancement; no volume needed).

    Raises
    ------
    FileNotFoundError
        ``data`` (or ``tf``) names no file or folder.
    ValueError
        The file's extension is not one of those, or the file cannot be read (the
        message names it); a folder is not a proxy folder or a store pv_hdrvol wrote.
    """
    if isinstance(data, (str, os.PathLike)):
        path = os.fspath(data)
        from .data.files import is_store

        if is_store(path):
            if kwargs.pop("scalars", None) is not None:
                raise ValueError("scalars= picks an array of a dataset; a multiresolution store holds one")
            kwargs.pop("preference", None)
            data = open_multiscale(path)  # a ValueError names what a zarr.json pv_hdrvol did not write lacks
            kwargs.setdefault("title", f"pv_hdrvol: {os.path.basename(os.path.abspath(path))}")
        elif os.path.isdir(path):
            data = load_proxies(path)  # names what a folder that is not a proxy folder lacks
            kwargs.setdefault("title", f"pv_hdrvol proxies: {path}")
        else:
            from .data.files import read_volume

            data = read_volume(path, scalars=kwargs.pop("scalars", None),
                               preference=kwargs.pop("preference", "point"))
            kwargs.setdefault("title", f"pv_hdrvol: {os.path.basename(path)}")
    if isinstance(data, ProxySet):
        if tf is not None:
            raise TypeError("a proxy set has its transfer function: tf= does not apply")
        from .proxy.qt import view as _view_proxies

        return _view_proxies(data, **kwargs)
    if isinstance(tf, (str, os.PathLike)):  # as pv-hdrvol view --tf: a ParaView preset lands on the data's range
        from .data.tets import as_tetmesh, is_unstructured
        from .editor.model import TransferFunctionModel, coarsest_values
        from .raycast.grid import as_volume

        if isinstance(data, MultiscaleVolume):
            values = coarsest_values(data)  # the range of a volume larger than memory: its coarsest level's
        else:
            convert = as_tetmesh if is_unstructured(data) else as_volume
            values = convert(data, scalars=kwargs.get("scalars"), preference=kwargs.get("preference", "point")).values
        tf = TransferFunctionModel.load(tf, values).transfer_function()
    from .viewer.qt import view as _view

    return _view(data, tf, **kwargs)


def add_hdr_volume(plotter, data, tf=None, **kwargs):
    """Draw ``data`` as an HDR volume in a PyVista plotter's scene, occluded by its meshes
    (:func:`pv_hdrvol.viewer.scene.add_hdr_volume`; also ``plotter.hdrvol.add_volume``).

    Raises
    ------
    TypeError
        ``plotter`` is not a PyVista plotter.
    """
    from .viewer.scene import add_hdr_volume as _add  # which checks the plotter

    return _add(plotter, data, tf, **kwargs)


register_renderer(render)  # RenderSettings.render replays through it

__all__ = ["render", "view", "add_hdr_volume"]
