"""Upsampling of low-resolution renders guided by full-resolution depth layers.

Callahan & Silva, "Accelerating unstructured volume rendering with joint bilateral
upsampling" (JGT 2009): render small, then upsample with a joint bilateral filter
whose range term compares a full-resolution reference (:func:`~pv_hdrvol.depth_layers`:
the mesh boundary peeled front to back, as the paper, or the length of each ray inside
the mesh, this package's default), so edges of the mesh stay sharp while its interior
is interpolated smoothly.
"""
from __future__ import annotations

import math

import numpy as np

from .._validate import as_choice, as_real
from . import _upsample_kernels as K
from .hdr import HDRImage

METHODS = ("joint_bilateral", "bilinear", "nearest")
GUIDES = ("thickness", "layers")
SPATIAL = ("bilinear", "gaussian")
_EXP_TABLE = K.exp_table()


class DepthLayers:
    """Per pixel, the first ``k`` depths (world distance along the ray; ``inf`` where a
    pixel has fewer) and, for a mesh, the length of the ray inside it.

    Attributes
    ----------
    depth : ndarray (k, rows, cols) float64
    counts : ndarray (rows, cols) int
        How many layers each pixel has in all (may exceed ``k``).
    thickness : ndarray (rows, cols) float64 or None
        Meshes: the world length of each pixel's ray inside the mesh, from all its
        boundary crossings (exits minus entries), not only the ``k`` kept; 0 where
        the ray misses. ``None`` for the reference depth of an image volume.
    seconds : float
        Time taken to compute them.
    """

    def __init__(self, depth, counts, seconds=0.0, source="", thickness=None):
        self.depth = depth
        self.counts = counts
        self.thickness = thickness
        self.seconds = seconds
        self.source = source

    @property
    def n_layers(self):
        return int(self.depth.shape[0])

    @property
    def shape(self):
        return self.depth.shape[1:]

    @property
    def layers_needed(self):
        """The most layers any pixel has: peeling more finds nothing new."""
        return int(self.counts.max()) if self.counts.size else 0

    def normalized(self, missing=2.0, layer_first=False):
        """The layers as a float64 guide: depths scaled to [0, 1] over the finite range,
        ``missing`` (default 2, far from every surface) where a pixel has no such layer;
        (rows, cols, k), or (k, rows, cols) with ``layer_first``."""
        from ._upsample_kernels import normalize_depths

        d = np.ascontiguousarray(self.depth, dtype=np.float64)
        out = np.empty(d.shape)
        normalize_depths(d.reshape(-1), float(missing), out.reshape(-1))
        return out if layer_first else np.ascontiguousarray(np.moveaxis(out, 0, -1))

    def normalized_thickness(self):
        """:attr:`thickness` divided by its largest value (all zeros stay zeros), float64
        (rows, cols): the guide of ``upsample(guide="thickness")``."""
        if self.thickness is None:
            raise ValueError(f"these layers have no thickness (they are the {self.source}); only a mesh's "
                             "boundary layers do")
        top = float(self.thickness.max()) if self.thickness.size else 0.0
        return self.thickness / top if top > 0.0 else np.array(self.thickness, dtype=np.float64)

    def __repr__(self):
        rows, cols = self.shape
        return (f"DepthLayers({cols}x{rows}, {self.n_layers} layers kept, {self.layers_needed} needed, "
                f"{self.seconds * 1e3:.1f} ms, {self.source})")


def _inverse_two_squares(sigma):
    """``1 / (2 sigma^2)``, capped at 1e300 so that a tiny sigma (whose square underflows)
    still weighs equal guides fully and any difference as nothing (never ``0 * inf``)."""
    return min(0.5 / (sigma * sigma), 1e300) if sigma * sigma > 0.0 else 1e300


def upsample(image, layers=None, factor=None, *, method="joint_bilateral", guide=None, spatial=None, support=None,
             sigma_range=None):
    """Upsample a low-resolution :class:`HDRImage` (or array) to the layers' resolution.

    Parameters
    ----------
    image : HDRImage or ndarray (h, w, c)
        Linear premultiplied RGBA (any channels are filtered alike).
    layers : DepthLayers or ndarray (H, W, k), optional
        The full-resolution reference (:func:`~pv_hdrvol.depth_layers`), or a guide
        given as an array (its values are compared as they are). Required for
        ``"joint_bilateral"``.
    factor : float, optional
        Full-resolution pixels per low-resolution pixel; default ``H / h`` from the
        layers. ``1`` with layers of the image's own size is the denoising use (the
        paper's Fig. 5).
    method : {"joint_bilateral", "bilinear", "nearest"}
    guide : {"thickness", "layers"}, optional
        What the range term compares, for :class:`DepthLayers`:

        - ``"thickness"``: the length of the pixel's ray inside the mesh
          (:attr:`DepthLayers.thickness`), scaled to [0, 1] by its largest value.
          The default where the layers have it (a mesh's boundary).
        - ``"layers"``: the vector of normalised depth layers, the paper's guide
          (missing layers count as 2, far from every surface). The default for the
          reference depth of an image volume.

        A volume rendering with a transparent transfer function varies with how much
        of the mesh a ray crosses, which the thickness measures: it goes to 0
        continuously where a silhouette fades out, and jumps where the ray enters or
        leaves a part of the mesh. The depth layers jump at every silhouette, also
        where the picture does not.
    spatial : {"bilinear", "gaussian"}, optional
        The spatial weights. ``"bilinear"``: the four low-resolution pixels around the
        output pixel with their bilinear weights, so a flat guide gives bilinear
        interpolation (to rounding; the default with ``guide="thickness"``). ``"gaussian"``: the
        paper's Gaussian of support ``support`` (the default otherwise).
        ``guide="layers", spatial="gaussian"`` is Callahan & Silva's filter as
        published; docs/tetrahedra.md measures both against bilinear interpolation.
    support : float, optional
        ``spatial="gaussian"``: the support Omega in full-resolution pixels; the
        Gaussian has sigma = Omega / 2. Default: ``factor`` (one low-resolution pixel),
        at least 2.
    sigma_range : float, optional
        Sigma of the range Gaussian on the distance between guide values, in the
        guide's units: default 0.2 (of the largest thickness) for ``"thickness"``,
        0.01 (of the depth range, as the paper) for ``"layers"`` and for array guides.

    Returns
    -------
    HDRImage or ndarray
        At the guide's size, in the input's float type: an HDRImage for an HDRImage
        (depth upsampled by nearest neighbour, metadata noting the method and guide),
        else an array.

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> low = np.arange(4.0).reshape(2, 2, 1)
    >>> hv.upsample(low, factor=2, method="bilinear")[..., 0]
    array([[0.  , 0.25, 0.75, 1.  ],
           [0.5 , 0.75, 1.25, 1.5 ],
           [1.5 , 1.75, 2.25, 2.5 ],
           [2.  , 2.25, 2.75, 3.  ]])
    """
    as_choice("method", method, METHODS)
    if guide is not None:
        as_choice("guide", guide, GUIDES)
    if spatial is not None:
        as_choice("spatial", spatial, SPATIAL)
    low, low_depth, src_meta = _low_resolution(image)
    h, w = low.shape[:2]
    ref, used, guide_scale = _range_guide(layers, guide, method)
    factor, H, W = _output_size(ref, h, w, factor)
    work = np.ascontiguousarray(low, dtype=np.float64)
    if method == "nearest":
        out = np.empty((H, W, low.shape[2]))
        K.nearest(work, factor, out)
    elif method == "bilinear":
        out = np.empty((H, W, low.shape[2]))
        K.bilinear(work, factor, out)
    else:
        if spatial is None:
            spatial = "bilinear" if used == "thickness" else "gaussian"
        if sigma_range is None:
            sigma_range = 0.2 if used == "thickness" else 0.01
        sigma_range = as_real("sigma_range", sigma_range, low=0.0, low_open=True)
        out = _joint_bilateral(work, low.dtype, ref, factor, (H, W), spatial, support,
                               _inverse_two_squares(sigma_range * guide_scale))
    out = out.astype(low.dtype, copy=False)
    depth = None if low_depth is None else _nearest_depth(low_depth, factor, (h, w), (H, W))
    if not isinstance(image, HDRImage):
        return out
    meta = dict(src_meta)
    meta["upsampled"] = {"method": method, "factor": factor, "from": [w, h]}
    if method == "joint_bilateral":
        meta["upsampled"].update(guide=used, spatial=spatial, sigma_range=sigma_range)
    return HDRImage(out, depth, metadata=meta)


def _low_resolution(image):
    """The low-resolution picture of :func:`upsample`'s ``image``, checked: its colours
    (rows, cols, channels), its depth (or None) and its metadata."""
    src_meta = {}
    if isinstance(image, HDRImage):
        low = image.rgba
        low_depth = image.depth
        src_meta = dict(image.metadata)
    else:
        low = np.asarray(image)
        low_depth = None
        if low.ndim != 3:
            raise ValueError(f"image must be an HDRImage or an array (rows, cols, channels); got shape {low.shape}")
    if not np.issubdtype(low.dtype, np.floating):
        raise TypeError(f"image must hold floats; got dtype {low.dtype}")
    return low, low_depth, src_meta


def _range_guide(layers, guide, method):
    """What the range term of :func:`upsample` compares: the guide (k, rows, cols) float64
    (None without layers), which one (``"thickness"``, ``"layers"``, ``"array"`` or None)
    and its unit (sigma_range is in units of it)."""
    ref = None
    used = None
    guide_scale = 1.0
    if layers is not None:
        if hasattr(layers, "normalized"):
            thickness = getattr(layers, "thickness", None)
            used = guide or ("thickness" if thickness is not None else "layers")
            if used == "thickness":
                if thickness is None:
                    raise ValueError(f"guide='thickness' needs the boundary layers of a mesh; these layers have no "
                                     f"thickness (they are the {layers.source})")
                # the thickness as it is: its scale to [0, 1] goes into the range sigma
                ref = np.asarray(thickness, dtype=np.float64)[None]
                top = float(ref.max()) if ref.size else 0.0
                guide_scale = top if top > 0.0 else 1.0
            else:
                ref = layers.normalized(layer_first=True)
        else:
            if guide is not None:
                raise ValueError(f"guide={guide!r} chooses from DepthLayers; an array of layers is the guide itself")
            used = "array"
            ref = np.asarray(layers, dtype=np.float64)
            if ref.ndim == 2:
                ref = ref[..., None]
            if ref.ndim != 3:
                raise ValueError(f"layers must be DepthLayers or an array (rows, cols, k); got shape {ref.shape}")
            if not np.all(np.isfinite(ref)):
                raise ValueError("layers must be finite (DepthLayers.normalized() encodes missing layers as 2)")
            ref = np.moveaxis(ref, -1, 0)
        ref = np.ascontiguousarray(ref, dtype=np.float64)
    elif method == "joint_bilateral":
        raise ValueError("method='joint_bilateral' needs the full-resolution layers")
    return ref, used, guide_scale


def _output_size(ref, h, w, factor):
    """The factor (default: the guide's rows over the image's) and the output's rows and
    columns, checked against the guide's size."""
    if factor is None:
        if ref is None:
            raise ValueError("factor must be given when there are no layers")
        factor = ref.shape[1] / h
    factor = as_real("factor", factor, low=0.0, low_open=True)
    H, W = (ref.shape[1], ref.shape[2]) if ref is not None else (int(round(h * factor)), int(round(w * factor)))
    if abs(H - h * factor) > 0.5 or abs(W - w * factor) > 0.5:
        raise ValueError(f"layers of {W}x{H} pixels are not the image's {w}x{h} times factor {factor:g}")
    return factor, H, W


def _joint_bilateral(work, dtype, ref, factor, size, spatial, support, inv_2sr):
    """Filter ``work`` (h, w, c) float64 to ``size`` (rows, cols) with the range weights of
    ``ref`` (``inv_2sr``: 1 / (2 sigma_range^2) in the guide's units) and the ``spatial``
    weights, four channels at a time (the kernels' width)."""
    H, W = size
    if spatial == "gaussian":
        omega = as_real("support", support, low=0.0, low_open=True) if support is not None else max(factor, 2.0)
        sigma_s = omega / 2.0
        radius = max(1, int(math.ceil(2.0 * sigma_s / factor)))
    elif support is not None:
        raise ValueError(f"support={support!r} sets the width of spatial='gaussian'; spatial='bilinear' reads "
                         "the four nearest low-resolution pixels")
    h, w, nc = work.shape
    groups = []
    for c0 in range(0, nc, 4):
        if nc - c0 >= 4:
            part = np.ascontiguousarray(work[..., c0:c0 + 4])
        else:
            part = np.zeros((h, w, 4))
            part[..., :nc - c0] = work[..., c0:]
        if spatial == "gaussian":
            res = np.empty((H, W, 4))
            K.joint_bilateral(part, ref, factor, radius, _inverse_two_squares(sigma_s), inv_2sr, _EXP_TABLE, res)
        else:
            res = np.empty((H, W, 4), dtype=dtype)  # written once, in the output's type
            K.joint_bilinear(part, ref, factor, inv_2sr, _EXP_TABLE, res)
        groups.append(res[..., :min(4, nc - c0)])
    return groups[0] if len(groups) == 1 else np.concatenate(groups, axis=2)


def _nearest_depth(low_depth, factor, low_size, size):
    """``low_depth`` of ``low_size`` (h, w) at ``size`` (rows, cols) by nearest neighbour
    (a whole factor: each pixel repeated)."""
    h, w = low_size
    H, W = size
    if factor == int(factor) and (H, W) == (h * int(factor), w * int(factor)):
        return np.repeat(np.repeat(low_depth, int(factor), axis=0), int(factor), axis=1)
    rows = np.minimum(((np.arange(H) + 0.5) / factor).astype(np.int64), h - 1)
    cols = np.minimum(((np.arange(W) + 0.5) / factor).astype(np.int64), w - 1)
    return low_depth[rows[:, None], cols[None, :]]

