"""Transfer functions for high-dynamic-range data, and their lookup tables."""
from __future__ import annotations

import math
import numbers

import numpy as np

from .._validate import as_choice, as_int, as_real

SCALES = ("linear", "log", "symlog")
SCALE_CODES = {"linear": 0, "log": 1, "symlog": 2}
COLOR_SPACES = ("rgb", "hsv")

#: The largest table the default (``table_size=None``) chooses: a log ramp over 16
#: decades moves by 2.4e-4 decades per entry (and 16-bit data get one entry per value).
DEFAULT_TABLE_SIZE = 65536
MIN_TABLE_SIZE = 256
MAX_TABLE_SIZE = 2**24
#: The default table's accuracy: the largest difference, anywhere on the axis, between
#: the table's linear interpolation and the function itself, in the opacity of a
#: segment of any length up to one unit distance and in the colour times the opacity
#: of one unit (relative to the brightest control point). See
#: :meth:`TransferFunction.table_error`.
TABLE_TOLERANCE = 1e-4
#: The sizes the default tries, smallest first.
AUTO_TABLE_SIZES = tuple(MIN_TABLE_SIZE * 2**k for k in range(9))

# The largest opacity a segment of one unit distance may have: keeps the extinction
# finite (-ln(2**-52) = 36 per unit distance, i.e. opaque for any practical purpose).
_ALPHA_MAX = 1.0 - 2.0**-52


def scale_forward(values, scale, linthresh=1.0):
    """Map data values to the transfer function's axis (vectorised, float64).

    ``log`` maps values <= 0 to ``-inf``; ``symlog`` is
    ``sign(v) * log10(1 + |v| / linthresh)``.
    """
    v = np.asarray(values, dtype=np.float64)
    if scale == "linear":
        return v.copy()
    if scale == "log":
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.log10(np.where(v > 0, v, np.nan))
        return np.where(v > 0, out, -np.inf)
    return np.sign(v) * np.log10(1.0 + np.abs(v) / linthresh)


def table_entry_span(lo, hi, scale, linthresh, axis_lo, axis_inv, n, *, nearest=False):
    """``(i0, i1)``: the first and last entries of an ``n``-entry table whose axis
    starts at ``axis_lo`` (position ``(axis - axis_lo) * axis_inv``, as the kernels
    compute it) that a value between ``lo`` and ``hi`` (arrays, data units) can read.

    The kernels interpolate between entries ``floor(x)`` and ``ceil(x)`` of the table
    position ``x``, clamped to the axis (values below it read entry 0 alone, so a
    function that is 0 at its first point and below gives them no opacity);
    ``nearest=True`` (the 8-bit emulation) reads entry ``round(x)``. The axis transform
    is monotone, so every value of a range reads entries between those of its ends.
    Non-linear axes get a margin of 1e-9 of the axis, because the kernels' ``log10``
    may differ from numpy's by an ulp. NaN ends read entry 0 (callers mask all-NaN
    ranges themselves).
    """
    margin = 0.0 if scale == "linear" else 1e-9
    with np.errstate(invalid="ignore"):  # inf * 0 on a one-point axis
        # log 0 = -inf lies off the axis, margin or not: reads entry 0 alone
        pos = [np.nan_to_num((scale_forward(v, scale, linthresh) - axis_lo) * axis_inv, nan=0.0, neginf=-1.0,
                             posinf=2.0) for v in (lo, hi)]
    ulo = np.clip(pos[0] - margin, 0.0, 1.0) * (n - 1)
    uhi = np.clip(pos[1] + margin, 0.0, 1.0) * (n - 1)
    if nearest:
        return np.floor(ulo + 0.5).astype(np.int64), np.floor(uhi + 0.5).astype(np.int64)
    return np.floor(ulo).astype(np.int64), np.ceil(uhi).astype(np.int64)


def _rgb_to_hsv(rgb):
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    mx = rgb.max(axis=-1)
    mn = rgb.min(axis=-1)
    d = mx - mn
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(mx == r, ((g - b) / d) % 6.0, np.where(mx == g, (b - r) / d + 2.0, (r - g) / d + 4.0))
        s = np.where(mx > 0, d / mx, 0.0)
    h = np.where(d > 0, h / 6.0, 0.0)
    return np.stack([h, s, mx], axis=-1)


def _hsv_to_rgb(hsv):
    h, s, v = hsv[..., 0] % 1.0, hsv[..., 1], hsv[..., 2]
    i = np.floor(h * 6.0)
    f = h * 6.0 - i
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    i = i.astype(int) % 6
    choices_r = [v, q, p, p, t, v]
    choices_g = [t, v, v, q, p, p]
    choices_b = [p, p, t, v, v, q]
    r = np.choose(i, choices_r)
    g = np.choose(i, choices_g)
    b = np.choose(i, choices_b)
    return np.stack([r, g, b], axis=-1)


class TransferFunction:
    """Colour and opacity over scalar value, for data that spans many decades.

    Parameters
    ----------
    values : array_like, shape (n,)
        Control-point positions in data units, strictly increasing, n >= 2. The first
        and last set the table's range; data outside it takes the end entries.
    colors : array_like, shape (n, 3)
        Linear RGB emission at each control point, >= 0 (values above 1 are allowed:
        emission is HDR).
    opacities : array_like, shape (n,)
        Opacity in [0, 1] reached over one ``opacity_unit_distance`` (see
        :class:`~pv_hdrvol.RenderOptions`).
    scale : {"linear", "log", "symlog"}
        Axis on which control points are interpolated and the table is sampled.
        ``log`` needs positive control points; data <= 0 maps below the range.
        ``symlog`` suits signed data spanning decades.
    linthresh : float
        Linear range of ``symlog`` around zero.
    color_space : {"rgb", "hsv"}
        Space in which colours are interpolated between control points.
    table_size : int or None
        Entries of the lookup table, 256 .. 2**24. Samples between entries are
        interpolated linearly. ``None`` (default): as many as the function needs, the
        smallest of 256, 512, ..., 65,536 entries whose interpolation stays within
        :data:`TABLE_TOLERANCE` (1e-4) of the function everywhere
        (:meth:`required_table_size`); 65,536 if none does. A 64-point colormap ramp
        needs 256; a function with sharp kinks more. ``table_size`` then reads the
        chosen size.

    Notes
    -----
    The table stores colour and *extinction* ``sigma = -ln(1 - a * global_alpha) / d``
    per world unit; a segment of length ``s`` then has opacity ``1 - exp(-sigma s)``
    whatever the step (opacity correction).

    Examples
    --------
    >>> import pv_hdrvol as hv
    >>> tf = hv.TransferFunction.ramp(1e-3, 1e4, scale="log", cmap="gray", opacity=(0, 1))
    >>> float(tf.opacity_at(10.0))  # halfway in log10 between 1e-3 and 1e4
    0.5714285714285714
    """

    def __init__(self, values, colors, opacities, *, scale="linear", linthresh=1.0,
                 color_space="rgb", table_size=None):
        self.scale = as_choice("scale", scale, SCALES)
        self.color_space = as_choice("color_space", color_space, COLOR_SPACES)
        self.linthresh = as_real("linthresh", linthresh, low=0, low_open=True)
        self._table_size = None if table_size is None else as_int("table_size", table_size, low=MIN_TABLE_SIZE,
                                                                  high=MAX_TABLE_SIZE)
        #: True when the table size is the function's own (``table_size=None``)
        self.table_size_auto = table_size is None
        values = np.array(values, dtype=np.float64).reshape(-1)
        colors = np.array(colors, dtype=np.float64)
        opacities = np.array(opacities, dtype=np.float64).reshape(-1)
        n = values.size
        if n < 2:
            raise ValueError(f"a transfer function needs at least 2 control points; got {n}")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"control-point values must be finite; got {values}")
        if np.any(np.diff(values) <= 0):
            raise ValueError(f"control-point values must be strictly increasing; got {values}")
        if self.scale == "log" and values[0] <= 0:
            raise ValueError(f"scale='log' needs positive control-point values; got vmin={float(values[0])!r}")
        if colors.shape != (n, 3):
            raise ValueError(f"colors must have shape ({n}, 3) to match values; got {colors.shape}")
        if not np.all(np.isfinite(colors)) or np.any(colors < 0):
            raise ValueError("colors must be finite and >= 0")
        if opacities.shape != (n,):
            raise ValueError(f"opacities must have shape ({n},) to match values; got {opacities.shape}")
        if not np.all(np.isfinite(opacities)) or np.any(opacities < 0) or np.any(opacities > 1):
            raise ValueError(f"opacities must lie in [0, 1]; got min {opacities.min()!r}, max {opacities.max()!r}")
        self.values, self.colors, self.opacities = values, colors, opacities
        for a in (self.values, self.colors, self.opacities):
            a.flags.writeable = False
        self._axis = scale_forward(values, self.scale, self.linthresh)
        self._tables = {}

    # -- factories ---------------------------------------------------------------
    @classmethod
    def ramp(cls, vmin, vmax, *, scale="linear", cmap="viridis", opacity=(0.0, 1.0), n_colors=64,
             linthresh=1.0, table_size=None):
        """Colormap ``cmap`` over ``[vmin, vmax]`` with opacity ramping along the axis.

        Parameters
        ----------
        vmin, vmax : float
            Range in data units (``vmin > 0`` for ``scale="log"``).
        cmap : str or matplotlib colormap
            A matplotlib colormap name (``"gray"`` works without matplotlib).
        opacity : sequence of float
            Opacities spread evenly along the *scaled* axis, interpolated between.
        n_colors : int
            Control points taken from the colormap.
        """
        vmin = as_real("vmin", vmin)
        vmax = as_real("vmax", vmax)
        if vmax <= vmin:
            raise ValueError(f"vmax must be > vmin; got vmin={vmin!r}, vmax={vmax!r}")
        scale = as_choice("scale", scale, SCALES)
        if scale == "log" and vmin <= 0:
            raise ValueError(f"scale='log' needs vmin > 0; got vmin={vmin!r}")
        n = as_int("n_colors", n_colors, low=2, high=4096)
        ops = np.array(opacity, dtype=np.float64).reshape(-1)
        if ops.size < 1:
            raise ValueError("opacity must hold at least one value")
        if ops.size == 1:
            ops = np.repeat(ops, 2)
        a0, a1 = scale_forward([vmin, vmax], scale, linthresh)
        axis = np.linspace(a0, a1, n)
        values = scale_inverse(axis, scale, linthresh)
        values[0], values[-1] = vmin, vmax
        colors = colormap_rgb(cmap, np.linspace(0.0, 1.0, n))
        opac = np.interp(np.linspace(0, 1, n), np.linspace(0, 1, ops.size), ops)
        return cls(values, colors, opac, scale=scale, linthresh=linthresh, table_size=table_size)

    from_colormap = ramp

    @classmethod
    def family(cls, bases, k=None, *, table_size=None):
        """The family ``tau'(v) = sum_i k_i tau_i(v)`` of ``bases`` in extinction space
        (:class:`TransferFunctionFamily`); ``k`` defaults to all ones (their sum)."""
        return TransferFunctionFamily(bases, k, table_size=table_size)

    # -- evaluation --------------------------------------------------------------
    @property
    def vmin(self):
        return float(self.values[0])

    @property
    def vmax(self):
        return float(self.values[-1])

    @property
    def axis_range(self):
        """``(a0, a1)``: the range on the scaled axis."""
        return float(self._axis[0]), float(self._axis[-1])

    def _positions(self, values):
        a = scale_forward(values, self.scale, self.linthresh)
        a0, a1 = self.axis_range
        return np.clip(a, a0, a1)

    def color_at(self, values):
        """Interpolated RGB at data ``values`` (exact control-point interpolation)."""
        a = self._positions(values)
        if self.color_space == "rgb":
            return np.stack([np.interp(a, self._axis, self.colors[:, c]) for c in range(3)], axis=-1)
        hsv = _rgb_to_hsv(self.colors)
        hue = np.unwrap(hsv[:, 0] * 2 * np.pi) / (2 * np.pi)  # shortest way round the hue circle
        out = np.stack([np.interp(a, self._axis, ch) for ch in (hue, hsv[:, 1], hsv[:, 2])], axis=-1)
        return _hsv_to_rgb(out)

    def opacity_at(self, values):
        """Interpolated opacity at data ``values``."""
        return np.interp(self._positions(values), self._axis, self.opacities)

    @property
    def table_size(self):
        """Entries of the lookup table: the one given, or :meth:`required_table_size`."""
        if self._table_size is None:
            self._table_size = self.required_table_size()
        return self._table_size

    def table_error(self, size):
        """The largest error of a ``size``-entry table against the function itself.

        The renderers interpolate colour and extinction linearly between entries; the
        function interpolates colour and opacity linearly between its control points.
        The error is the larger of

        - the opacity error of a segment of any length ``s`` up to one unit distance
          (global opacity 1): ``max_s |exp(-sigma_table s) - exp(-sigma s)|``, bounded by
          ``|sigma_table - sigma| max_s s exp(-sigma_low s)`` with ``sigma_low`` the
          smaller of the two (short segments matter: a mesh's cells, the last step of
          a ray; near opacity 1 the extinction ``-ln(1 - a)`` is steep and a table
          never reproduces it well);
        - the colour error times the opacity of one unit distance, relative to the
          brightest control point,

        taken at every control point (where a kink between two entries is cut off most)
        and halfway between entries (where the extinction's curvature and HSV's arcs
        show most).

        Examples
        --------
        >>> tf = TransferFunction([0.0, 1.0], [[0, 0, 0], [1, 1, 1]], [0.5, 0.5])
        >>> tf.table_error(256) < 1e-15   # linear colour, constant opacity: exact
        True
        """
        n = as_int("size", size, low=2, high=MAX_TABLE_SIZE)
        a0, a1 = self.axis_range
        rgb, sigma = self.table(np.float64, 1.0, 1.0, n)
        nodes = np.linspace(a0, a1, n)
        x = np.concatenate([0.5 * (nodes[1:] + nodes[:-1]), self._axis])
        position = (x - a0) / (a1 - a0) * (n - 1)
        j = np.clip(np.floor(position).astype(np.int64), 0, n - 2)
        f = position - j
        values = scale_inverse(x, self.scale, self.linthresh)
        values[-self._axis.size:] = self.values  # the control points exactly, not through the axis
        alpha = np.minimum(self.opacity_at(values), _ALPHA_MAX)
        sigma_x = -np.log1p(-alpha)
        sigma_t = sigma[j] * (1.0 - f) + sigma[j + 1] * f
        low = np.minimum(sigma_x, sigma_t)
        # max over 0 < s <= 1 of s exp(-low s): at s = 1/low when low > 1
        reach = np.where(low > 1.0, 1.0 / (np.e * np.maximum(low, 1.0)), np.exp(-low))
        error = float(np.max(np.abs(sigma_t - sigma_x) * reach))
        c_max = float(self.colors.max())
        if c_max > 0:
            color_t = rgb[j] * (1.0 - f)[:, None] + rgb[j + 1] * f[:, None]
            emitted = np.abs(color_t - self.color_at(values)) * alpha[:, None]
            error = max(error, float(np.max(emitted)) / c_max)
        return error

    def required_table_size(self, tolerance=TABLE_TOLERANCE):
        """The smallest of 256, 512, ..., 65,536 entries whose :meth:`table_error` is
        at most ``tolerance``; 65,536 when none is (a step in the function is never
        interpolated exactly: 65,536 entries make its ramp 1/65,535 of the axis wide).

        A table whose entries fall on the control points reproduces a function linear
        between them (save the extinction's curvature): 256 entries for control points
        on the 256 values of 8-bit data, as the HDR VolVis paper prescribes.
        """
        tolerance = as_real("tolerance", tolerance, low=0, low_open=True)
        for size in AUTO_TABLE_SIZES:
            if self.table_error(size) <= tolerance:
                return size
        return AUTO_TABLE_SIZES[-1]

    def table(self, dtype=np.float64, global_alpha=1.0, unit_distance=1.0, size=None):
        """Sample the function into a lookup table.

        Returns
        -------
        rgb : ndarray, shape (size, 3), ``dtype``
        sigma : ndarray, shape (size,), ``dtype``
            Extinction per world unit, ``-ln(1 - a * global_alpha) / unit_distance``.
        """
        size = self.table_size if size is None else as_int("table size", size, low=2, high=MAX_TABLE_SIZE)
        key = (np.dtype(dtype).str, float(global_alpha), float(unit_distance), size)
        if key not in self._tables:
            a0, a1 = self.axis_range
            axis = np.linspace(a0, a1, size)
            values = scale_inverse(axis, self.scale, self.linthresh)
            values[0], values[-1] = self.vmin, self.vmax
            rgb = self.color_at(values)
            alpha = np.minimum(self.opacity_at(values) * global_alpha, _ALPHA_MAX)
            sigma = -np.log1p(-alpha) / unit_distance
            self._tables = {key: (np.ascontiguousarray(rgb, dtype=dtype), np.ascontiguousarray(sigma, dtype=dtype))}
        return self._tables[key]

    # -- plain values (JSON) ---------------------------------------------------------
    def to_dict(self):
        """The function as plain Python values (lists, floats, str, int), ready for JSON.

        :meth:`from_dict` gives back an equal function: JSON keeps every float64
        exactly, so renders from the copy are bit-identical.

        Examples
        --------
        >>> import json
        >>> tf = TransferFunction([0.0, 0.1], [[1, 0, 0], [0, 0, 1]], [0.0, 1 / 3], scale="symlog")
        >>> back = TransferFunction.from_dict(json.loads(json.dumps(tf.to_dict())))
        >>> back.opacities.tolist() == tf.opacities.tolist(), back.scale
        (True, 'symlog')
        """
        return {"values": self.values.tolist(), "colors": self.colors.tolist(), "opacities": self.opacities.tolist(),
                "scale": self.scale, "linthresh": float(self.linthresh), "color_space": self.color_space,
                "table_size": int(self.table_size)}

    @classmethod
    def from_dict(cls, data):
        """A function from :meth:`to_dict`'s form: keys ``values``, ``colors`` and
        ``opacities``, optionally ``scale``, ``linthresh``, ``color_space``,
        ``table_size`` (the constructor's defaults when absent); or a
        :class:`TransferFunctionFamily`'s form (keys ``bases`` and ``weights``)."""
        if hasattr(data, "keys") and "bases" in data:
            return TransferFunctionFamily.from_dict(data)
        keywords = _check_keys("TransferFunction", data, required=("values", "colors", "opacities"),
                               optional=("scale", "linthresh", "color_space", "table_size"))
        return cls(keywords.pop("values"), keywords.pop("colors"), keywords.pop("opacities"), **keywords)

    def __repr__(self):
        return (f"TransferFunction({self.values.size} points, range [{self.vmin:.6g}, {self.vmax:.6g}], "
                f"scale={self.scale!r}, color_space={self.color_space!r}, table_size={self.table_size})")


class TransferFunctionFamily(TransferFunction):
    """A weighted sum of basis transfer functions in extinction space.

    ``tau'(v) = sum_i k_i tau_i(v)`` with ``k_i >= 0`` (Gao et al. 2003, Eq. 2): the
    opacity of any ray segment is then ``1 - prod_i (1 - a_i)^{k_i}`` (Eq. 3), with
    ``a_i`` the opacity basis ``i`` alone gives the segment, exactly, whatever the
    data along it. Plenoptic opacity functions computed once per basis
    (:class:`pv_hdrvol.culling.PlenopticOpacity`) therefore stay valid for every
    weight vector: changing ``k`` needs no recomputation.

    Parameters
    ----------
    bases : sequence of TransferFunction
        At least one. They share ``scale`` and ``linthresh``; the family's range is the
        union of theirs, and outside its own range a basis takes its end entries.
    k : sequence of float, optional
        One weight ``>= 0`` per basis (default all 1: the sum of the bases).
    table_size : int, optional
        Entries of the table; default the largest of the bases' own.

    Notes
    -----
    Extinction, not opacity, is what is weighted: ``sigma'(v) = sum_i k_i sigma_i(v)``
    with ``sigma_i = -ln(1 - a_i global_alpha) / unit_distance``. Scaling *opacity*
    (``a -> k a``) would not compose along a ray: for ``k < 1``, ``1 - (1 - a)^k >= k a``
    (Bernoulli), so the block opacities of a culling scheme would overestimate the
    true ones. The family's colour is the extinction-weighted mean of the bases'
    colours, ``c' = sum_i k_i sigma_i c_i / sum_i k_i sigma_i`` (the emission of a
    mixture of absorbers; where no basis absorbs, the ``k``-weighted mean).

    References
    ----------
    J. Gao, J. Huang, H.-W. Shen, J. A. Kohl, "Visibility culling using plenoptic
    opacity functions for large volume visualization", IEEE Visualization 2003.

    Examples
    --------
    >>> skin = TransferFunction([0.0, 1.0], [[1, 0.8, 0.6]] * 2, [0.2, 0.2])
    >>> bone = TransferFunction([0.0, 1.0], [[1, 1, 1]] * 2, [0.5, 0.0])
    >>> fam = TransferFunction.family([skin, bone], k=[0.5, 2.0])
    >>> expected = 1 - (1 - 0.2) ** 0.5 * (1 - 0.5) ** 2.0
    >>> bool(abs(float(fam.opacity_at(0.0)) - expected) < 1e-15)
    True
    """

    def __init__(self, bases, k=None, *, table_size=None):
        if isinstance(bases, (TransferFunction, str, bytes)) or not hasattr(bases, "__len__"):
            raise TypeError(f"bases must be a sequence of TransferFunction; got {type(bases).__name__}")
        bases = tuple(bases)
        if not bases:
            raise ValueError("a transfer-function family needs at least one basis; got none")
        for i, b in enumerate(bases):
            if not isinstance(b, TransferFunction) or isinstance(b, TransferFunctionFamily):
                raise TypeError(f"bases[{i}] must be a TransferFunction (not a family); got {type(b).__name__}")
        scales = {(b.scale, float(b.linthresh)) for b in bases}
        if len(scales) > 1:
            raise ValueError(f"the bases of a family must share scale and linthresh; got {sorted(scales)}")
        weights = np.ones(len(bases)) if k is None else np.array(k, dtype=np.float64).reshape(-1)
        if weights.shape != (len(bases),):
            raise ValueError(f"k must have one weight per basis ({len(bases)}); got {weights.size}")
        if not np.all(np.isfinite(weights)) or np.any(weights < 0):
            raise ValueError(f"family weights k must be finite and >= 0; got {weights.tolist()}")
        self.bases = bases
        self.k = weights
        self.k.flags.writeable = False
        values = np.unique(np.concatenate([b.values for b in bases]))
        scale, linthresh = bases[0].scale, bases[0].linthresh
        size = max(b.table_size for b in bases) if table_size is None else table_size
        super().__init__(values, self.color_at(values), self.opacity_at(values), scale=scale, linthresh=linthresh,
                         table_size=size)

    def with_weights(self, k):
        """The same bases with weights ``k`` (cheap: no basis is recomputed)."""
        return TransferFunctionFamily(self.bases, k, table_size=self.table_size)

    def _basis_sigmas(self, values, global_alpha=1.0):
        """``(p, n)`` extinction per unit distance of each basis at ``values``."""
        return np.stack([-np.log1p(-np.minimum(b.opacity_at(values) * global_alpha, _ALPHA_MAX))
                         for b in self.bases])

    def _mix(self, values, global_alpha=1.0):
        sigmas = self._basis_sigmas(values, global_alpha) * self.k[:, None]
        sigma = sigmas.sum(axis=0)
        colors = np.stack([b.color_at(values) for b in self.bases])  # (p, n, 3)
        weights = np.where(sigma > 0, sigmas, self.k[:, None] * np.ones_like(sigma))
        total = weights.sum(axis=0)
        color = np.einsum("pn,pnc->nc", weights, colors) / np.where(total > 0, total, 1.0)[:, None]
        return color, sigma

    def color_at(self, values):
        """Extinction-weighted mean colour of the bases at data ``values``."""
        return self._mix(np.atleast_1d(np.asarray(values, dtype=np.float64)))[0].reshape(np.shape(values) + (3,))

    def opacity_at(self, values):
        """``1 - prod_i (1 - a_i)^{k_i}``: opacity of one unit distance at ``values``."""
        sigma = (self._basis_sigmas(np.atleast_1d(np.asarray(values, dtype=np.float64))) * self.k[:, None]).sum(0)
        return (-np.expm1(-sigma)).reshape(np.shape(values))

    def table(self, dtype=np.float64, global_alpha=1.0, unit_distance=1.0, size=None):
        """Colour and ``sigma' = sum_i k_i sigma_i`` on the family's axis (see
        :meth:`TransferFunction.table`): each basis is evaluated on the same entries, so
        the table's interpolation is the weighted sum of the bases' interpolations."""
        size = self.table_size if size is None else as_int("table size", size, low=2, high=MAX_TABLE_SIZE)
        key = (np.dtype(dtype).str, float(global_alpha), float(unit_distance), size)
        if key not in self._tables:
            a0, a1 = self.axis_range
            values = scale_inverse(np.linspace(a0, a1, size), self.scale, self.linthresh)
            values[0], values[-1] = self.vmin, self.vmax
            rgb, sigma = self._mix(values, global_alpha)
            self._tables = {key: (np.ascontiguousarray(rgb, dtype=dtype),
                                  np.ascontiguousarray(sigma / unit_distance, dtype=dtype))}
        return self._tables[key]

    def basis_tables(self, global_alpha=1.0, unit_distance=1.0, size=None):
        """``(p, size)`` float64 extinction of each basis on the family's table entries."""
        size = self.table_size if size is None else as_int("table size", size, low=2, high=MAX_TABLE_SIZE)
        a0, a1 = self.axis_range
        values = scale_inverse(np.linspace(a0, a1, size), self.scale, self.linthresh)
        values[0], values[-1] = self.vmin, self.vmax
        return self._basis_sigmas(values, global_alpha) / unit_distance

    def to_dict(self):
        """Plain values: ``{"bases": [basis.to_dict(), ...], "weights": [...], "table_size": n}``."""
        return {"bases": [b.to_dict() for b in self.bases], "weights": self.k.tolist(),
                "table_size": int(self.table_size)}

    @classmethod
    def from_dict(cls, data):
        keywords = _check_keys("TransferFunctionFamily", data, required=("bases", "weights"),
                               optional=("table_size",))
        bases = [TransferFunction.from_dict(b) for b in keywords["bases"]]
        return cls(bases, keywords["weights"], table_size=keywords.get("table_size"))

    def __repr__(self):
        return (f"TransferFunctionFamily({len(self.bases)} bases, k={self.k.tolist()}, "
                f"range [{self.vmin:.6g}, {self.vmax:.6g}], scale={self.scale!r}, table_size={self.table_size})")


def _check_keys(kind, data, required, optional=()):
    """``dict(data)`` after checking it is a mapping with all ``required`` keys and no
    others than ``optional``; errors name the missing or unknown keys."""
    if not hasattr(data, "keys"):
        raise TypeError(f"{kind}.from_dict needs a dict; got {type(data).__name__}")
    data = dict(data)
    missing = [k for k in required if k not in data]
    if missing:
        raise ValueError(f"{kind}.from_dict: missing keys {missing}; needs {list(required)}")
    unknown = sorted(set(data) - set(required) - set(optional))
    if unknown:
        raise ValueError(f"{kind}.from_dict: unknown keys {unknown}; allowed: {list(required) + list(optional)}")
    return data


def scale_inverse(axis, scale, linthresh):
    """Data values (float64) of positions ``axis`` on a ``"linear"``, ``"log"`` (base 10)
    or ``"symlog"`` axis (linear threshold ``linthresh``): the inverse of the axis map."""
    axis = np.asarray(axis, dtype=np.float64)
    if scale == "linear":
        return axis.copy()
    if scale == "log":
        return 10.0 ** axis
    return np.sign(axis) * linthresh * (10.0 ** np.abs(axis) - 1.0)


def colormap_rgb(cmap, t):
    """RGB of colormap ``cmap`` (a name or a matplotlib colormap) at ``t`` in [0, 1]."""
    t = np.asarray(t, dtype=np.float64)
    if isinstance(cmap, str) and cmap in ("gray", "grey"):
        return np.repeat(t[:, None], 3, axis=1)
    try:
        import matplotlib
    except ImportError:  # pragma: no cover - matplotlib comes with pyvista
        raise ValueError(f"cmap {cmap!r} needs matplotlib; only 'gray' works without it") from None
    if isinstance(cmap, str):
        try:
            cm = matplotlib.colormaps[cmap]
        except KeyError:
            raise ValueError(f"cmap {cmap!r} is not a matplotlib colormap name") from None
    elif callable(cmap):
        cm = cmap
    else:
        raise TypeError(f"cmap must be a colormap name or a matplotlib colormap; got {cmap!r}")
    return np.asarray(cm(t), dtype=np.float64)[:, :3]


# -- the default transfer function -----------------------------------------------------------
#: Colormap of the default transfer function, and the part of it used: its darkest
#: eighth would vanish against a black background.
DEFAULT_CMAP = "magma"
_CMAP_START = 0.125
#: Transmittance left by a ray through the whole volume if every voxel it crossed were
#: an average voxel of the data: the default opacity keeps the average ray from saturating.
DEFAULT_TRANSMITTANCE = 0.25
#: The transmittance the context class of integer (CT-like) data keeps on its own:
#: the most voluminous class above the background (soft tissue, dentin) stays a veil
#: over the denser classes, which take the rest of the opacity.
CONTEXT_TRANSMITTANCE = 0.8
#: The veil's emission relative to the colormap's first colour: it absorbs (it dims
#: what lies behind it, as tissue does) but hardly glows, so the tone mapper does not
#: make a bright fog of its large volume.
VEIL_BRIGHTNESS = 0.05
#: The colormap of a signed field's default: diverging about zero (ParaView's default
#: "Cool to Warm").
SIGNED_CMAP = "coolwarm"
#: The default opacity never makes one unit distance fully opaque: at most 0.99
#: (extinction 4.6 per unit). At 1 the extinction jumps to 36 per unit (the float
#: limit), and no table interpolates that jump well for the short segments of fine
#: mesh cells; visually 0.99 and 1 are the same.
DEFAULT_MAX_OPACITY = 0.99
_HIST_BINS = 256


def auto_transfer_function(values, ray_length, *, spacing=None, weights=None, scale=None, clim=None, cmap=None,
                           opacity=None, integer=False):
    """The default transfer function of ``values``: what a careful user would set by hand.

    - **Axis**: ``log`` when the data are not negative and their positive values span
      more than 3 decades from the 5th percentile to the maximum (zeros are empty; a
      few stray tiny values, or noise about zero, do not count), ``symlog`` when they
      have both signs and their magnitudes span more than 3 decades, also from the 5th
      percentile (a smooth field's values near its zero crossing do not count), else
      ``linear`` (``scale`` overrides).
    - **Background**: the histogram's dominant mode (air in CT, the floor of a density
      field) stays transparent when it lies in the lower half of the axis: opacity
      starts where the smoothed histogram (256 bins on the axis) falls below 5 % of the
      mode's peak after it, or at its first valley below half the peak, ``vmin`` (when
      the mode is a peak: over 3 times the median bin, and within a quarter of the
      axis; evenly spread data has no background). Otherwise ``vmin`` is the 0.5th
      percentile. A dominant mode in the upper half of the axis (a free stream) is
      cut out of the opacity instead: 0 over the mode, rising to the ramp over one
      mode's width on either side.
    - **Structure**: the colormap and the opacity ramp span ``[vmin, vmax]``,
      ``vmax`` the 99.9th percentile of the values above ``vmin``. Constant data has
      none: its default is transparent (the renderers then warn that the image is
      empty, and why).
    - **Opacity**: 0 at ``vmin``, rising to ``a`` at ``vmax``: linearly along a linear
      or symlog axis; on a log axis in proportion to the value (a density: faint
      decades get little opacity and stay visible in the HDR image, instead of
      fogging the view). ``a`` is chosen so that rays through the data keep a
      transmittance of :data:`DEFAULT_TRANSMITTANCE` (the HDR VolVis rule
      ``alpha = 1 - exp(ln(r) / n)`` for ``n`` samples, applied to the data's mix of
      values; ``s(v)`` is the opacity's shape). On a grid (3-D ``values`` with
      ``spacing``) the rays are the grid's columns along its three axes, and the 95th
      percentile of their optical depths ``sum a s(v) spacing`` (in unit distances, to
      first order in ``a``) is held to ``-ln(0.25)``: the densest rays stay readable.
      Elsewhere a ray of ``ray_length`` through average voxels is:
      ``ray_length * mean(-ln(1 - a s(v))) = -ln(0.25)`` (weighted by ``weights``).
      ``a`` is at most :data:`DEFAULT_MAX_OPACITY` (0.99).
    - **Classes of CT-like data** (``integer=True``, a linear axis, a grid): the most
      voluminous class above the background (soft tissue under bone, dentin under
      enamel) is found as the background is, a peak in the lower half of the
      structure's range, and becomes a veil: its own columns keep a transmittance of
      :data:`CONTEXT_TRANSMITTANCE` (0.8), an opacity ``c`` reached at the class's end;
      the denser classes above it take an opacity rising from ``c`` to ``c + a`` at
      ``vmax``, ``a`` chosen so that the columns of the whole still keep 0.25 (the rule
      above). The colormap spans the denser classes; the veil takes its first colour
      times :data:`VEIL_BRIGHTNESS` (0.05): it dims what lies behind it and hardly
      glows. A linear ramp gave the class most of the opacity and light: the CT head's
      brain and skin were a pink fog over the skull.
    - **Signed fields** (both signs, each at least 1 % of the values, the lesser
      side's 99.9th-percentile magnitude at least 1e-3 of the other's; not integer
      data, where a sign is an offset, e.g. Hounsfield units): both signs show. The
      range is symmetric, ``[-M, M]`` with ``M`` the 99.9th percentile of ``|v|``; the
      colormap diverges about zero (:data:`SIGNED_CMAP`); the opacity is in
      proportion to the magnitude, 0 at zero, ``a`` at either end (``a`` by the rule
      above; as a log axis's density, the faint decades get little opacity and stay
      visible in the HDR image: opacity linear in the symlog axis fogged the view). A
      symlog axis then has ``linthresh`` at the 5th percentile of the non-zero
      magnitudes, so the axis is spent on the decades the data fill.

    Parameters
    ----------
    values : array of real numbers
        The data (any shape; NaN and inf ignored).
    ray_length : float
        The longest ray through the data in unit distances (voxels of the smallest
        spacing; cells for a mesh).
    spacing : sequence of 3 floats, optional
        With 3-D ``values`` (z, y, x) of a grid: its (x, y, z) spacing in unit
        distances; the opacity then follows from the grid's columns.
    weights : array of floats >= 0, optional
        One per value: the share of the volume it stands for (a mesh's cell volumes at
        its corners). The histogram and the average ray are then of space, not of
        values.
    scale, clim, cmap, opacity : optional
        Replace single choices, with PyVista's meanings (``add_volume``): the axis
        (``"linear"``, ``"log"``, ``"symlog"``); the range ``(vmin, vmax)`` that the
        colormap and the opacity span (either end ``None``: the default's; a number
        ``c``: ``(-c, c)``); a matplotlib colormap, used whole; the opacity (see
        :func:`opacity_curve`: a PyVista curve name, a number, or values spread
        evenly along the axis from ``vmin`` to ``vmax``), reached over one opacity
        unit distance and not rescaled.
    integer : bool
        The values are integer samples of a measurement (CT, MRI): the classes above
        the background are separated, and a sign is not a signed field's.

    Returns
    -------
    TransferFunction

    Examples
    --------
    >>> v = np.concatenate([np.zeros(9000), np.linspace(50, 200, 1000)])  # 90 % background
    >>> tf = auto_transfer_function(v, ray_length=30)
    >>> tf.scale, float(tf.opacity_at(0.0)), tf.vmin > 0, tf.vmax > 190
    ('linear', 0.0, True, True)
    """
    vmin, vmax = parse_clim(clim)
    if cmap is not None:
        colormap_rgb(cmap, [0.0])  # a bad name fails here, whatever the data
    if opacity is not None:
        opacity = opacity_curve(opacity)
    v, w = _finite_values(values, weights)
    if v.size == 0:
        return TransferFunction.ramp(0.0, 1.0, cmap=_cmap_colors(cmap), opacity=(0.0, 0.0))
    lo, hi = float(v.min()), float(v.max())
    signed = not integer and _is_signed(v, w)
    if scale is None:
        scale = _default_scale(v, lo, hi)
    scale = as_choice("scale", scale, SCALES)
    if signed and scale != "log":
        return _signed_default(values, v, w, scale, vmin, vmax, cmap, opacity, float(ray_length), spacing)
    linthresh = 1.0
    if scale == "log":
        v, w, w_empty = _positive_values(v, w, lo, hi)
        lo = float(v.min())
    elif scale == "symlog":
        nonzero = np.abs(v[v != 0])
        linthresh = float(nonzero.min()) if nonzero.size else 1.0
    axis = scale_forward(v, scale, linthresh)
    a_lo, a_hi = float(axis.min()), float(axis.max())
    notch = None
    if vmin is None or vmax is None or opacity is None:
        t0, t1, notch = _structure_range(axis, a_lo, a_hi, w)
        if vmin is None:
            vmin = float(scale_inverse([t0], scale, linthresh)[0]) if t0 > a_lo else lo
        if vmax is None:
            vmax = float(scale_inverse([t1], scale, linthresh)[0]) if t1 < a_hi else hi
    if scale == "log" and vmin <= 0:  # before any axis arithmetic on it
        raise ValueError(f"scale='log' needs a positive low end of clim; got {vmin!r}")
    if lo == hi and opacity is None:
        # constant data has no structure to show: an empty picture, which the renderers
        # explain (EmptyRenderWarning), rather than a uniform fog
        return TransferFunction.ramp(lo, lo + 1.0, cmap=_cmap_colors(cmap), opacity=(0.0, 0.0))
    if vmax < vmin:  # one end given, the other chosen beyond it
        raise ValueError(f"clim {(vmin, vmax)!r} (the ends not given are the default's) must have high > low; "
                         "give both ends")
    if vmax == vmin:  # all of the structure at one value: a narrow ramp about it
        pad = 1e-3 * max(abs(vmin), 1.0)
        vmin, vmax = (vmin, vmax + pad) if scale == "log" else (vmin - pad, vmax + pad)
    n = 128 if scale == "log" else 64
    if opacity is not None:
        n = min(max(n, opacity.size), 4096)  # a PyVista curve keeps its 256 points
    else:
        # the opacity's shape at the ramp's control points, then the height the rays allow
        n = n if notch is None else 256
        axis_points, points = _opacity_shape(vmin, vmax, scale, linthresh, n, notch)
        raw = np.asarray(values)
        soft = None
        if integer and scale == "linear" and notch is None and spacing is not None and raw.ndim == 3:
            soft = _soft_class(axis, float(axis_points[0]), float(axis_points[-1]), w)
        if soft is not None:
            return _veiled_classes(raw, scale, linthresh, axis_points, soft, cmap, spacing)
        elif spacing is not None and raw.ndim == 3:
            opacity = _column_opacity(raw, scale, linthresh, axis_points, points, spacing) * points
        else:
            shape = np.interp(axis, axis_points, points)
            if scale == "log":  # values <= 0 (dropped above) are empty: they count as transparent voxels
                empty = int(np.count_nonzero(raw <= 0))
                shape = np.concatenate([shape, np.zeros(empty)])
                w = None if w is None else np.concatenate([w, np.full(empty, w_empty / max(empty, 1))])
            opacity = _ray_opacity(shape, float(ray_length), w) * points
    return TransferFunction.ramp(vmin, vmax, scale=scale, cmap=_cmap_colors(cmap), opacity=opacity, n_colors=n,
                                 linthresh=linthresh)


def _finite_values(values, weights):
    """The finite values, flat float64, and their weights (None without ``weights``).

    Raises
    ------
    ValueError
        ``weights`` not finite, negative somewhere, or not one per value.
    """
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    finite = np.isfinite(v)
    w = None
    if weights is not None:
        w = np.asarray(weights, dtype=np.float64).reshape(-1)
        if w.shape != v.shape or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise ValueError(f"weights must be finite, >= 0 and one per value ({v.size}); got shape "
                             f"{np.shape(weights)}")
        w = w[finite]
    return v[finite], w


def _positive_values(v, w, lo, hi):
    """What a log axis keeps of the values ``v`` (spanning ``[lo, hi]``): the positive
    ones, their weights, and the weight of the rest (values <= 0: empty space)."""
    positive = v > 0
    v = v[positive]
    if v.size == 0:
        raise ValueError(f"scale='log' needs positive data; the values span [{lo:g}, {hi:g}]")
    w_empty = 0.0 if w is None else float(w[~positive].sum())
    w = None if w is None else w[positive]
    return v, w, w_empty


def _opacity_shape(vmin, vmax, scale, linthresh, n, notch):
    """The default opacity's ``n`` control points on the axis from ``vmin`` to ``vmax``
    and its shape there, 0 to 1: linear along the axis, or on a log axis in proportion
    to the value; cut out over ``notch`` (a dominant mode high on the axis) when given."""
    # on a log axis a density: every decade keeps its share of the light, faint ones
    # faint, and the HDR image keeps them
    axis_points = np.linspace(*scale_forward([vmin, vmax], scale, linthresh), n)
    if scale == "log":
        points = 10.0 ** (axis_points - axis_points[-1])  # v / vmax, exactly 1 at the top
        points[0] = 0.0  # the background stays transparent
    else:
        points = np.linspace(0.0, 1.0, n)
    if notch is not None:
        # a dominant mode high on the axis (a free stream around the structure):
        # transparent over the mode, rising to the ramp over one mode's width on
        # either side (the ramp has 256 points then, to resolve it)
        width = notch[1] - notch[0]
        gap = np.maximum(notch[0] - axis_points, axis_points - notch[1])
        notched = points * np.clip(gap / width, 0.0, 1.0)
        if np.any(notched > 0):
            points = notched
    return axis_points, points


def _veiled_classes(raw, scale, linthresh, axis_points, soft, cmap, spacing):
    """The transfer function of CT-like classes: the context class (up to ``soft`` on
    the axis) a dim veil, the denser classes the rest of the opacity and the colormap."""
    # 256 points: the kink at the veil's end
    n = 256
    axis_points = np.linspace(axis_points[0], axis_points[-1], n)
    veil = np.clip((axis_points - axis_points[0]) / (soft - axis_points[0]), 0.0, 1.0)
    dense = np.clip((axis_points - soft) / (axis_points[-1] - soft), 0.0, 1.0)
    c, a = _class_opacity(raw, scale, linthresh, axis_points, veil, dense, spacing)
    # the colormap spans the denser classes; the veil has its first colour, dimmed
    rgb = _cmap_rgb(cmap, dense) * np.where(axis_points < soft, VEIL_BRIGHTNESS, 1.0)[:, None]
    return TransferFunction(axis_points, rgb, c * veil + a * dense)


def parse_clim(clim):
    """``(low, high)`` of a ``clim=`` keyword (PyVista's meaning), ``None`` where the
    default chooses.

    ``None`` is ``(None, None)``; a number ``c`` is ``(-c, c)``, as in PyVista; a pair
    may leave either end ``None``. Given ends are finite, and ``high > low``.

    Examples
    --------
    >>> parse_clim(3), parse_clim((None, 1e3)), parse_clim(None)
    ((-3.0, 3.0), (None, 1000.0), (None, None))
    """
    if clim is None:
        return None, None
    if isinstance(clim, numbers.Real) and not isinstance(clim, (bool, np.bool_)):
        clim = (-clim, clim)
    if isinstance(clim, (str, bytes)) or not hasattr(clim, "__len__") or len(clim) != 2:
        raise TypeError(f"clim must be (low, high) or a number c meaning (-c, c); got {clim!r}")
    ends = []
    for end in clim:
        if end is None:
            ends.append(None)
            continue
        if isinstance(end, (bool, np.bool_)) or not isinstance(end, numbers.Real):
            raise TypeError(f"clim must be (low, high) or a number c meaning (-c, c); got {clim!r}")
        ends.append(float(end))
    lo, hi = ends
    if any(e is not None and not math.isfinite(e) for e in ends) or (lo is not None and hi is not None
                                                                     and not hi > lo):
        raise ValueError(f"clim must be finite with high > low; got {clim!r}")
    return lo, hi


#: The names of PyVista's opacity curves (``pyvista.opacity_transfer_function``) are
#: sampled at this many points, as ``add_volume`` samples them (its ``n_colors``).
PYVISTA_N_COLORS = 256


def opacity_curve(opacity):
    """The opacities of an ``opacity=`` keyword (PyVista's meaning), as a 1-D array
    spread evenly over the transfer function's range.

    - a name of ``pyvista.opacity_transfer_function`` (``"linear"``, ``"linear_r"``,
      ``"geom"``, ``"geom_r"``, ``"sigmoid"``, ``"sigmoid_r"``, ``"sigmoid_1"`` ...
      ``"sigmoid_20"`` and their ``_r``, ``"foreground"``): 256 values, as PyVista
      samples it (``opacity_transfer_function(name, 256) / 255``);
    - one number in [0, 1]: that opacity everywhere;
    - a sequence of at least 2 numbers in [0, 1]: as given.

    Examples
    --------
    >>> opacity_curve([0, 0.5]).tolist(), opacity_curve(0.25).tolist()
    ([0.0, 0.5], [0.25, 0.25])
    """
    if isinstance(opacity, str):
        try:
            from pyvista import opacity_transfer_function
        except ImportError:  # pragma: no cover - pyvista is a dependency
            raise ValueError(f"opacity={opacity!r} names a PyVista opacity transfer function, which needs "
                             "pyvista; pass opacities instead") from None
        try:
            curve = opacity_transfer_function(opacity, PYVISTA_N_COLORS)
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
    return np.full(2, float(values)) if values.ndim == 0 else values


#: The keywords that shape the default transfer function, the same in every front end
#: (``hv.render``, ``dataset.hdrvol.render``, ``HDRVolumeRenderer.Set<Name>`` and the
#: CLI's ``--<name>``): PyVista's ``add_volume`` names and meanings, and the axis.
TF_KEYWORDS = ("cmap", "clim", "opacity", "scale")


def default_transfer_function_keyword(name, value):
    """Check one keyword of the default transfer function (``cmap``, ``clim``,
    ``opacity``, ``scale``) on its own, as :func:`auto_transfer_function` would (a
    ``TypeError`` or ``ValueError`` naming what is wrong), and return its meaning: the
    colormap or axis, ``parse_clim``'s pair, ``opacity_curve``'s values as a tuple."""
    if name == "cmap":
        colormap_rgb(value, [0.0])
        return value
    if name == "clim":
        return parse_clim(value)
    if name == "opacity":
        return tuple(opacity_curve(value).tolist())
    if name == "scale":
        return as_choice("scale", value, SCALES)
    raise ValueError(f"{name!r} is not a keyword of the default transfer function; they are "
                     f"{', '.join(TF_KEYWORDS)}")


def _default_scale(v, lo, hi):
    """``log`` for non-negative data whose positive values span more than 3 decades
    (zeros are then empty), ``symlog`` for data of both signs whose magnitudes do,
    else ``linear``; both from the 5th percentile, so that the few tiny values of a
    smooth field near zero (or its zero crossing) do not count."""
    if lo >= 0 and hi > 0:
        positive = v[v > 0]
        return "log" if hi / np.percentile(positive, 5.0) > 1e3 else "linear"
    if lo < 0 < hi:
        mags = np.abs(v[v != 0])
        if mags.size and mags.max() / np.percentile(mags, 5.0) > 1e3:
            return "symlog"
    return "linear"


def _structure_range(axis, a_lo, a_hi, weights=None):
    """``(t0, t1, notch)`` on the axis: past the dominant mode when it lies in the lower
    half of the axis (air, a density's floor; values below it are hidden too), to the
    99.9th percentile; ``notch`` the dominant mode's ``(start, end)`` when it lies in
    the upper half (a free stream around slower and faster structure), else None.
    ``weights``: each value's share of the volume. (A notch for a mode in the lower
    half too was tried: it showed the Blunt Fin's whole domain and a box around the
    headsq CT, so values below a low mode stay hidden.)"""
    if not a_hi > a_lo:
        return a_lo, a_hi, None
    smooth, edges, mode, is_peak = _histogram_mode(axis, a_lo, a_hi, weights, _HIST_BINS)
    t0 = float(np.percentile(axis, 0.5))
    notch = None
    end = _mode_end(smooth, mode, 1)
    if mode < _HIST_BINS // 2:
        if is_peak and end - mode <= _HIST_BINS // 4:
            t0 = float(edges[end])  # the structure starts past the mode: all below it is hidden
    else:
        start = _mode_end(smooth, mode, -1)
        if is_peak and end - start <= _HIST_BINS // 4:
            # a walk that reached an end of the axis takes the mode to that end
            notch = (float(edges[start + 1]), float(edges[-1] if end == _HIST_BINS - 1 else edges[end]))
    above = axis[axis > t0]
    t1 = float(np.percentile(above, 99.9)) if above.size else a_hi
    return t0, max(t1, t0), notch


def _histogram_mode(axis, lo, hi, weights, bins):
    """``(smooth, edges, mode, is_peak)``: the histogram of ``axis`` over ``[lo, hi]`` in
    ``bins`` bins smoothed over 5, its dominant bin, and whether that is a peak (over 3
    times the median non-empty bin: evenly spread data has none)."""
    counts, edges = np.histogram(axis, bins=bins, range=(lo, hi), weights=weights)
    smooth = np.convolve(counts, np.ones(5) / 5.0, mode="same")
    mode = int(np.argmax(smooth))
    return smooth, edges, mode, bool(smooth[mode] > 3.0 * float(np.median(smooth[smooth > 0])))


def _mode_end(smooth, mode, step):
    """The bin where the mode at ``mode`` ends going by ``step`` (+1 or -1): where the
    histogram falls below 5 % of its peak, or at a valley below half of it (a plateau
    of noise has no such valley inside); an end of the histogram at the latest."""
    peak = smooth[mode]
    end = mode + step
    while 0 < end < smooth.size - 1 and smooth[end] >= 0.05 * peak and not (
            smooth[end] < 0.5 * peak and smooth[end] < smooth[end - step] and smooth[end] <= smooth[end + step]):
        end += step
    return end


def _is_signed(v, w=None):
    """Whether finite values ``v`` (weights ``w``) are a signed field: both signs, each at
    least 1 % of the values (of the weight), the lesser side's 99.9th-percentile
    magnitude at least 1e-3 of the other's (noise about zero is not a sign)."""
    neg, pos = v < 0, v > 0
    if not (neg.any() and pos.any()):
        return False
    total = float(v.size if w is None else w.sum())
    shares = [float(m.sum() if w is None else w[m].sum()) / total if total > 0 else 0.0 for m in (neg, pos)]
    if min(shares) < 0.01:
        return False
    tops = [float(np.percentile(np.abs(v[m]), 99.9)) for m in (neg, pos)]
    return min(tops) >= 1e-3 * max(tops)


def _signed_default(values, v, w, scale, vmin, vmax, cmap, opacity, ray_length, spacing):
    """The default transfer function of a signed field (see
    :func:`auto_transfer_function`): symmetric range, diverging colours, opacity in
    proportion to the magnitude, 0 at zero."""
    mags = np.abs(v[v != 0])
    linthresh = float(np.percentile(mags, 5.0)) if scale == "symlog" else 1.0
    top = float(np.percentile(np.abs(v), 99.9))
    if not top > 0:
        top = float(mags.max())
    vmin = -top if vmin is None else vmin
    vmax = top if vmax is None else vmax
    if vmax <= vmin:
        raise ValueError(f"clim {(vmin, vmax)!r} (the ends not given are the default's) must have high > low; "
                         "give both ends")
    n = 129  # odd: zero is a control point of a symmetric range
    if opacity is not None:
        n = min(max(n, opacity.size), 4096)
    else:
        a0, a1 = scale_forward([vmin, vmax], scale, linthresh)
        axis_points = np.linspace(a0, a1, n)
        # in proportion to the magnitude, 0 at zero (on a symlog axis, as a log axis's density:
        # faint decades get little opacity and stay visible in the HDR image, not a fog)
        magnitude = np.abs(scale_inverse(axis_points, scale, linthresh))
        points = magnitude / magnitude.max()
        raw = np.asarray(values)
        if spacing is not None and raw.ndim == 3:
            opacity = _column_opacity(raw, scale, linthresh, axis_points, points, spacing) * points
        else:
            shape = np.interp(scale_forward(v, scale, linthresh), axis_points, points)
            opacity = _ray_opacity(shape, ray_length, w) * points
    return TransferFunction.ramp(vmin, vmax, scale=scale, cmap=SIGNED_CMAP if cmap is None else cmap,
                                 opacity=opacity, n_colors=n, linthresh=linthresh)


def _class_opacity(values, scale, linthresh, axis_points, veil, dense, spacing):
    """``(c, a)`` of the opacity ``c veil(v) + a dense(v)`` on a grid: the veil's columns
    alone keep :data:`CONTEXT_TRANSMITTANCE` at their 95th percentile, the whole's
    :data:`DEFAULT_TRANSMITTANCE` (column depths are linear in ``c`` and ``a``: one pass
    each, then a bisection on the sums)."""
    d_veil, d_dense = (_column_depths(values, scale, linthresh, axis_points, p, spacing) for p in (veil, dense))
    p95 = float(np.percentile(d_veil, 95.0))
    c = min(-np.log(CONTEXT_TRANSMITTANCE) / p95, DEFAULT_MAX_OPACITY) if p95 > 0 else 0.0
    target = -np.log(DEFAULT_TRANSMITTANCE)
    top = DEFAULT_MAX_OPACITY - c
    if float(np.percentile(c * d_veil + top * d_dense, 95.0)) <= target:
        return c, top
    lo, hi = 0.0, top
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if float(np.percentile(c * d_veil + mid * d_dense, 95.0)) <= target else (lo, mid)
    return c, lo


def _soft_class(axis, t0, t1, weights=None):
    """The end of the most voluminous class of the structure ``[t0, t1]`` on the axis
    when it is a peak in the lower half of it (soft tissue above the air of a CT), else
    None."""
    inside = (axis >= t0) & (axis <= t1)
    if not t1 > t0 or inside.sum() < 16:
        return None
    sample = axis[inside]
    bins = _HIST_BINS
    if np.array_equal(sample, np.round(sample)) and t1 - t0 < 2 * _HIST_BINS:
        bins = max(8, int(np.ceil(t1 - t0)))  # integer data: no bin without a value in it (a comb of valleys)
    smooth, edges, mode, is_peak = _histogram_mode(sample, t0, t1, None if weights is None else weights[inside], bins)
    if mode >= bins // 2 or not is_peak:
        return None
    end = _mode_end(smooth, mode, 1)
    if end - mode > bins // 4:
        return None
    return float(edges[end])


def _ray_opacity(shape, ray_length, weights=None):
    """The largest opacity ``a`` (per unit distance) with
    ``ray_length * mean(-ln(1 - a shape)) <= -ln(DEFAULT_TRANSMITTANCE)``, by bisection
    (the mean weighted by ``weights``, each value's share of the volume, if given)."""
    target = -np.log(DEFAULT_TRANSMITTANCE) / max(ray_length, 1.0)
    if shape.size == 0 or not np.any(shape > 0):
        return DEFAULT_MAX_OPACITY
    # bin the shape: the mean over millions of voxels, cheaply (transparent voxels,
    # most of them, exactly: they add nothing)
    visible = shape > 0
    hist, edges = np.histogram(shape[visible], bins=4096, range=(0.0, 1.0),
                               weights=None if weights is None else weights[visible])
    centers = 0.5 * (edges[:-1] + edges[1:])
    weights = hist / (shape.size if weights is None else float(weights.sum()))

    def depth(a):
        return float(weights @ -np.log1p(-np.minimum(a * centers, _ALPHA_MAX)))

    if depth(DEFAULT_MAX_OPACITY) <= target:
        return DEFAULT_MAX_OPACITY
    lo, hi = 0.0, DEFAULT_MAX_OPACITY
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if depth(mid) <= target else (lo, mid)
    return lo


def _column_opacity(values, scale, linthresh, axis_points, points, spacing):
    """The opacity ``a`` (per unit distance) whose 95th percentile of column optical
    depths ``sum a s(v) spacing`` along the grid's three axes is ``-ln(r)``."""
    d95 = float(np.percentile(_column_depths(values, scale, linthresh, axis_points, points, spacing), 95.0))
    if not d95 > 0:
        return DEFAULT_MAX_OPACITY
    return float(min(-np.log(DEFAULT_TRANSMITTANCE) / d95, DEFAULT_MAX_OPACITY))


def _column_depths(values, scale, linthresh, axis_points, points, spacing):
    """The optical depths ``sum s(v) spacing`` (per unit of opacity) of a grid's columns
    along its three axes, one array, for the shape ``s`` given at ``axis_points``."""
    with np.errstate(invalid="ignore", divide="ignore"):
        axis = scale_forward(values, scale, linthresh)
    shape = np.interp(axis, axis_points, points)
    shape[~np.isfinite(axis)] = 0.0  # NaN, and values <= 0 on a log axis: empty
    return np.concatenate([shape.sum(axis=2).ravel() * spacing[0], shape.sum(axis=1).ravel() * spacing[1],
                           shape.sum(axis=0).ravel() * spacing[2]])


def _cmap_rgb(cmap, t):
    """RGB at ``t`` in [0, 1] of ``cmap`` (None: the default colormap, as :func:`_cmap_colors`)."""
    return _cmap_colors(None)(t) if cmap is None else colormap_rgb(cmap, t)


def _cmap_colors(cmap):
    """``cmap`` as given (a user's colormap is used whole), or for ``None`` the
    default colormap without its darkest part."""
    if cmap is not None:
        return cmap

    def start_above_black(t):
        return colormap_rgb(DEFAULT_CMAP, _CMAP_START + (1.0 - _CMAP_START) * np.asarray(t))
    return start_above_black
