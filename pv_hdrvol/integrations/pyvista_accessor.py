"""``dataset.hdrvol``: PyVista accessor for HDR volume rendering.

Registered on ``pyvista.DataObject`` (every dataset and ``pyvista.MultiBlock``) when this
module is imported; PyVista imports it on
first use of ``dataset.hdrvol`` through the ``pyvista.accessors`` entry point, so
``import pv_hdrvol`` is not needed.
"""
from __future__ import annotations

import pyvista as pv

from ..data.kinds import BLOCKS, GRID, MESH, data_kind
from ..rays.camera import fit_camera
from . import VolumeCache


@pv.register_dataset_accessor("hdrvol", pv.DataObject)
class HDRVolAccessor:
    """High-dynamic-range volume rendering of PyVista's volumetric datasets.

    Available as ``dataset.hdrvol`` on every PyVista dataset and ``MultiBlock``;
    ``ImageData``, ``RectilinearGrid``, ``StructuredGrid`` (curvilinear: each hexahedron
    split into five tetrahedra), ``UnstructuredGrid`` (tetrahedra; other 3-D cells are
    split) and ``MultiBlock`` / partitioned datasets of those can be rendered
    (:mod:`pv_hdrvol.data.kinds`).

    Examples
    --------
    >>> import pyvista as pv, numpy as np
    >>> grid = pv.ImageData(dimensions=(8, 8, 8))
    >>> grid["density"] = np.geomspace(1e-6, 1.0, grid.n_points)
    >>> grid.hdrvol.render(size=(16, 12)).shape
    (12, 16)
    """

    def __init__(self, dataset):
        self._dataset = dataset
        self._volumes = VolumeCache()

    def _check_renderable(self):
        """The dataset's kind (:func:`~pv_hdrvol.data.kinds.data_kind`), or the
        ``TypeError`` that names what is rendered."""
        return data_kind(self._dataset)

    def render(self, scalars=None, tf=None, camera=None, size=(512, 512), preference="point", lens=None,
               labels=None, label_styles=None, progress_bar=None, progress=None, *, cmap=None, clim=None,
               opacity=None, scale=None, cull=None, **options):
        """Ray cast the dataset into a linear float :class:`~pv_hdrvol.HDRImage`.

        The dataset is not modified.

        Parameters
        ----------
        scalars : str, optional
            Point or cell array to render; default: the active scalars, else the
            only array.
        tf : TransferFunction, optional
            Default: chosen from the data (:func:`~pv_hdrvol.raycast.grid.default_transfer_function`:
            the background transparent, a log axis where the data span decades).
        cmap, clim, opacity, scale : optional
            PyVista's ``add_volume`` keywords, with its meanings, in place of ``tf``:
            each replaces one choice of the default. A colormap name; the range the
            colormap and opacity span (a number ``c`` means ``(-c, c)``; an end
            ``None`` stays the default's); an opacity: a name of
            ``pyvista.opacity_transfer_function`` (``"linear"``, ``"sigmoid"``,
            ``"geom_r"``, ...), one number, or opacities spread over ``clim``,
            reached over one ``opacity_unit_distance``; and the axis (``"linear"``,
            ``"log"``, ``"symlog"``). What is not given stays the default's (PyVista
            would take the data range and the ``"linear"`` opacity); ``hv.render``,
            ``plotter.hdrvol.add_volume``, ``hv.view``, ``HDRVolumeRenderer`` and the
            CLI take the same (:func:`~pv_hdrvol.raycast.grid.resolve_render_options`).
            Giving ``tf`` too is a ``TypeError``.
        camera : None, str, Camera, pyvista.Plotter, pyvista.Camera or vtkCamera
            A view name (``"iso"`` (default), ``"xy"``, ``"xz"``, ``"yz"``, ``"yx"``,
            ``"zx"``, ``"zy"``) frames the dataset's bounds
            (:func:`~pv_hdrvol.rays.camera.fit_camera`, as ``hv.render`` does); a
            Plotter or camera renders what that window shows.
        size : int or (width, height)
            Pixels.
        preference : {"point", "cell"}
            Association used when ``scalars`` names both a point and a cell array.
        lens : Lens, optional
            A ray generator (:class:`~pv_hdrvol.Magnifier`, :class:`~pv_hdrvol.FeatureLens`,
            :class:`~pv_hdrvol.SamplingRateLens`, :class:`~pv_hdrvol.Fisheye`) applied
            to the camera.
        labels : str or ndarray, optional
            A label array of the dataset (by name) or a (z, y, x) integer array:
            two-level rendering, styled per label by ``label_styles`` (see
            :func:`~pv_hdrvol.render_volume`).
        label_styles : dict, optional
            ``{label: TransferFunction | blending | (tf, blending)}``.
        progress_bar : bool or None
            ``None`` (default): a tqdm bar for a render that will take over 1 s, on a
            terminal or in a notebook only; ``True``: always; ``False``: never. Slow
            renders run in short chunks either way, so Ctrl-C stops them.
        progress : callable, optional
            ``progress(fraction)``; returning ``False`` aborts with ``RuntimeError``.
        cull : PlenopticOpacity or Culling, optional
            Image data only: skip blocks hidden behind opaque ones
            (:func:`~pv_hdrvol.render_volume`); ``img.metadata["culling"]`` has the counts.
        **options
            :class:`~pv_hdrvol.RenderOptions` fields: ``step``, ``precision``,
            ``global_alpha``, ``opacity_unit_distance``, ``termination``,
            ``depth_threshold``, ``block_size``, ``skip_empty``, ``blending``
            (PyVista's names: ``"composite"``, ``"maximum"``, ``"minimum"``,
            ``"average"``, ``"additive"``), ``gradient_opacity``, ``shade`` and its
            weights, and ``tolerance``: the accuracy you accept instead of the
            knobs, the RMS error of the linear, premultiplied RGB image against the
            converged render relative to its peak, in ``(0, 0.5]``
            (``grid.hdrvol.render(tolerance=1e-3)``). The renderer then chooses
            ``step``, ``termination``, the table size and ``precision`` (which must
            stay at their defaults: a ``ValueError`` otherwise) and puts them and its
            estimated error in ``img.metadata["tolerance"]``; the pixels are those of
            ``hv.render(..., tolerance=)``.

        Returns
        -------
        HDRImage
            ``(rows, cols, 4)`` linear premultiplied RGBA, row 0 at the top, and depth.

        Raises
        ------
        TypeError
            For datasets that are not volumes (``PolyData``, ...), unknown options
            or an unusable camera.
        ScalarsError
            (a ``ValueError``) when ``scalars`` is missing or ambiguous.
        """
        from ..raycast.grid import render_volume

        kind = self._check_renderable()
        if kind != GRID:
            for name, value in (("lens", lens), ("labels", labels), ("label_styles", label_styles), ("cull", cull)):
                if value is not None:
                    raise ValueError(f"{name}= is not supported for {_WHAT[kind]}")
        tf_keywords = dict(cmap=cmap, clim=clim, opacity=opacity, scale=scale)
        if kind == BLOCKS:
            from ..raycast.blocks import render_blocks

            return render_blocks(self._dataset, tf, camera, size, scalars=scalars, preference=preference,
                                 progress_bar=progress_bar, progress=progress, **tf_keywords, **options)
        if kind == MESH:
            from ..data.tets import check_has_cells
            from ..raycast.tets import render_tets

            check_has_cells(self._dataset)  # before its (unset) bounds frame a camera
            mesh = self._volumes.get(self._dataset, scalars, preference)
            cam = fit_camera(self._dataset, camera)
            return render_tets(mesh, tf, cam, size, progress_bar=progress_bar, progress=progress, **tf_keywords,
                               **options)
        volume = self._volumes.get(self._dataset, scalars, preference)
        cam = fit_camera(self._dataset, camera)  # the dataset's bounds: a volume of cell data spans its centres
        if isinstance(labels, str):
            from ..data.grid import labels_from_dataset

            labels = labels_from_dataset(self._dataset, labels, preference)
        return render_volume(volume, tf, cam, size, lens=lens, labels=labels, label_styles=label_styles, cull=cull,
                             progress_bar=progress_bar, progress=progress, **tf_keywords, **options)

    def make_proxies(self, camera=None, size=(512, 512), tf=None, scalars=None, preference="point", **options):
        """Proxy images of this ``ImageData`` for exploring it later without it (views,
        opacity changes, lighting): :func:`~pv_hdrvol.make_proxies`, whose keywords
        (``intervals``, ``layers``, ``multi_perspective``, ``training``, ``clusters``,
        ``step``, ...) it takes. ``camera``: a parallel-projection
        :class:`~pv_hdrvol.Camera` or a view name (default ``"iso"``).

        Returns
        -------
        ProxySet
            ``.save(folder)``, ``.synthesize(...)``.
        """
        from ..proxy.generate import make_proxies

        if self._check_renderable() != GRID or self._dataset.GetClassName() == "vtkRectilinearGrid":
            raise TypeError(f"proxies are made of image data (ImageData); got a {type(self._dataset).__name__}: "
                            f"resample it onto one first (pyvista.ImageData(...).sample(dataset))")
        volume = self._volumes.get(self._dataset, scalars, preference)
        return make_proxies(volume, camera, size, tf, **options)

    def __repr__(self):
        ds = self._dataset
        kind = type(ds).__name__
        try:
            what = self._check_renderable()
        except TypeError:
            return f"<hdrvol accessor of {kind}: not renderable (not a volume: see pv_hdrvol.data.kinds)>"
        if what == BLOCKS:
            return (f"<hdrvol accessor of {kind} with {ds.n_blocks} blocks; call .render(scalars=, tf=, camera=, "
                    f"size=, **options)>")
        arrays = [f"point {n!r}" for n in ds.point_data.keys()] + [f"cell {n!r}" for n in ds.cell_data.keys()]
        active = ds.active_scalars_name
        shape = f"{ds.n_cells} cells" if ds.GetClassName() == "vtkUnstructuredGrid" else str(tuple(ds.dimensions))
        return (f"<hdrvol accessor of {kind} {shape}; arrays: {', '.join(arrays) or 'none'}; "
                f"active scalars: {active!r}; call .render(scalars=, tf=, camera=, size=, **options)>")


#: What the options that apply to image data only name, per kind.
_WHAT = {MESH: "tetrahedral meshes and curvilinear grids", BLOCKS: "multiblock datasets"}

__all__ = ["HDRVolAccessor"]
