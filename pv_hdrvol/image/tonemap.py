r"""Tone mapping: show an HDR image on an 8-bit display.

Every operator maps world luminance ``L`` (Rec. 709 luminance of the linear,
premultiplied RGB, that is the image over black) to display luminance ``Ld``; colour
follows by the luminance-ratio rule with a saturation exponent ``s``,

.. math:: C_d = \left(\frac{C}{L}\right)^{s} L_d ,

and the result is encoded for the display (sRGB by default) and clipped to [0, 1].
``knee`` instead scales the colour by its largest channel's mapping, so hue and chroma
are kept, and is shown unencoded by default: it is the display of colour-map colours,
which are display values already, as ParaView's and VTK's volume mappers show them.

Operators (a name, an :class:`Operator` instance, or any callable ``f(L) -> Ld``):

========== ======= ==========================================================
name       kind    method
========== ======= ==========================================================
linear     global  exposure in stops, clamp
gamma      global  as ``linear``, with a pure power-law display encoding
knee       global  colours as they are up to a knee, a shoulder above it; hue kept
reinhard   global  photographic tone reproduction (Reinhard et al. 2002)
reinhard   local   ``local=True``: dodging and burning, centre-surround scales
drago      global  adaptive logarithmic mapping (Drago et al. 2003)
durand     local   bilateral base/detail split (Durand & Dorsey 2002)
fattal     local   gradient-domain compression (Fattal et al. 2002)
========== ======= ==========================================================

Image-dependent parameters (log-average, maxima, base range, gradient scale) are fitted
on a region of interest (``roi=``) when one is given, so detail there is kept best.
Global operators are invertible: :meth:`ToneMapped.inverse` maps displayed values back
to the HDR values they came from.

Handling of special pixels, for every operator: ``L = 0`` maps to black; a NaN in any
channel gives black and is left out of every statistic; ``L = +inf`` gives white and is
left out of the statistics; negative channels are treated as 0.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable, Optional

import numpy as np

from . import _tonemap_kernels as K
from .display import LUMINANCE_WEIGHTS, srgb_decode

_LUTS = {}


def _encoding_lut(gamma):
    """The cached encoding table: sRGB for ``gamma=None``, else ``x**(1/gamma)``."""
    if gamma not in _LUTS:
        if len(_LUTS) > 16:
            _LUTS.clear()
        _LUTS[gamma] = K.encoding_lut(gamma)
    return _LUTS[gamma]


# -- operators ----------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Operator:
    """Base class: parameters of one tone-mapping operator (frozen, validated).

    Subclasses implement ``_fit(L, use)`` (statistics from the pixels ``use`` selects) or
    override ``fit``, and either ``_curve(stats) -> (code, params)`` with ``_inverse``
    (global operators, evaluated in the fused kernel) or ``_map(L, fitted) -> Ld``
    (local operators).
    """

    saturation: float = 1.0
    name = "operator"
    is_global = True

    def __post_init__(self):
        _check_positive("saturation", self.saturation)

    def fit(self, luminance, weights=None):
        """Fitted state for world luminance ``luminance`` (rows, cols), optionally weighted."""
        y = np.asarray(luminance, dtype=np.float64)
        return Fitted(self, self._fit(y, _in_roi(np.isfinite(y) & (y > 0), weights)), weights)

    def _fit(self, y, use):
        return {}


class Fitted:
    """An operator with its image statistics: maps luminance; inverts if global."""

    def __init__(self, operator, stats, weights=None, layers=None):
        self.operator = operator
        self.stats = stats
        self.weights = weights
        # (luminance array, intermediate layers) of the fit, reused when the same array
        # is mapped next (local operators filter the image once, not twice)
        self._layers = layers

    def layers_of(self, y):
        """The fit's intermediate layers if ``y`` is the very array that was fitted."""
        if self._layers is not None and self._layers[0] is y:
            return self._layers[1]
        return None

    def __repr__(self):
        stats = ", ".join(f"{k}={v:.4g}" for k, v in self.stats.items() if isinstance(v, float))
        return f"Fitted({self.operator!r}; {stats})"

    @property
    def is_global(self):
        return self.operator.is_global

    def curve(self):
        """``(code, params)`` of a global operator for the fused kernel."""
        return self.operator._curve(self.stats)

    def display_luminance(self, luminance):
        """Display luminance (linear, before clipping) of world luminance (rows, cols)."""
        y = np.asarray(luminance, dtype=np.float64)
        if self.is_global:
            code, p = self.curve()
            out = np.empty(y.size)
            K.map_luminance(np.ascontiguousarray(y).reshape(-1), code, p, out)
            return out.reshape(y.shape)
        return self.operator._map(y, self)

    def inverse_luminance(self, display_luminance):
        """World luminance that maps to ``display_luminance`` (global operators only)."""
        if not self.is_global:
            raise TypeError(f"{self.operator.name} (local) has no inverse: a displayed value depends on the "
                            f"pixel's neighbourhood; only global operators are invertible")
        return self.operator._inverse(np.asarray(display_luminance, dtype=np.float64), self.stats)


@dataclasses.dataclass(frozen=True)
class Linear(Operator):
    """Scale by ``2**exposure_stops`` and clamp (the baseline).

    ``exposure_stops=None`` fits the exposure that brings the ``percentile`` of luminance
    (in the region of interest) to 1.

    Examples
    --------
    >>> import numpy as np
    >>> fit = Linear(exposure_stops=1.0).fit(np.array([[0.25]]))
    >>> float(fit.display_luminance(np.array([[0.25]]))[0, 0])
    0.5
    """

    exposure_stops: Optional[float] = None
    percentile: float = 99.0
    name = "linear"

    def __post_init__(self):
        super().__post_init__()
        if self.exposure_stops is not None:
            _check_finite("exposure_stops", self.exposure_stops)
        if not 0.0 < self.percentile <= 100.0:
            raise ValueError(f"percentile must be in (0, 100]; got {self.percentile!r}")

    def _fit(self, y, use):
        if self.exposure_stops is not None:
            return {"scale": 2.0 ** float(self.exposure_stops)}
        ref = float(np.percentile(y[use], self.percentile)) if use.any() else 1.0
        return {"scale": 1.0 / ref}

    def _curve(self, stats):
        return K.LINEAR, np.array([stats["scale"]])

    def _inverse(self, ld, stats):
        return ld / stats["scale"]


@dataclasses.dataclass(frozen=True)
class Gamma(Linear):
    """:class:`Linear` with a pure power-law display encoding ``x**(1/gamma)`` (not sRGB)."""

    gamma: float = 2.2
    name = "gamma"

    def __post_init__(self):
        super().__post_init__()
        _check_positive("gamma", self.gamma)


@dataclasses.dataclass(frozen=True)
class Knee(Operator):
    r"""Colours as they are up to ``knee``, compressed above it, hue and chroma kept.

    With :math:`m` the largest channel after the exposure :math:`2^{\text{stops}}`, the
    colour is scaled by :math:`g(m) / m`, where :math:`g(m) = m` for :math:`m \le k`
    and :math:`g(m) = k + (1 - k)(1 - e^{-(m - k)/(1 - k)})` above: slope 1 at the
    knee, approaching 1, so values beyond the display range keep their hue and an
    order among themselves instead of clipping channel by channel.

    This is the display of a composite of colour-map colours: those colours are
    display (sRGB-encoded) values, and ParaView's and VTK's volume mappers composite
    and show them without encoding, so its default encoding is ``"linear"``. Where no
    channel exceeds ``knee`` the picture is the composite itself, as those mappers
    show it.

    Examples
    --------
    >>> import numpy as np
    >>> op = Knee(knee=0.8)
    >>> [round(float(v), 4) for v in op.fit(np.ones((1, 3))).display_luminance(np.array([[0.5, 0.8, 1.0]]))[0]]
    [0.5, 0.8, 0.9264]
    """

    exposure_stops: float = 0.0
    knee: float = 0.8
    name = "knee"

    def __post_init__(self):
        super().__post_init__()
        _check_finite("exposure_stops", self.exposure_stops)
        if not 0.0 < self.knee < 1.0:
            raise ValueError(f"knee must be in (0, 1): the display value where compression begins; "
                             f"got {self.knee!r}")
        if self.saturation != 1.0:
            raise ValueError(f"knee keeps each colour's hue and chroma: its saturation is 1; got {self.saturation!r}")

    def _fit(self, y, use):
        return {"scale": 2.0 ** float(self.exposure_stops)}

    def _curve(self, stats):
        return K.KNEE, np.array([stats["scale"], float(self.knee)])

    def _inverse(self, ld, stats):
        k = float(self.knee)
        ld = np.asarray(ld, dtype=np.float64)
        with np.errstate(divide="ignore"):
            above = k - (1.0 - k) * np.log1p(-(np.minimum(ld, 1.0) - k) / (1.0 - k))
        return np.where(ld <= k, ld, above) / stats["scale"]


@dataclasses.dataclass(frozen=True)
class Reinhard(Operator):
    r"""Photographic tone reproduction (Reinhard, Stark, Shirley & Ferwerda 2002).

    Global: :math:`L_m = a L / \bar L_w` with :math:`\bar L_w` the log-average luminance,
    then :math:`L_d = L_m (1 + L_m / L_{white}^2) / (1 + L_m)`. ``white=None`` takes the
    largest :math:`L_m` (so nothing in the region of interest clips); ``white=inf`` gives
    :math:`L_m / (1 + L_m)`.

    Local (``local=True``): dodging and burning. At each pixel the centre-surround
    activity :math:`V(s) = (V_1(s) - V_2(s)) / (2^\phi a / s^2 + V_1(s))` is computed for
    scales :math:`s = 1.6^i`, :math:`V_1, V_2` being Gaussian averages of :math:`L_m` with
    :math:`\sigma = \alpha_{1,2} s / \sqrt 2`, :math:`\alpha_1 = 1/(2\sqrt2)`,
    :math:`\alpha_2 = 1.6 \alpha_1`; the largest scale with :math:`|V| < \epsilon` is
    used, :math:`L_d = L_m / (1 + V_1(s_m))`.

    References
    ----------
    E. Reinhard, M. Stark, P. Shirley, J. Ferwerda, "Photographic tone reproduction for
    digital images", ACM TOG 21(3), 2002.

    Examples
    --------
    >>> import numpy as np
    >>> fit = Reinhard(key=0.18, white=np.inf).fit(np.array([[1.0]]))  # log-average 1
    >>> round(float(fit.display_luminance(np.array([[1.0]]))[0, 0]), 6)  # 0.18 / 1.18
    0.152542
    """

    key: float = 0.18
    white: Optional[float] = None
    local: bool = False
    phi: float = 8.0
    epsilon: float = 0.05
    scales: int = 8
    name = "reinhard"

    def __post_init__(self):
        super().__post_init__()
        _check_positive("key", self.key)
        if self.white is not None:
            _check_positive("white", self.white, allow_inf=True)
        _check_positive("phi", self.phi)
        _check_positive("epsilon", self.epsilon)
        if not isinstance(self.scales, (int, np.integer)) or not 1 <= self.scales <= 16:
            raise ValueError(f"scales must be an integer in 1..16; got {self.scales!r}")
        object.__setattr__(self, "is_global", not self.local)

    def fit(self, luminance, weights=None):
        y = np.asarray(luminance, dtype=np.float64)
        log_avg, peak = _log_average_and_max(y, weights)
        a = self.key / log_avg
        white = a * peak if self.white is None else float(self.white)
        return Fitted(self, {"log_average": log_avg, "scale": a, "white": white}, weights)

    def _curve(self, stats):
        w = stats["white"]
        return K.REINHARD, np.array([stats["scale"], 0.0 if math.isinf(w) else 1.0 / (w * w)])

    def _inverse(self, ld, stats):
        # solve Ld (1 + Lm) = Lm + Lm^2 / W^2 for Lm >= 0
        ld = np.clip(ld, 0.0, None)
        w = stats["white"]
        with np.errstate(divide="ignore", invalid="ignore"):
            if math.isinf(w):
                lm = np.where(ld < 1.0, ld / (1.0 - ld), np.inf)
            else:
                c = 1.0 / (w * w)
                b = 1.0 - ld
                lm = 2.0 * ld / (b + np.sqrt(b * b + 4.0 * c * ld))  # stable root of c x^2 + b x - ld
        return lm / stats["scale"]

    def _map(self, y, fitted):
        from .filters import gaussian_blur

        lm = np.where(np.isfinite(y) & (y > 0), y, 0.0) * fitted.stats["scale"]
        alpha1 = 1.0 / (2.0 * math.sqrt(2.0))
        scales = 1.6 ** np.arange(self.scales + 1)
        blurred = [gaussian_blur(lm, alpha1 * s / math.sqrt(2.0)) for s in scales]
        v1_chosen = blurred[0].copy()
        undecided = np.ones(lm.shape, dtype=bool)
        for i in range(self.scales):
            s = scales[i]
            v1, v2 = blurred[i], blurred[i + 1]  # surround = centre at the next scale (1.6 s)
            activity = (v1 - v2) / (2.0 ** self.phi * self.key / (s * s) + v1)
            ok = undecided & (np.abs(activity) < self.epsilon)
            v1_chosen[ok] = v1[ok]
            undecided &= ok  # stop at the first scale where the activity exceeds epsilon
        return lm / (1.0 + v1_chosen)


@dataclasses.dataclass(frozen=True)
class Drago(Operator):
    r"""Adaptive logarithmic mapping (Drago, Myszkowski, Annen & Chiba 2003).

    .. math:: L_d = \frac{0.01\, L_{d,max}}{\log_{10}(L_{w,max} + 1)}
              \frac{\ln(L_w + 1)}{\ln\left(2 + 8 (L_w / L_{w,max})^{\ln b / \ln 0.5}\right)}

    with :math:`L_w = 2^{stops} L / L_{wa}`, :math:`L_{wa}` the log-average (world
    adaptation) luminance and :math:`L_{w,max}` the largest :math:`L_w`, both from the
    region of interest. ``bias`` :math:`b` (0.7..0.9 in the paper) steers contrast in
    the dark; ``display_max`` :math:`L_{d,max}` is the display's peak in cd/m² (100:
    :math:`L_{w,max}` maps to 1). For wide ranges the formula peaks below
    :math:`L_{w,max}` (decades below, on 16-decade data) and then falls; the curve is
    held at its peak so it stays monotone and invertible.

    References
    ----------
    F. Drago, K. Myszkowski, T. Annen, N. Chiba, "Adaptive logarithmic mapping for
    displaying high contrast scenes", Computer Graphics Forum 22(3), 2003.

    Examples
    --------
    >>> import numpy as np
    >>> y = np.array([[0.5, 2.0]])
    >>> fit = Drago().fit(y)
    >>> round(float(fit.display_luminance(y).max()), 12)  # L_w,max maps to display_max / 100 here
    1.0
    """

    bias: float = 0.85
    display_max: float = 100.0
    exposure_stops: float = 0.0
    name = "drago"

    def __post_init__(self):
        super().__post_init__()
        if not 0.0 < self.bias < 1.0:
            raise ValueError(f"bias must be in (0, 1); got {self.bias!r}")
        _check_positive("display_max", self.display_max)
        _check_finite("exposure_stops", self.exposure_stops)

    def fit(self, luminance, weights=None):
        y = np.asarray(luminance, dtype=np.float64)
        lwa, peak = _log_average_and_max(y, weights)
        scale = 2.0 ** self.exposure_stops / lwa
        return Fitted(self, {"log_average": lwa, "scale": scale, "max": scale * peak}, weights)

    def _curve(self, stats):
        lmax = stats["max"]
        c = 0.01 * self.display_max / math.log10(lmax + 1.0)
        k = math.log(self.bias) / math.log(0.5)
        # the formula peaks below lmax (by decades when the range is wide) and then falls:
        # find the peak (scaled luminance); the kernel holds the curve there
        def value(t):  # the formula at lw = lmax * 10**t
            return np.log1p(lmax * 10.0 ** t) / np.log(2.0 + 8.0 * 10.0 ** (k * t))

        grid = np.linspace(-40.0, 3.0, 4301)  # the peak falls decades below lmax for wide ranges
        i = int(np.argmax(value(grid)))
        lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
        for _ in range(60):  # golden-section refinement of the peak (to ~1e-14 of a decade)
            a, b = hi - 0.618034 * (hi - lo), lo + 0.618034 * (hi - lo)
            if value(a) < value(b):
                lo = a
            else:
                hi = b
        peak = lmax * 10.0 ** (0.5 * (lo + hi))
        return K.DRAGO, np.array([stats["scale"], lmax, k, c, peak])

    def _inverse(self, ld, stats):
        # monotone up to the peak: bisection on ln L, 80 halvings; values at or above
        # the peak come back as the peak (clipped)
        code, p = self._curve(stats)
        ld = np.asarray(ld, dtype=np.float64)
        lo = np.full(ld.shape, math.log(p[4] / stats["scale"]) - 140.0)
        hi = np.full(ld.shape, math.log(p[4] / stats["scale"]))
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            out = np.empty(mid.size)
            K.map_luminance(np.exp(mid).reshape(-1), code, p, out)
            below = out.reshape(mid.shape) < ld
            lo = np.where(below, mid, lo)
            hi = np.where(below, hi, mid)
        y = np.exp(0.5 * (lo + hi))
        return np.where(ld > 0, y, 0.0)


@dataclasses.dataclass(frozen=True)
class Durand(Operator):
    r"""Fast bilateral filtering (Durand & Dorsey 2002).

    Log luminance is split into a base layer (a bilateral filter: ``sigma_spatial``
    pixels, ``sigma_range`` in log10 units; :func:`~pv_hdrvol.image.filters.bilateral_grid`)
    and a detail layer; only the base is compressed, to ``target_contrast`` over its range
    in the region of interest, whose brightest base maps to 1:

    .. math:: \log_{10} L_d = (B - B_{max}) \min\left(1, \frac{\log_{10} c}{B_{max} - B_{min}}\right)
              + (\log_{10} L - B)

    (the factor is capped at 1: a base within the target contrast is not expanded).

    ``sigma_spatial=None`` is 2% of the larger image side, as in the paper.

    References
    ----------
    F. Durand, J. Dorsey, "Fast bilateral filtering for the display of high-dynamic-range
    images", ACM TOG 21(3), 2002.
    """

    sigma_spatial: Optional[float] = None
    sigma_range: float = 0.4
    target_contrast: float = 50.0
    name = "durand"
    is_global = False

    def __post_init__(self):
        super().__post_init__()
        if self.sigma_spatial is not None:
            _check_positive("sigma_spatial", self.sigma_spatial)
        _check_positive("sigma_range", self.sigma_range)
        if not self.target_contrast > 1.0 or math.isinf(self.target_contrast):
            raise ValueError(f"target_contrast must be a finite ratio > 1; got {self.target_contrast!r}")

    def _layers(self, y):
        from .filters import bilateral_grid

        log_y, valid = _filled_log10(y)
        sigma_s = self.sigma_spatial if self.sigma_spatial is not None else 0.02 * max(y.shape)
        base = bilateral_grid(log_y, max(sigma_s, 1.0), self.sigma_range)
        return log_y, base, valid

    def fit(self, luminance, weights=None):
        y = np.asarray(luminance, dtype=np.float64)
        log_y, base, valid = self._layers(y)
        use = _in_roi(valid, weights)
        if use.any():
            bmin, bmax = float(base[use].min()), float(base[use].max())
        else:
            bmin = bmax = 0.0
        return Fitted(self, {"base_min": bmin, "base_max": bmax}, weights, (y, (log_y, base, valid)))

    def _map(self, y, fitted):
        stats = fitted.stats
        log_y, base, valid = fitted.layers_of(y) or self._layers(y)
        span = stats["base_max"] - stats["base_min"]
        # compress only: a base already within the target contrast keeps its contrast
        # (a flat base, up to the filter's rounding, is not blown up to the target)
        factor = min(1.0, math.log10(self.target_contrast) / span) if span > 0 else 1.0
        out = (base - stats["base_max"]) * factor + (log_y - base)
        return np.where(valid, 10.0 ** out, np.where(y == np.inf, np.inf, 0.0))


@dataclasses.dataclass(frozen=True)
class Fattal(Operator):
    r"""Gradient-domain compression (Fattal, Lischinski & Werman 2002).

    Gradients of :math:`H = \ln L` are scaled by
    :math:`\Phi = \prod_k \varphi_k`, :math:`\varphi_k = (\alpha/\|\nabla H_k\|)
    (\|\nabla H_k\|/\alpha)^\beta` over a Gaussian pyramid, and the image is
    reintegrated by solving the Poisson equation with Neumann boundaries (DCT);
    see :func:`~pv_hdrvol.image.gradient_domain.compress_log_luminance`. ``alpha`` is
    relative to the mean gradient magnitude (of the region of interest); ``beta`` < 1
    compresses. The result is anchored so the ``percentile`` of the region of interest
    maps to 1. The paper recommends ``saturation`` 0.4 to 0.6.

    References
    ----------
    R. Fattal, D. Lischinski, M. Werman, "Gradient domain high dynamic range
    compression", ACM TOG 21(3), 2002.
    """

    saturation: float = 0.6
    alpha: float = 0.1
    beta: float = 0.85
    percentile: float = 99.5
    name = "fattal"
    is_global = False

    def __post_init__(self):
        super().__post_init__()
        _check_positive("alpha", self.alpha)
        if not 0.0 < self.beta <= 1.0:
            raise ValueError(f"beta must be in (0, 1]; got {self.beta!r}")
        if not 0.0 < self.percentile <= 100.0:
            raise ValueError(f"percentile must be in (0, 100]; got {self.percentile!r}")

    def _compressed(self, y, weights):
        from .gradient_domain import compress_log_luminance

        log_y, valid = _filled_log10(y)
        w = None if weights is None else np.where(valid, weights, 0.0)
        return compress_log_luminance(log_y * math.log(10.0), self.alpha, self.beta, weights=w), valid

    def fit(self, luminance, weights=None):
        y = np.asarray(luminance, dtype=np.float64)
        h, valid = self._compressed(y, weights)
        use = _in_roi(valid, weights)
        ref = float(np.percentile(h[use], self.percentile)) if use.any() else 0.0
        return Fitted(self, {"reference": ref}, weights, (y, (h, valid)))

    def _map(self, y, fitted):
        h, valid = fitted.layers_of(y) or self._compressed(y, fitted.weights)
        return np.where(valid, np.exp(h - fitted.stats["reference"]), np.where(y == np.inf, np.inf, 0.0))


@dataclasses.dataclass(frozen=True)
class Curve(Operator):
    """A user's global curve ``function(L) -> Ld`` (vectorised over numpy arrays).

    Invertible when ``inverse(Ld) -> L`` is given.
    """

    function: Optional[Callable] = None
    inverse: Optional[Callable] = None
    name = "curve"

    def __post_init__(self):
        super().__post_init__()
        if not callable(self.function):
            raise TypeError(f"function must be callable; got {type(self.function).__name__}")

    def fit(self, luminance, weights=None):
        return _CurveFitted(self, {}, weights)


class _CurveFitted(Fitted):
    def display_luminance(self, luminance):
        y = np.asarray(luminance, dtype=np.float64)
        out = np.asarray(self.operator.function(np.where(y > 0, y, 0.0)), dtype=np.float64)
        if out.shape != y.shape:
            raise ValueError(f"the tone curve returned shape {out.shape} for luminance of shape {y.shape}")
        return out

    def curve(self):
        return None

    def inverse_luminance(self, display_luminance):
        if self.operator.inverse is None:
            raise TypeError("this curve has no inverse: pass Curve(function, inverse=...)")
        return np.asarray(self.operator.inverse(np.asarray(display_luminance, dtype=np.float64)), dtype=np.float64)


#: How an exposure control, in stops (0: the operator's default), sets each global
#: operator's parameters: the viewers' exposure sliders (Reinhard has no exposure: its
#: key, 0.18 by default, scales instead).
EXPOSURE_PARAMETERS = {
    "reinhard": lambda stops: {"key": 0.18 * 2.0 ** stops},
    "drago": lambda stops: {"exposure_stops": stops},
    "linear": lambda stops: {"exposure_stops": stops},
    "gamma": lambda stops: {"exposure_stops": stops},
    "knee": lambda stops: {"exposure_stops": stops},
}

OPERATORS = {"linear": Linear, "gamma": Gamma, "knee": Knee, "reinhard": Reinhard, "drago": Drago,
             "durand": Durand, "fattal": Fattal}


def make_operator(operator="reinhard", **params):
    """An :class:`Operator` from a name (with parameters), an instance, or a callable."""
    if isinstance(operator, Operator):
        return dataclasses.replace(operator, **params) if params else operator
    if isinstance(operator, str):
        if operator not in OPERATORS:
            raise ValueError(f"operator must be one of {sorted(OPERATORS)} or a callable; got {operator!r}")
        cls = OPERATORS[operator]
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(params) - names)
        if unknown:
            raise TypeError(f"{operator} takes parameters {sorted(names)}; got unknown {unknown}")
        return cls(**params)
    if callable(operator):
        return Curve(function=operator, **params)
    raise TypeError(f"operator must be a name, an Operator or a callable; got {type(operator).__name__}")


# -- the result ---------------------------------------------------------------------------
class ToneMapped:
    """A tone-mapped picture and how it was made.

    Attributes
    ----------
    rgb : ndarray, shape (rows, cols, 3), float32
        Display-encoded values in [0, 1] (row 0 at the top).
    fitted : Fitted
        The operator with the statistics it used.
    encoding : str or float
        ``"srgb"``, ``"linear"``, or a gamma.
    """

    def __init__(self, rgb, fitted, encoding):
        self.rgb = rgb
        self.fitted = fitted
        self.encoding = encoding

    @property
    def operator(self):
        return self.fitted.operator

    @property
    def rgb8(self):
        """8-bit display values (rows, cols, 3), uint8."""
        return np.round(self.rgb * 255.0).astype(np.uint8)

    def __array__(self, dtype=None, copy=None):
        return self.rgb if dtype is None else self.rgb.astype(dtype)

    def __repr__(self):
        r, c = self.rgb.shape[:2]
        return f"ToneMapped({c}x{r}, {self.fitted!r}, encoding={self.encoding!r})"

    def inverse(self, display=None):
        """HDR linear RGB that maps to ``display`` (default: this picture).

        Parameters
        ----------
        display : ndarray (..., 3), float in [0, 1] or uint8, optional
            Display-encoded values, as in :attr:`rgb` or :attr:`rgb8`.

        Returns
        -------
        ndarray (..., 3), float64
            Linear RGB. Values that clipped at 1 come back as the smallest HDR value
            that clips, a lower bound (``knee`` approaches 1 without reaching it: a
            channel shown at 1 comes back infinite).

        Raises
        ------
        TypeError
            For local operators (Reinhard local, Durand, Fattal), which have no inverse.
        """
        d = self.rgb if display is None else np.asarray(display)
        if d.shape[-1:] != (3,):
            raise ValueError(f"display must have shape (..., 3); got {d.shape}")
        d = d.astype(np.float64) / 255.0 if d.dtype == np.uint8 else d.astype(np.float64)
        lin = _decode(d, self.encoding)
        if isinstance(self.operator, Knee):  # the largest channel was mapped, the ratios kept
            md = lin.max(axis=-1)
            m = self.fitted.inverse_luminance(md)
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.where(md[..., None] > 0, lin * (m / md)[..., None], 0.0)
        s = self.operator.saturation
        # colour rule C_d = (C/L)^s Ld with lum(C) = L gives Ld = (sum_c w_c C_d,c^(1/s))^s
        ld = np.power(np.power(lin, 1.0 / s) @ LUMINANCE_WEIGHTS, s)
        y = self.fitted.inverse_luminance(ld)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(ld[..., None] > 0, np.power(lin / ld[..., None], 1.0 / s), 0.0)
        return ratio * y[..., None]

    def save_png(self, path):
        """Write :attr:`rgb8` as a PNG."""
        from .io import write_png

        write_png(path, self.rgb8)

    def _repr_png_(self):
        import io

        from .io import write_png

        buf = io.BytesIO()
        write_png(buf, self.rgb8)
        return buf.getvalue()


# -- the function -------------------------------------------------------------------------
def fit(image, operator="reinhard", *, roi=None, **params):
    """The statistics ``operator`` takes from ``image`` (its :class:`Fitted`), to map
    another image the same way: ``tonemap(other, fitted=fit(image, ...))``. A scene
    fits on the volume's render without the meshes in front, so that a mesh changes
    only the pixels it covers. ``image``, ``operator``, ``roi`` and ``**params``: as
    :func:`tonemap`."""
    pixels = _as_pixels(image)
    op = make_operator(operator, **params)
    return op.fit(_luminance(pixels), _roi_weights(roi, pixels.shape[:2]))


def _luminance(pixels):
    """Luminance (rows, cols) float64 of (rows, cols, 3 or 4) linear pixels."""
    flat = np.ascontiguousarray(pixels).reshape(-1, pixels.shape[2])
    y = np.empty(flat.shape[0])
    K.luminance(flat, y)
    return y.reshape(pixels.shape[:2])


def default_encoding(op):
    """The display encoding an operator implies: the ``gamma`` operator's gamma,
    ``"linear"`` for ``knee`` (colour-map colours are display values already), else
    ``"srgb"``."""
    if isinstance(op, Gamma):
        return float(op.gamma)
    if isinstance(op, Knee):
        return "linear"
    return "srgb"


def tonemap(image, operator="reinhard", *, roi=None, encoding=None, fitted=None, **params):
    """Tone map an HDR image for display.

    Parameters
    ----------
    image : HDRImage or ndarray, shape (rows, cols, 3 or 4)
        Linear (premultiplied) colour; alpha is ignored (the image over black).
    operator : str, Operator or callable
        ``"linear"``, ``"gamma"``, ``"knee"``, ``"reinhard"``, ``"drago"``, ``"durand"``,
        ``"fattal"``, an :class:`Operator`, or ``f(L) -> Ld`` on luminance arrays.
    roi : (col, row, radius) or ndarray of bool (rows, cols), optional
        Region of interest in pixels: the operator fits its parameters there.
    encoding : "srgb", "linear", float or None
        Display encoding; a float is a gamma (``x**(1/gamma)``). None (default): the
        operator's own (:func:`default_encoding`): sRGB, the ``gamma`` operator's
        ``gamma``, ``"linear"`` for ``knee``.
    fitted : Fitted, optional
        Reuse the statistics of an earlier fit (consistent mapping across frames).
    **params
        Operator parameters (``exposure_stops=``, ``key=``, ``bias=``, ``saturation=``...).

    Returns
    -------
    ToneMapped
        ``.rgb`` float32 in [0, 1], ``.rgb8`` uint8, ``.inverse()`` for global operators.

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> img = hv.HDRImage(np.full((1, 2, 4), 1.0, np.float32))
    >>> out = hv.tonemap(img, "linear", exposure_stops=-1.0, encoding="linear")
    >>> out.rgb[0, 0].tolist()
    [0.5, 0.5, 0.5]
    """
    pixels = _as_pixels(image)  # (rows, cols, 3 or 4): the kernels read the first three
    shape = pixels.shape[:2]
    op = make_operator(operator, **params)
    weights = _roi_weights(roi, shape)
    if encoding is None:
        encoding = default_encoding(op)
    elif isinstance(op, Gamma) and encoding == "srgb":  # as before the operator's own default
        encoding = float(op.gamma)
    enc_code, gamma = display_encoding(encoding)
    if fitted is not None and not isinstance(fitted, Fitted):
        raise TypeError(f"fitted must be a Fitted (ToneMapped.fitted); got {type(fitted).__name__}")
    flat = np.ascontiguousarray(pixels).reshape(-1, pixels.shape[2])
    y = None
    if fitted is None or not fitted.is_global:
        y = _luminance(pixels)
    if fitted is None:
        fitted = op.fit(y, weights)
    out = np.empty((flat.shape[0], 3), dtype=np.float32)
    curve = fitted.curve() if fitted.is_global else None
    table = np.empty(0)
    if curve is not None:
        code, p = curve
        ld = np.empty(0)
        if code == K.DRAGO:
            p, table = _drago_table(p)
    else:
        code, p = K.PRECOMPUTED, np.zeros(1)
        ld = np.ascontiguousarray(fitted.display_luminance(y), dtype=np.float64).reshape(-1)
    K.map_pixels(flat, ld, code, p, table, float(fitted.operator.saturation), enc_code, _encoding_lut(gamma), out)
    return ToneMapped(out.reshape(shape + (3,)), fitted, encoding)


# -- helpers ------------------------------------------------------------------------------
def _as_pixels(image):
    """The image's (rows, cols, 3 or 4) float array (RGB first), validated, not copied."""
    rgba = getattr(image, "rgba", None)  # an HDRImage (hdr.py imports this module: no isinstance)
    arr = np.asarray(image) if rgba is None else rgba
    if arr.ndim != 3 or arr.shape[2] not in (3, 4):
        raise ValueError(f"image must be an HDRImage or an array of shape (rows, cols, 3 or 4); got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating):
        raise TypeError(f"image must hold linear floats; got dtype {arr.dtype}")
    if arr.dtype == np.float16:
        arr = arr.astype(np.float32)
    return arr


def _roi_weights(roi, shape):
    """1 inside the region of interest, 0 outside (float64 (rows, cols)); None for no ROI."""
    if roi is None:
        return None
    if isinstance(roi, np.ndarray) and roi.ndim == 2:
        if roi.shape != shape:
            raise ValueError(f"roi mask must have the image's shape {shape}; got {roi.shape}")
        if roi.dtype != np.bool_:
            raise TypeError(f"roi mask must be bool; got dtype {roi.dtype}")
        w = roi.astype(np.float64)
    else:
        try:
            col, row, radius = (float(v) for v in roi)
        except (TypeError, ValueError):
            raise TypeError(f"roi must be (col, row, radius) in pixels or a bool mask; got {roi!r}") from None
        if not radius > 0:
            raise ValueError(f"roi radius must be > 0 pixels; got {radius!r}")
        rr, cc = np.mgrid[0:shape[0], 0:shape[1]]
        w = (((cc - col) ** 2 + (rr - row) ** 2) <= radius * radius).astype(np.float64)
    if not w.any():
        raise ValueError("roi covers no pixel of the image")
    return w


def display_encoding(encoding):
    """``(kernel code, gamma)``: gamma None for sRGB (both read a table)."""
    if isinstance(encoding, str):
        if encoding == "srgb":
            return K.ENC_TABLE, None
        if encoding == "linear":
            return K.ENC_LINEAR, None
        raise ValueError(f"encoding must be 'srgb', 'linear' or a gamma > 0; got {encoding!r}")
    g = float(encoding)
    if not g > 0 or math.isinf(g):
        raise ValueError(f"encoding gamma must be finite and > 0; got {encoding!r}")
    return K.ENC_TABLE, g


def _drago_table(p):
    """Drago's display curve over ``t = ln L_w`` (see ``_tonemap_kernels._display_curve``)."""
    t_hi = math.log(p[4])
    t_lo = t_hi - K.DRAGO_TABLE_DECADES * math.log(10.0)
    t = np.linspace(t_lo, t_hi, K.DRAGO_TABLE_SIZE)
    values = np.empty(t.size)
    K.map_luminance(np.exp(t) / p[0], K.DRAGO, p, values)
    inv_step = (K.DRAGO_TABLE_SIZE - 1) / (t_hi - t_lo)
    return np.concatenate([p, [t_lo, inv_step]]), values


def _decode(d, encoding):
    if encoding == "srgb":
        return srgb_decode(d)
    if encoding == "linear":
        return np.clip(d, 0.0, 1.0)
    return np.power(np.clip(d, 0.0, 1.0), float(encoding))


def _in_roi(valid, weights):
    """The valid pixels inside the region of interest, or all valid pixels when the
    region holds none (or there is no region)."""
    if weights is None:
        return valid
    inside = valid & (weights > 0)
    return inside if inside.any() else valid


def _log_average_and_max(y, weights):
    """``exp(mean(ln L))`` and ``max(L)`` over finite ``L > 0`` (in the region of interest
    when it holds any such pixel); ``(1.0, 1.0)`` for an image without one."""
    flat = np.ascontiguousarray(y).reshape(-1)
    parts = np.empty((64, 3))
    if weights is not None:
        K.log_stats(flat, np.ascontiguousarray(weights, dtype=np.float64).reshape(-1), parts)
        total = parts.sum(axis=0)
        if total[1] > 0:
            return float(np.exp(total[0] / total[1])), float(parts[:, 2].max())
    K.log_stats(flat, np.empty(0), parts)
    total = parts.sum(axis=0)
    if total[1] == 0:
        return 1.0, 1.0
    return float(np.exp(total[0] / total[1])), float(parts[:, 2].max())


def _filled_log10(y):
    """``log10 L`` with non-positive / non-finite pixels set to the smallest valid value.

    Local operators filter the whole image; black pixels (background) take the darkest
    valid level so they do not pull filters towards minus infinity.
    """
    valid = np.isfinite(y) & (y > 0)
    out = np.zeros(y.shape)
    if valid.any():
        logs = np.log10(y[valid])
        out[:] = logs.min()
        out[valid] = logs
    return out, valid


def _check_positive(name, value, allow_inf=False):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number; got {type(value).__name__}")
    if not value > 0 or (math.isinf(value) and not allow_inf):
        raise ValueError(f"{name} must be {'> 0' if allow_inf else 'finite and > 0'}; got {value!r}")


def _check_finite(name, value):
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number; got {type(value).__name__}")
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite; got {value!r}")
