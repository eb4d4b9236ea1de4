"""Render options shared by every front end (Python, PyVista, VTK, ParaView, CLI).

One frozen dataclass validates once in ``__post_init__`` and converts itself once into
the kernel's parameter tuple, so each name has one meaning everywhere.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Optional

from ._validate import as_choice, as_int, as_real

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
