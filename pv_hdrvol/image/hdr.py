"""HDRImage: the linear float result of a render."""
from __future__ import annotations

import io as _io
import json
import os
import pathlib

import numpy as np

from . import display as _display
from . import io as _fileio
from . import rgbe as _rgbe

#: Field-data array of :meth:`HDRImage.to_vtk` that holds the metadata as JSON.
_METADATA_ARRAY = "hdrvol_metadata"


class HDRImage:
    """A linear, premultiplied RGBA image with depth.

    Parameters
    ----------
    rgba : ndarray, shape (rows, cols, 4), float32 or float64
        Linear light, premultiplied alpha, row 0 at the top.
    depth : ndarray, shape (rows, cols), optional
        Distance along each ray to where accumulated opacity first reached the
        render's ``depth_threshold``; ``inf`` where it never did.
    metadata : dict, optional
        Render parameters; saved in EXR headers.
    value : ndarray, shape (rows, cols), float64, optional
        The scalar a projection computed per pixel (``blending="maximum"``,
        ``"minimum"``, ``"average"``: a data value; ``"additive"``: the line integral);
        NaN where the ray met no valid sample. ``None`` for emission-absorption.

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> img = hv.HDRImage(np.full((2, 3, 4), 0.25, np.float32))
    >>> img.shape, img.peak_luminance
    ((2, 3), 0.25)
    """

    def __init__(self, rgba, depth=None, metadata=None, value=None):
        rgba = np.asarray(rgba)
        if rgba.ndim != 3 or rgba.shape[2] != 4:
            raise ValueError(f"rgba must have shape (rows, cols, 4); got {rgba.shape}")
        if rgba.dtype not in (np.float32, np.float64):
            if rgba.dtype == np.float16:
                rgba = rgba.astype(np.float32)
            else:
                raise TypeError(f"rgba must be float32 or float64; got {rgba.dtype}")
        if depth is None:
            depth = np.full(rgba.shape[:2], np.inf)
        depth = np.asarray(depth, dtype=np.float64)
        if depth.shape != rgba.shape[:2]:
            raise ValueError(f"depth must have shape {rgba.shape[:2]}; got {depth.shape}")
        if value is not None:
            value = np.asarray(value, dtype=np.float64)
            if value.shape != rgba.shape[:2]:
                raise ValueError(f"value must have shape {rgba.shape[:2]}; got {value.shape}")
        self.rgba = rgba
        self.depth = depth
        self.metadata = dict(metadata or {})
        self.value = value

    # -- basic facts -------------------------------------------------------------
    @property
    def shape(self):
        """``(rows, cols)``."""
        return self.rgba.shape[:2]

    @property
    def luminance(self):
        """Linear luminance (rows, cols), float64."""
        return _display.luminance(self.rgba.astype(np.float64))

    @property
    def peak_luminance(self):
        y = self.luminance
        y = y[np.isfinite(y)]
        return float(y.max()) if y.size else 0.0

    @property
    def min_nonzero_luminance(self):
        """Smallest luminance above zero (0.0 if the image is black)."""
        y = self.luminance
        y = y[np.isfinite(y) & (y > 0)]
        return float(y.min()) if y.size else 0.0

    @property
    def dynamic_range_decades(self):
        """``log10(peak / smallest non-zero luminance)``; 0 for a black image."""
        lo = self.min_nonzero_luminance
        return float(np.log10(self.peak_luminance / lo)) if lo > 0 else 0.0

    def stats(self):
        """Dict of the statistics above, plus coverage and distinct luminance levels."""
        y = self.luminance
        return {
            "shape": self.shape,
            "dtype": str(self.rgba.dtype),
            "peak_luminance": self.peak_luminance,
            "min_nonzero_luminance": self.min_nonzero_luminance,
            "dynamic_range_decades": self.dynamic_range_decades,
            "covered_fraction": float(np.mean(self.rgba[..., 3] > 0)),
            "distinct_luminance_levels": int(np.unique(y[y > 0]).size),
            "nan_pixels": int(np.isnan(self.rgba).any(axis=2).sum()),
        }

    def __repr__(self):
        r, c = self.shape
        return (f"HDRImage({c}x{r}, {self.rgba.dtype}, peak luminance {self.peak_luminance:.4g}, "
                f"{self.dynamic_range_decades:.2f} decades, {self.metadata.get('precision', '?')} compositing)")

    def settings(self, partial=False):
        """The settings this image was rendered with, from ``metadata["settings"]``.

        Returns
        -------
        RenderSettings
            ``(tf, camera, size, options, keywords)``; ``settings.render(data)`` renders
            ``data`` with them again, bit-identical on the same data and machine
            (see :mod:`pv_hdrvol.settings`).

        Raises
        ------
        ValueError
            When the metadata hold no settings (an image from ``.npy``, or not rendered
            by pv_hdrvol), or when the render also used inputs settings do not hold
            (a lens, labels, a block mask, rays instead of a camera) or the image is
            not the size rendered (upsampled or resized after the render), unless
            ``partial=True``.
        """
        from ..settings import RenderSettings

        stored = self.metadata.get("settings")
        if not isinstance(stored, dict):
            raise ValueError("this image's metadata hold no render settings (images keep them from a pv_hdrvol "
                             "render, in .exr, .hdr and VTK files; .npy files keep no metadata)")
        not_stored = stored.get("not_stored") or []
        if not_stored and not partial:
            raise ValueError(f"the render also used {', '.join(not_stored)}, which the settings do not hold; "
                             f"settings(partial=True) returns the rest")
        settings = RenderSettings.from_dict(stored)
        rows, cols = self.shape
        if settings.size != (cols, rows) and not partial:
            raise ValueError(f"the settings are those of a {settings.size[0]}x{settings.size[1]} render; this image "
                             f"is {cols}x{rows} (changed after the render, e.g. by pv_hdrvol.upsample); "
                             f"settings(partial=True) returns them anyway")
        return settings

    # -- display -----------------------------------------------------------------
    def to_display(self, exposure_stops=None, background=(0.0, 0.0, 0.0)):
        """8-bit sRGB (rows, cols, 3) by exposure and clamp; ``None``: auto exposure."""
        return _display.display(self.rgba, exposure_stops, background=background)

    def exposures(self, stops):
        """The image at several exposures (stops relative to the auto exposure).

        Returns
        -------
        list of ndarray, each (rows, cols, 3) uint8
        """
        base = _display.auto_exposure(self.rgba)
        return [self.to_display(base + float(s)) for s in np.atleast_1d(stops)]

    def tonemap(self, operator="reinhard", **kwargs):
        """Tone map for display: :func:`pv_hdrvol.tonemap` on this image (returns a ``ToneMapped``)."""
        from .tonemap import tonemap

        return tonemap(self, operator, **kwargs)

    def save_png(self, path, exposure_stops=None):
        """Write the default display mapping as an 8-bit PNG."""
        _fileio.write_png(path, self.to_display(exposure_stops))

    def _repr_png_(self):
        buf = _io.BytesIO()
        _fileio.write_png(buf, self.to_display())
        return buf.getvalue()

    # -- files -------------------------------------------------------------------
    def save(self, path, pixel_type="float32"):
        """Save to a file whose suffix picks the format.

        - ``.exr``: OpenEXR, RGBA + Z (+ V: :attr:`value`, float32), metadata in the header. ``pixel_type="float16"``
          writes half RGBA (about 4.8e-4 relative error, saturating at 65504); depth is
          always float32. float32 round-trips bit-exact.
        - ``.hdr``: Radiance RGBE (run-length encoded), metadata in a ``PV_HDRVOL``
          header line. Only the premultiplied RGB is stored, i.e. the image composited
          over black, with 8-bit mantissas (within ``2**-8`` of each pixel's largest
          component); alpha and depth are not representable and are dropped.
          ``pixel_type`` is ignored. See :func:`pv_hdrvol.image.rgbe.write_hdr`.
        - ``.npy``: RGBA and depth, bit-exact, no metadata.
        - ``.png``: the default 8-bit display mapping (:meth:`save_png`).

        Raises
        ------
        ValueError
            For an unknown extension or ``pixel_type``.
        OSError
            Naming the file or folder: ``FileNotFoundError`` when the folder does not
            exist, ``IsADirectoryError``, ``PermissionError`` (see
            :func:`pv_hdrvol.image.io.check_writable`).
        """
        path = pathlib.Path(os.fspath(path))
        ext = path.suffix.lower()
        if ext not in (".exr", ".hdr", ".npy", ".png"):
            raise ValueError(f"unknown image extension {ext!r}; use .exr, .hdr, .npy or .png")
        _fileio.check_writable(path)
        if ext == ".exr":
            _fileio.write_exr(path, self.rgba, self.depth, self.metadata, pixel_type, self.value)
        elif ext == ".hdr":
            # as for EXR, values JSON cannot hold (numpy scalars...) are saved as strings
            metadata = json.loads(json.dumps(self.metadata, default=str))
            _rgbe.write_hdr(path, self.rgba[..., :3], metadata)
        elif ext == ".npy":
            _fileio.write_npy(path, self.rgba, self.depth)
        else:
            self.save_png(path)
        return path

    @classmethod
    def load(cls, path):
        """Read an image written by :meth:`save`, an RGB(A) OpenEXR or a Radiance RGBE file.

        ``.exr`` and ``.npy`` give back what was saved. ``.hdr`` gives an opaque
        picture: RGB as stored (``EXPOSURE`` not applied), alpha 1.0 everywhere, depth
        ``inf``, metadata from the ``PV_HDRVOL`` header line.

        Raises
        ------
        FileNotFoundError, IsADirectoryError, PermissionError
            As ``open(path)`` does, naming the path.
        ValueError
            For an unknown extension, or a file that is not a readable image of its
            extension's format (another format, truncated, corrupt), naming the path.
        """
        path = pathlib.Path(os.fspath(path))
        ext = path.suffix.lower()
        if ext == ".exr":
            rgba, depth, meta, value = _fileio.read_exr(path)
            return cls(rgba, depth, meta, value)
        if ext == ".hdr":
            rgb, header = _rgbe.read_hdr(path)
            rgba = np.concatenate([rgb, np.ones(rgb.shape[:2] + (1,), np.float32)], axis=2)
            return cls(rgba, None, header["metadata"])
        if ext == ".npy":
            rgba, depth = _fileio.read_npy(path)
            return cls(rgba, depth)
        raise ValueError(f"unknown image extension {ext!r}; use .exr, .hdr or .npy")

    # -- VTK / PyVista -----------------------------------------------------------
    def to_vtk(self):
        """A 2-D ``vtkImageData`` with point arrays ``rgba`` (4 comp.), ``depth`` (and ``value``).

        VTK's row 0 is the bottom: rows are flipped here. The metadata travels as JSON
        in the field-data string array ``"hdrvol_metadata"``.
        """
        from vtkmodules.util.numpy_support import numpy_to_vtk
        from vtkmodules.vtkCommonDataModel import vtkImageData

        rows, cols = self.shape
        img = vtkImageData()
        img.SetDimensions(cols, rows, 1)
        rgba = np.ascontiguousarray(self.rgba[::-1].reshape(-1, 4))
        arr = numpy_to_vtk(rgba, deep=True)
        arr.SetName("rgba")
        img.GetPointData().AddArray(arr)
        img.GetPointData().SetActiveScalars("rgba")
        dep = numpy_to_vtk(np.ascontiguousarray(self.depth[::-1].reshape(-1)), deep=True)
        dep.SetName("depth")
        img.GetPointData().AddArray(dep)
        if self.value is not None:
            val = numpy_to_vtk(np.ascontiguousarray(self.value[::-1].reshape(-1)), deep=True)
            val.SetName("value")
            img.GetPointData().AddArray(val)
        if self.metadata:
            from vtkmodules.vtkCommonCore import vtkStringArray

            meta = vtkStringArray()
            meta.SetName(_METADATA_ARRAY)
            meta.InsertNextValue(json.dumps(self.metadata, default=str))
            img.GetFieldData().AddArray(meta)
        return img

    def to_pyvista(self):
        """As :meth:`to_vtk`, wrapped as ``pyvista.ImageData``."""
        import pyvista as pv

        return pv.wrap(self.to_vtk())

    @classmethod
    def from_pyvista(cls, image, rgba="rgba", depth="depth"):
        """Inverse of :meth:`to_pyvista` / :meth:`to_vtk` (rows flipped back)."""
        from vtkmodules.util.numpy_support import vtk_to_numpy

        dims = image.GetDimensions()
        if dims[2] != 1:
            raise ValueError(f"expected a 2-D image (z dimension 1); got dimensions {dims}")
        cols, rows = dims[0], dims[1]
        pd = image.GetPointData()
        arr = pd.GetArray(rgba)
        if arr is None or arr.GetNumberOfComponents() != 4:
            raise ValueError(f"the image has no 4-component point array {rgba!r}")
        data = vtk_to_numpy(arr).reshape(rows, cols, 4)[::-1]
        d = pd.GetArray(depth)
        dep = vtk_to_numpy(d).reshape(rows, cols)[::-1] if d is not None else None
        meta = image.GetFieldData().GetAbstractArray(_METADATA_ARRAY)
        metadata = json.loads(meta.GetValue(0)) if meta is not None and meta.GetNumberOfValues() else None
        v = pd.GetArray("value")
        val = np.array(vtk_to_numpy(v).reshape(rows, cols)[::-1]) if v is not None else None
        return cls(np.array(data), None if dep is None else np.array(dep), metadata, val)


def load(path):
    """Read an :class:`HDRImage` from ``.exr``, ``.hdr`` or ``.npy`` (see :meth:`HDRImage.load`)."""
    return HDRImage.load(path)
