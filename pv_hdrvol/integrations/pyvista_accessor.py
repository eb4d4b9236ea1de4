"""``dataset.hdrvol``: PyVista accessor for HDR volume rendering.

Registered on ``pyvista.DataSet`` when this module is imported; PyVista imports it on
first use of ``dataset.hdrvol`` through the ``pyvista.accessors`` entry point, so
``import pv_hdrvol`` is not needed.
"""
from __future__ import annotations

import pyvista as pv

from ..rays.camera import as_camera
from . import VolumeCache

_IMAGE_CLASSES = ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid")


@pv.register_dataset_accessor("hdrvol", pv.DataSet)
class HDRVolAccessor:
    """High-dynamic-range volume rendering of ``pyvista.ImageData`` and tetrahedral
    ``pyvista.UnstructuredGrid``.

    Available as ``dataset.hdrvol`` on every PyVista dataset; image data and
    unstructured grids (tetrahedra; other 3-D cells are split) can be rendered.

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
        ds = self._dataset
        name = ds.GetClassName()
        if name in _IMAGE_CLASSES or name == "vtkUnstructuredGrid":
            return
        kind = type(ds).__name__
        raise TypeError(f"hdrvol renders pyvista.ImageData and UnstructuredGrid; got {kind} "
                        "(cast it, e.g. dataset.cast_to_unstructured_grid(), or resample it onto an ImageData "
                        "with dataset.sample())")

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
            ``HDRVolumeRenderer`` and the CLI take the same. Giving ``tf`` too is a
            ``TypeError``.
        camera : None, str, Camera, pyvista.Plotter, pyvista.Camera or vtkCamera
            A view name (``"iso"`` (default), ``"xy"``, ``"xz"``, ``"yz"``, ``"yx"``,
            ``"zx"``, ``"zy"``) frames the dataset; a Plotter or camera renders what
            that window shows.
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
            For datasets other than ImageData and UnstructuredGrid, unknown options
            or an unusable camera.
        ScalarsError
            (a ``ValueError``) when ``scalars`` is missing or ambiguous.
        """
        from ..raycast.grid import render_volume

        self._check_renderable()
        if self._dataset.GetClassName() == "vtkUnstructuredGrid":
            from ..data.tets import check_has_cells

            check_has_cells(self._dataset)  # before its (unset) bounds frame a camera
        cam = as_camera(camera, self._dataset.bounds)
        if self._dataset.GetClassName() == "vtkUnstructuredGrid":
            from ..raycast.tets import render_tets

            for name, value in (("lens", lens), ("labels", labels), ("label_styles", label_styles), ("cull", cull)):
                if value is not None:
                    raise ValueError(f"{name}= is not supported for tetrahedral meshes")
            return render_tets(self._dataset, tf, cam, size, scalars=scalars, preference=preference,
                               progress_bar=progress_bar, progress=progress, cmap=cmap, clim=clim, opacity=opacity,
                               scale=scale, **options)
        volume = self._volumes.get(self._dataset, scalars, preference)
        if isinstance(labels, str):
            from ..data.grid import labels_from_dataset

            labels = labels_from_dataset(self._dataset, labels, preference)
        return render_volume(volume, tf, cam, size, lens=lens, labels=labels, label_styles=label_styles, cull=cull,
                             progress_bar=progress_bar, progress=progress, cmap=cmap, clim=clim, opacity=opacity,
                             scale=scale, **options)

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

        self._check_renderable()
        if self._dataset.GetClassName() == "vtkUnstructuredGrid":
            raise TypeError("proxies are made of image data (ImageData); resample a mesh onto one first "
                            "(pyvista.ImageData(...).sample(mesh))")
        volume = self._volumes.get(self._dataset, scalars, preference)
        return make_proxies(volume, camera, size, tf, **options)

    def __repr__(self):
        ds = self._dataset
        kind = type(ds).__name__
        try:
            self._check_renderable()
        except TypeError:
            return f"<hdrvol accessor of {kind}: not renderable (ImageData and UnstructuredGrid only)>"
        arrays = [f"point {n!r}" for n in ds.point_data.keys()] + [f"cell {n!r}" for n in ds.cell_data.keys()]
        active = ds.active_scalars_name
        shape = f"{ds.n_cells} cells" if ds.GetClassName() == "vtkUnstructuredGrid" else str(tuple(ds.dimensions))
        return (f"<hdrvol accessor of {kind} {shape}; arrays: {', '.join(arrays) or 'none'}; "
                f"active scalars: {active!r}; call .render(scalars=, tf=, camera=, size=, **options)>")


__all__ = ["HDRVolAccessor"]
