"""Render options shared by every front end (Python, PyVista, VTK, ParaView, CLI).

One frozen dataclass validates once in ``__post_init__`` and converts itself once into
the kernel's parameter tuple, so each name has one meaning everywhere.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ._validate import as_choice, as_int, as_real, as_vector

#: Compositing precisions. ``float64`` and ``float32`` composite in that arithmetic by
#: accumulated opacity, never forming ``1 - alpha``; ``float16`` and ``uint8`` *emulate*
#: the conventional ``over`` operator in half-float and 8-bit buffers, for comparison.
PRECISIONS = ("float64", "float32", "float16", "uint8")

# Integer codes the kernels switch on (see raycast/_kernels.py).
PRECISION_CODES = {"float64": 0, "float32": 1, "float16": 2, "uint8": 3}

#: How samples along a ray combine, by PyVista's ``add_volume(blending=...)`` names:
#: emission-absorption compositing, maximum/minimum intensity projection, the average
#: value, and the additive line integral (an X-ray).
BLENDINGS = ("composite", "maximum", "minimum", "average", "additive")
BLENDING_CODES = {name: i for i, name in enumerate(BLENDINGS)}  # raycast/_kernels_ext.py

#: Where a shaded sample's gradient comes from: central differences of the interpolated
#: field at the sample (``"sampled"``, six more trilinear lookups per sample, no memory),
#: or central differences at the grid points, trilinearly interpolated
#: (``"interpolated"``, three more values per voxel in memory).
SHADE_GRADIENTS = ("sampled", "interpolated")

#: Where a render runs: the numba CPU kernels, or the same kernels on an NVIDIA GPU
#: through numba-cuda (``pv_hdrvol.gpu``).
DEVICES = ("cpu", "cuda")


@dataclass(frozen=True)
class Light:
    """A directional light for :class:`RenderOptions` ``lights``.

    Parameters
    ----------
    direction : "headlight" or sequence of 3 floats
        ``"headlight"``: light from the eye along each ray (the default light). Else the
        world direction from the scene *towards* the light, any non-zero length
        (kept as given; :attr:`unit_direction` is the normalised one).
    intensity : float or sequence of 3 floats
        Linear RGB intensity, ``>= 0``; HDR: values above 1 are kept.

    Examples
    --------
    >>> Light((0, 0, 2)).unit_direction
    (0.0, 0.0, 1.0)
    """

    direction: object = "headlight"
    intensity: object = 1.0

    def __post_init__(self):
        d = self.direction
        if isinstance(d, str):
            as_choice("Light direction", d, ("headlight",))
        else:
            v = as_vector("Light direction", d)
            if not np.any(v):
                raise ValueError(f"Light direction must not be the zero vector; got {d!r}")
            object.__setattr__(self, "direction", tuple(float(x) for x in v))
        i = self.intensity
        if isinstance(i, (int, float, np.integer, np.floating)) and not isinstance(i, bool):
            i = (i, i, i)
        rgb = as_vector("Light intensity", i)
        if np.any(rgb < 0):
            raise ValueError(f"Light intensity must be >= 0; got {self.intensity!r}")
        object.__setattr__(self, "intensity", tuple(float(x) for x in rgb))

    @property
    def is_headlight(self):
        return self.direction == "headlight"

    @property
    def unit_direction(self):
        """The direction towards the light, of length 1 (``None`` for a headlight)."""
        if self.is_headlight:
            return None
        v = np.array(self.direction)
        return tuple(float(x) for x in v / np.sqrt(v @ v))


def as_lights(value):
    """``lights=`` as a tuple of :class:`Light`: a Light, a direction, or a sequence of them."""
    if isinstance(value, Light):
        return (value,)
    if isinstance(value, str):
        return (Light(value),)
    try:
        items = list(value)
    except TypeError:
        raise TypeError(f"lights must be None, a Light, a direction or a sequence of them; got {value!r}") from None
    if len(items) == 3 and all(isinstance(x, (int, float, np.integer, np.floating)) for x in items):
        return (Light(tuple(items)),)  # one direction
    if not items:
        raise ValueError("lights must hold at least one light (None: a headlight)")
    if len(items) > 8:
        raise ValueError(f"at most 8 lights; got {len(items)}")
    return tuple(x if isinstance(x, Light) else Light(x) for x in items)


@dataclass(frozen=True)
class ClipPlane:
    """A clipping plane for :class:`RenderOptions` ``clip_planes``.

    VTK's convention for a mapper's clipping planes (``vtkVolumeMapper.AddClippingPlane``):
    the points ``x`` with ``(x - origin) . normal >= 0`` are kept -- the side the normal
    points to -- and the rest of the volume is cut away.

    Parameters
    ----------
    origin : sequence of 3 floats
        A point of the plane (world coordinates).
    normal : sequence of 3 floats
        Towards the kept side; any non-zero length (kept as given).

    Examples
    --------
    >>> ClipPlane((0, 0, 1), (0, 0, 2)).normal
    (0.0, 0.0, 2.0)
    """

    origin: object = (0.0, 0.0, 0.0)
    normal: object = (0.0, 0.0, 1.0)

    def __post_init__(self):
        o = as_vector("clip plane origin", self.origin)
        n = as_vector("clip plane normal", self.normal)
        if not np.any(n):
            raise ValueError(f"a clip plane's normal must not be the zero vector; got {self.normal!r}")
        # kept as given: the cut depends on its direction only, and a saved plane reads back bit for bit
        object.__setattr__(self, "origin", tuple(float(x) for x in o))
        object.__setattr__(self, "normal", tuple(float(x) for x in n))


#: at most this many clip planes (VTK's GPU mapper takes 6; the kept set stays convex)
MAX_CLIP_PLANES = 32


def _is_vector(value):
    try:
        return len(value) == 3 and all(isinstance(x, (int, float, np.integer, np.floating))
                                       and not isinstance(x, bool) for x in value)
    except TypeError:
        return False


def _one_plane(value):
    """One :class:`ClipPlane` from a ClipPlane, ``(origin, normal)``, a dict of those, a
    ``vtkPlane`` (``GetOrigin``/``GetNormal``), else ``None``."""
    if isinstance(value, ClipPlane):
        return value
    if hasattr(value, "keys"):
        unknown = sorted(set(value) - {"origin", "normal"})
        if unknown:
            raise ValueError(f"a clip plane dict has keys 'origin' and 'normal'; got {sorted(value)}")
        return ClipPlane(**value)
    if callable(getattr(value, "GetOrigin", None)) and callable(getattr(value, "GetNormal", None)):
        return ClipPlane(value.GetOrigin(), value.GetNormal())
    if not isinstance(value, (str, bytes)) and hasattr(value, "__len__") and len(value) == 2 \
            and _is_vector(value[0]) and _is_vector(value[1]):
        return ClipPlane(value[0], value[1])
    return None


def as_clip_planes(value):
    """``clip_planes=`` as a tuple of :class:`ClipPlane`: ``None`` (none), one plane
    (a ClipPlane, ``(origin, normal)``, a ``vtkPlane``), VTK's ``vtkPlanes`` or
    ``vtkPlaneCollection``, or a sequence of planes."""
    if value is None:
        return ()
    one = _one_plane(value)
    if one is not None:
        return (one,)
    if callable(getattr(value, "GetNumberOfPlanes", None)):  # vtkPlanes
        items = [value.GetPlane(i) for i in range(value.GetNumberOfPlanes())]
    elif callable(getattr(value, "GetNumberOfItems", None)) and callable(getattr(value, "GetItem", None)):
        items = [value.GetItem(i) for i in range(value.GetNumberOfItems())]  # vtkPlaneCollection
    elif isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise TypeError(f"clip_planes must be None, a plane (ClipPlane, (origin, normal) or a vtkPlane) or a "
                        f"sequence of planes; got {value!r}")
    else:
        items = list(value)
    if len(items) > MAX_CLIP_PLANES:
        raise ValueError(f"at most {MAX_CLIP_PLANES} clip planes; got {len(items)}")
    planes = []
    for i, item in enumerate(items):
        plane = _one_plane(item)
        if plane is None:
            raise TypeError(f"clip_planes[{i}] must be a ClipPlane, (origin, normal) or a vtkPlane; got {item!r}")
        planes.append(plane)
    return tuple(planes)


def as_crop_box(value):
    """``crop_box=`` as ``(xmin, xmax, ymin, ymax, zmin, zmax)`` floats (VTK's bounds
    order, as ``SetCroppingRegionPlanes``), each ``min < max``; ``None``: no crop."""
    if value is None:
        return None
    if callable(getattr(value, "GetBounds", None)):  # a vtkBox, or a dataset whose bounds crop
        value = value.GetBounds()
    try:
        b = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"crop_box must be (xmin, xmax, ymin, ymax, zmin, zmax); got {value!r}") from None
    if b.shape != (6,):
        raise ValueError(f"crop_box must be 6 numbers (xmin, xmax, ymin, ymax, zmin, zmax); got {value!r}")
    if np.isnan(b).any() or not np.all(b[1::2] > b[0::2]):
        raise ValueError(f"crop_box needs min < max on every axis (infinite ends allowed); got {value!r}")
    return tuple(float(x) for x in b)


#: the options ``tolerance=`` chooses (they must stay at their defaults beside it)
TOLERANCE_KNOBS = ("step", "termination", "precision")


@dataclass(frozen=True)
class RenderOptions:
    """How a volume is sampled and composited.

    Parameters
    ----------
    step : float
        Distance between samples along a ray, in voxels of the smallest spacing.
        Default 0.5. Opacity is defined per unit length, so ``step`` changes the
        picture only by sampling error.
    precision : {"float32", "float64", "float16", "uint8"}
        Arithmetic of compositing, of the transfer-function table and of the output.
        ``float16`` and ``uint8`` emulate 16-bit float and 8-bit frame buffers (the
        table and data are 8 bit too for ``uint8``); they exist to show what those
        buffers lose.
    global_alpha : float
        Multiplier in ``(0, 1]`` applied to every opacity of the transfer function.
        It stays meaningful at 1e-6: compositing accumulates opacity and never forms
        ``1 - alpha``.
    opacity_unit_distance : float or None
        World length over which a transfer-function opacity ``a`` is reached
        (extinction ``sigma = -ln(1 - a) / opacity_unit_distance``). ``None`` means the
        smallest voxel spacing, so opacities read as "per voxel".
    termination : float
        Early ray termination: a ray stops once its transmittance falls below this
        value; the pixel then differs from the exact one by at most
        ``termination * max emission``. ``0`` disables it.
    depth_threshold : float
        Accumulated opacity at which the depth image records the distance. Pixels that
        never reach it have depth ``inf``.
    block_size : int
        Edge, in cells, of the blocks used for empty-space skipping (a power of two,
        default 4). Smaller blocks skip air more tightly but cost more leaps; the
        volume's memory layout (bricks of 8 cells) does not depend on it.
    skip_empty : bool
        Skip blocks whose value range maps to zero opacity. Results are identical with
        and without; only the time changes.
    blending : {"composite", "maximum", "minimum", "average", "additive"}
        ``composite`` (default): emission-absorption. ``maximum``/``minimum``: the
        extreme value along the ray (MIP/MinIP), ``average``: the mean, coloured by the
        transfer function with its opacity over one unit distance; ``additive``: the
        line integral of the value (an X-ray) and of the emission ``c sigma``. The
        projections also return the value itself (:attr:`HDRImage.value`; with
        ``precision="uint8"``, in the 8-bit pipeline's levels 0-255).
    gradient_opacity : (float, float) or None
        Emission-absorption only: scale extinction by a ramp of the gradient magnitude
        ``|grad v|`` (data units per world unit), 0 at the first value and 1 from the
        second on, so homogeneous regions fade and boundaries stand out (Levoy 1988).
        ``None`` (default) computes no gradient.
    shade : bool
        Emission-absorption only: light each sample by Blinn-Phong shading of the
        data's gradient (PyVista's ``add_volume(shade=True)``, ParaView's "Shade"):
        colour ``c (ambient + diffuse sum_l I_l |n.l|) + specular sum_l I_l (n.h)^p``,
        the normal turned towards the eye (two-sided). HDR: nothing is clamped, a
        highlight may exceed 1. Where the gradient is small (homogeneous regions, noise)
        the shading fades out (``shade_threshold``). ``False`` (default) computes no
        gradient and gives the unshaded pixels bit for bit.
    ambient, diffuse, specular : float
        Blinn-Phong weights, each ``>= 0`` (defaults 0.1, 0.7, 0.2: VTK's and PyVista's).
    specular_power : float
        Blinn-Phong exponent ``p``, ``>= 1`` (default 10).
    lights : None, Light, direction, or a sequence of them
        ``None`` (default): one white headlight. A direction (3 floats, from the scene
        towards the light) is a white :class:`Light`; at most 8 lights.
    shade_gradient : {"sampled", "interpolated"}
        How the gradient is formed: central differences of the interpolated field at
        each sample (``"sampled"``, default: six more lookups per sample in the bricks
        the sample already reads, no memory), or central differences at the grid
        points, trilinearly interpolated (three more values per voxel in memory, read
        from three more arrays). For a trilinear field the two are the same function
        (to rounding); ``"sampled"`` measured faster (docs/tradeoffs.md). Tetrahedra
        use each cell's exact, constant gradient.
    shade_threshold : float
        Shading is at full strength where the value changes by at least this fraction
        of the transfer function's axis across one voxel (of the smallest spacing;
        on the axis, so a log axis measures relative change), and fades linearly to
        none where it does not change. Default 0.01; ``0`` shades wherever the gradient
        is non-zero.
    tolerance : float or None
        The accuracy you accept, instead of the knobs: the RMS error of the linear,
        premultiplied RGB image against the converged render (over every pixel and
        channel), relative to the image's brightest value, in ``(0, 0.5]``. The
        renderer then chooses ``step`` (meshes: ``tau_max``), ``termination``, the
        table size and ``precision`` to meet it in the least time it finds: a pilot
        of about 4,096 pixels of the same view rendered at halving steps gives the
        sampling error's order and size (Richardson extrapolation), and the chosen
        termination and table are measured on it against none and the function's own
        (:mod:`pv_hdrvol.raycast.tolerance`). ``step``, ``termination`` and
        ``precision`` must then stay at their defaults. The choices and the estimated
        error are in ``metadata["tolerance"]``. ``None`` (default): the knobs as given.
    clip_planes : plane or sequence of planes
        Cut the volume (grid, mesh or blocks) with planes, VTK's convention: each plane
        keeps the points ``x`` with ``(x - origin) . normal >= 0``. A plane is a
        :class:`ClipPlane`, an ``(origin, normal)`` pair or a ``vtkPlane``; VTK's
        ``vtkPlanes`` and ``vtkPlaneCollection`` give several. The kept set (with
        ``crop_box``) is convex, so each ray keeps one interval ``[near, far]``,
        computed exactly: sampling starts at ``near`` and its last segment ends at
        ``far``, with the opacity of the segment's true length. Default: none.
    crop_box : (xmin, xmax, ymin, ymax, zmin, zmax) or None
        Keep only this world box (VTK's bounds order; a ``vtkBox`` or a dataset gives
        its bounds). Default ``None``: no crop.
    device : {"cpu", "cuda"}
        Where a render runs. ``"cpu"`` (default): the numba CPU kernels. ``"cuda"``:
        the same kernels compiled for an NVIDIA GPU by numba-cuda (``pip install
        'pv_hdrvol[gpu]'``), the data and tables kept on the GPU between renders of a
        plan; equal to the CPU render to rounding. It takes ``float32``/``float64``
        precision; on uniform grids in memory composite (shaded or not), maximum,
        minimum, average and additive blending, clipping, ``far=``, block masks and
        lenses without a level of detail; tetrahedral meshes as on the CPU. Labels,
        gradient opacity, rectilinear grids, level-of-detail lenses and out-of-core
        volumes raise ``ValueError`` (docs/gpu.md). A machine without a usable GPU raises
        :class:`~pv_hdrvol.DeviceUnavailableError` naming what is missing.
    """

    step: float = 0.5
    precision: str = "float32"
    global_alpha: float = 1.0
    opacity_unit_distance: Optional[float] = None
    termination: float = 1e-6
    depth_threshold: float = 0.05
    block_size: int = 4
    skip_empty: bool = True
    blending: str = "composite"
    gradient_opacity: Optional[tuple] = None
    shade: bool = False
    ambient: float = 0.1
    diffuse: float = 0.7
    specular: float = 0.2
    specular_power: float = 10.0
    lights: object = None
    shade_gradient: str = "sampled"
    shade_threshold: float = 0.01
    tolerance: Optional[float] = None
    clip_planes: tuple = ()
    crop_box: Optional[tuple] = None
    device: str = "cpu"

    def __post_init__(self):
        object.__setattr__(self, "step", as_real("step", self.step, low=0, low_open=True))
        if self.step < 1e-4:
            raise ValueError(f"step must be >= 1e-4 voxels; got {self.step!r}")
        as_choice("precision", self.precision, PRECISIONS)
        object.__setattr__(
            self, "global_alpha", as_real("global_alpha", self.global_alpha, low=0, high=1, low_open=True)
        )
        if self.opacity_unit_distance is not None:
            object.__setattr__(
                self,
                "opacity_unit_distance",
                as_real("opacity_unit_distance", self.opacity_unit_distance, low=0, low_open=True),
            )
        object.__setattr__(
            self, "termination", as_real("termination", self.termination, low=0, high=1, high_open=True)
        )
        object.__setattr__(
            self,
            "depth_threshold",
            as_real("depth_threshold", self.depth_threshold, low=0, high=1, low_open=True),
        )
        b = as_int("block_size", self.block_size, low=2, high=256)
        if b & (b - 1):
            raise ValueError(f"block_size must be a power of two; got {self.block_size!r}")
        object.__setattr__(self, "block_size", b)
        if not isinstance(self.skip_empty, bool):
            raise TypeError(f"skip_empty must be a bool; got {self.skip_empty!r}")
        as_choice("blending", self.blending, BLENDINGS)
        if self.gradient_opacity is not None:
            g = self.gradient_opacity
            if isinstance(g, (str, bytes)) or not hasattr(g, "__len__") or len(g) != 2:
                raise TypeError(f"gradient_opacity must be None or (low, high); got {g!r}")
            lo = as_real("gradient_opacity[0]", g[0], low=0)
            hi = as_real("gradient_opacity[1]", g[1], low=0)
            if not hi > lo:
                raise ValueError(f"gradient_opacity must be (low, high) with high > low >= 0; got {g!r}")
            if self.blending != "composite":
                raise ValueError(f"gradient_opacity applies to blending='composite' only; got blending={self.blending!r}")
            object.__setattr__(self, "gradient_opacity", (lo, hi))
        if not isinstance(self.shade, bool):
            raise TypeError(f"shade must be a bool; got {self.shade!r}")
        for name in ("ambient", "diffuse", "specular"):
            object.__setattr__(self, name, as_real(name, getattr(self, name), low=0))
        object.__setattr__(self, "specular_power", as_real("specular_power", self.specular_power, low=1))
        if self.lights is not None:
            object.__setattr__(self, "lights", as_lights(self.lights))
        as_choice("shade_gradient", self.shade_gradient, SHADE_GRADIENTS)
        object.__setattr__(self, "shade_threshold", as_real("shade_threshold", self.shade_threshold, low=0))
        if self.shade and self.blending != "composite":
            raise ValueError(f"shade applies to blending='composite' only; got blending={self.blending!r}")
        if self.tolerance is not None:
            object.__setattr__(self, "tolerance",
                               as_real("tolerance", self.tolerance, low=0, high=0.5, low_open=True))
            chosen = {name: getattr(self, name) for name in TOLERANCE_KNOBS
                      if getattr(self, name) != _DEFAULTS[name]}
            if chosen:
                raise ValueError(f"tolerance= chooses {', '.join(TOLERANCE_KNOBS)}: leave them at their defaults or "
                                 f"drop tolerance; got {', '.join(f'{k}={v!r}' for k, v in chosen.items())}")
        object.__setattr__(self, "clip_planes", as_clip_planes(self.clip_planes))
        object.__setattr__(self, "crop_box", as_crop_box(self.crop_box))
        as_choice("device", self.device, DEVICES)
        if self.device == "cuda" and self.precision not in ("float32", "float64"):
            raise ValueError(f"device='cuda' composites in float32 or float64; got precision={self.precision!r} "
                             "(the float16 and uint8 emulations run on device='cpu')")

    @property
    def light_list(self):
        """The lights of a shaded render: ``lights``, or one white headlight."""
        return self.lights if self.lights is not None else (Light(),)

    def replace(self, **changes):
        """Return a copy with ``changes`` applied (validated again)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_kwargs(cls, options=None, **kwargs):
        """Merge an optional ``RenderOptions`` with keyword overrides.

        Unknown keywords raise ``TypeError`` naming them and the allowed ones.
        """
        if options is not None and not isinstance(options, cls):
            raise TypeError(f"options must be a RenderOptions; got {type(options).__name__}")
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(kwargs) - names)
        if unknown:
            raise TypeError(f"unknown render option(s) {unknown}; allowed: {sorted(names)}")
        base = options if options is not None else cls()
        return dataclasses.replace(base, **kwargs) if kwargs else base


#: the defaults of :class:`RenderOptions` (``tolerance=`` checks its knobs against them)
_DEFAULTS = {f.name: f.default for f in dataclasses.fields(RenderOptions)}
