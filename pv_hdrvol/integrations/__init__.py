"""Thin adapters from other tools to the pv_hdrvol pipeline; no numerics here.

- :mod:`~pv_hdrvol.integrations.pyvista_accessor`: ``dataset.hdrvol.render(...)``,
  found by PyVista through the ``pyvista.accessors`` entry point.
- :mod:`~pv_hdrvol.integrations.vtk_algorithm`: ``HDRVolumeRenderer``, a VTK
  algorithm (vtkImageData in, 2-D float RGBA vtkImageData out).
- :mod:`~pv_hdrvol.integrations.cli`: the ``pv-hdrvol`` command.

Submodules are imported on demand: importing this package loads neither PyVista nor VTK.
"""
from __future__ import annotations

#: Lookup-table entries of PyVista's ``add_volume`` (its ``n_colors`` default): the
#: control points a transfer function made from ``cmap=``/``clim=``/``opacity=`` has.
PYVISTA_N_COLORS = 256
#: Colormap when only ``clim=`` or ``opacity=`` is given: pv_hdrvol's default.
DEFAULT_CMAP = "magma"


def resolve_transfer_function(tf, value_range, cmap=None, clim=None, opacity=None):
    """``tf``, or a :class:`~pv_hdrvol.TransferFunction` made from PyVista's
    ``add_volume`` keywords, with PyVista's meanings.

    Parameters
    ----------
    tf : TransferFunction or None
        Given, it is returned; it may not be combined with the keywords below.
    value_range : (float, float) or callable
        The data range (or a function returning it, called only when needed), the
        default of ``clim``.
    cmap : str or matplotlib colormap, optional
        Colormap name; default ``"magma"`` (pv_hdrvol's default).
    clim : (float, float) or float, optional
        Value range the colormap and opacity span; a number ``c`` means ``(-c, c)``,
        as in PyVista. Default: the data range.
    opacity : str, float or sequence of float, optional
        A name of ``pyvista.opacity_transfer_function`` (``"linear"`` (default),
        ``"linear_r"``, ``"geom"``, ``"geom_r"``, ``"sigmoid"``, ``"sigmoid_r"``,
        ``"sigmoid_3"`` ... ``"sigmoid_10"`` and their ``_r``, ``"sigmoid_1"``,
        ``"sigmoid_2"``, ``"sigmoid_15"``, ``"sigmoid_20"``, ``"foreground"``), sampled
        as PyVista samples it (``opacity_transfer_function(name, 256) / 255``); one
        opacity in [0, 1] for every value; or opacities in [0, 1] spread evenly over
        ``clim`` and interpolated linearly.

    Returns
    -------
    TransferFunction or None
        ``None`` when neither ``tf`` nor a keyword is given (the renderer's default).
        Otherwise 256 control points evenly spaced over ``clim`` on a linear axis, as
        PyVista's lookup table has 256 entries; PyVista's opacity is reached over one
        ``opacity_unit_distance``.
    """
    import numpy as np

    from ..data.transfer import TransferFunction, colormap_rgb

    given = [name for name, value in (("cmap", cmap), ("clim", clim), ("opacity", opacity)) if value is not None]
    if not given:
        return tf
    if tf is not None:
        raise TypeError(f"pass either tf= or PyVista's {', '.join(n + '=' for n in given)}, not both: a "
                        "TransferFunction sets colour, opacity and range already")
    n = PYVISTA_N_COLORS
    lo, hi = _clim(clim, value_range)
    opacities = _opacity_curve("linear" if opacity is None else opacity, n)
    colors = colormap_rgb(DEFAULT_CMAP if cmap is None else cmap, np.linspace(0.0, 1.0, n))
    values = np.linspace(lo, hi, n)
    return TransferFunction(values, colors, opacities)


def _clim(clim, value_range):
    """``(low, high)`` of ``clim=`` (PyVista's meaning), or of the data range."""
    import numpy as np

    if clim is None:
        lo, hi = value_range() if callable(value_range) else value_range
        return (float(lo), float(hi) if hi > lo else float(lo) + 1.0)  # constant data: as the default tf
    if isinstance(clim, (int, float, np.integer, np.floating)) and not isinstance(clim, (bool, np.bool_)):
        clim = (-clim, clim)
    if isinstance(clim, (str, bytes)) or not hasattr(clim, "__len__") or len(clim) != 2:
        raise TypeError(f"clim must be (low, high) or a number c meaning (-c, c); got {clim!r}")
    try:
        lo, hi = float(clim[0]), float(clim[1])
    except (TypeError, ValueError):
        raise TypeError(f"clim must be (low, high) or a number c meaning (-c, c); got {clim!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ValueError(f"clim must be finite with high > low; got {clim!r}")
    return lo, hi


def _opacity_curve(opacity, n):
    """``n`` opacities in [0, 1] from ``opacity=`` (see :func:`resolve_transfer_function`)."""
    import numpy as np

    if isinstance(opacity, str):
        try:
            from pyvista import opacity_transfer_function
        except ImportError:
            raise ValueError(f"opacity={opacity!r} names a PyVista opacity transfer function, which needs "
                             "pyvista; pass opacities instead") from None
        try:
            curve = opacity_transfer_function(opacity, n)
        except ValueError as err:
            raise ValueError(f"opacity={opacity!r} is not a PyVista opacity transfer function: {err}") from None
        return np.asarray(curve, dtype=np.float64) / 255.0
    if isinstance(opacity, (bool, np.bool_)):
        raise TypeError(f"opacity must be a PyVista opacity name, a number or a sequence of numbers; got {opacity!r}")
    try:
        values = np.array(opacity, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"opacity must be a PyVista opacity name, a number or a sequence of numbers; "
                        f"got {opacity!r}") from None
    if values.ndim > 1 or (values.ndim == 1 and values.size < 2):
        raise ValueError(f"opacity must be one number or a 1-D sequence of at least 2; got shape {values.shape}")
    if not np.all(np.isfinite(values)) or values.min() < 0 or values.max() > 1:
        raise ValueError(f"opacity values must lie in [0, 1]; got {opacity!r}")
    if values.ndim == 0:
        return np.full(n, float(values))
    return np.interp(np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, values.size), values)


class VolumeCache:
    """The :class:`~pv_hdrvol.GridVolume` of a dataset, kept while the dataset is unchanged.

    A GridVolume carries what the first render builds (bricks, block ranges), so a
    second render of the same data (another transfer function, camera or size) skips
    that work. The key is the array choice and the dataset's VTK modification time,
    which covers its arrays: after changing values in place through numpy, call
    ``dataset.Modified()``, as VTK pipelines require too.
    """

    def __init__(self):
        self._key = None
        self._volume = None

    def get(self, dataset, scalars, preference):
        from ..data.grid import volume_from_dataset

        key = (scalars, preference, dataset.GetMTime())
        if key != self._key:
            self._volume, self._key = volume_from_dataset(dataset, scalars=scalars, preference=preference), key
        return self._volume


__all__ = ["VolumeCache", "resolve_transfer_function"]
