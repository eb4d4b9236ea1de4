"""Blinn-Phong shading settings, converted once for the kernels (``_shading_kernels``)."""
from __future__ import annotations

import math

import numpy as np

from . import _shading_kernels as SK


def shading_arrays(opts, spacing, *, unit=None, sampled=None):
    """``(shading, lights)``: the Blinn-Phong settings of ``opts`` as the kernels read them
    (float64; placeholders when ``opts.shade`` is off).

    ``spacing`` is the grid's (x, y, z) spacing, whose smallest entry is also the
    length over which ``shade_threshold`` is measured (``unit``, where given: a
    rectilinear grid's narrowest cell); tetrahedral meshes pass a typical cell size on
    all three axes. ``sampled``: whether the gradient is sampled at each sample
    (default ``opts.shade_gradient == "sampled"``) or interpolated from the points'.
    """
    shading = np.zeros(SK.SHADING_SIZE)
    lights = np.zeros((1, SK.LIGHT_COLUMNS))
    if not opts.shade:
        return shading, lights
    spacing = np.asarray(spacing, dtype=np.float64)
    shading[SK.SH_AMBIENT] = opts.ambient
    shading[SK.SH_DIFFUSE] = opts.diffuse
    shading[SK.SH_SPECULAR] = opts.specular
    shading[SK.SH_POWER] = opts.specular_power
    # |grad a| / axis range * length / threshold reaches 1 at full strength
    unit = float(spacing.min()) if unit is None else float(unit)
    shading[SK.SH_FADE] = unit / opts.shade_threshold if opts.shade_threshold > 0 else math.inf
    shading[SK.SH_SAMPLED] = float(opts.shade_gradient == "sampled" if sampled is None else sampled)
    shading[SK.SH_SPACING:SK.SH_SPACING + 3] = spacing
    shading[SK.SH_INV_SPACING:SK.SH_INV_SPACING + 3] = 1.0 / spacing
    lights = np.zeros((len(opts.light_list), SK.LIGHT_COLUMNS))
    for k, light in enumerate(opts.light_list):
        if light.is_headlight:
            lights[k, 6] = 1.0
        else:
            lights[k, :3] = light.unit_direction
        lights[k, 3:6] = light.intensity
    return shading, lights


def shading_metadata(opts):
    """The shading settings of ``opts`` for an image's metadata."""
    return {"ambient": opts.ambient, "diffuse": opts.diffuse, "specular": opts.specular,
            "specular_power": opts.specular_power, "shade_gradient": opts.shade_gradient,
            "shade_threshold": opts.shade_threshold,
            "lights": [{"direction": light.direction, "intensity": list(light.intensity)}
                       for light in opts.light_list]}
