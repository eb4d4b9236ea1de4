"""
High dynamic range versus an 8-bit pipeline
===========================================

A volume whose values span many decades -- here the SCF total electron density of a
molecule, 16 decades from 2e-17 to 0.49 (``m4_total_density``, a real Gaussian cube
file) -- is rendered twice with the same camera and transfer function:

* in ``float32``, where :func:`pv_hdrvol.raycast` accumulates *optical depth* and
  colour with compensated sums, so a sample whose opacity is 1e-17 still adds its
  exact share of light;
* in the ``uint8`` emulation of a conventional pipeline: data and lookup table
  quantised to 256 entries, and every step of the *over* operator rounded to a
  multiple of 1/255, as an 8-bit frame buffer stores it.

The transfer function is emission-absorption with opacity proportional to the density
on a log axis (0.5 per voxel at the peak), coloured with a magma ramp. The faint outer
density then contributes light many decades below the core. An 8-bit buffer rounds any
per-sample contribution below 0.5/255 to zero, so those regions vanish: no exposure can
bring back what was never stored. The float image keeps them, and each exposure
(``img.exposures([-4, 0, 12])``: stops relative to the automatic exposure, which maps
the 99th percentile of luminance to 1) reveals a different band of decades: -4 stops
shows the core, +12 stops (3.6 decades brighter) the envelope that only the float
image kept.

The figure shows both images at three exposures, as a map of log10 luminance, and as
a histogram of pixel luminance.
When ``../shared/data`` is missing the analytic hydrogen ``3d`` orbital
(:func:`pv_hdrvol.datasets.hydrogen_orbital`) is rendered instead.
"""
import os
import pathlib

import matplotlib.pyplot as plt
import numpy as np

import pv_hdrvol as hv
from pv_hdrvol.data.transfer import colormap_rgb

SIZE = 240
STOPS = [-4, 0, 12]

try:
    HERE = pathlib.Path(__file__).resolve().parent
except NameError:  # executed without a file (e.g. pasted into a console)
    HERE = pathlib.Path.cwd()
REPO = HERE.parent
DATA = REPO.parent / "shared" / "data" / "hdr" / "m4_total_density_25x22x31_float32.vti"

# %%
# Load the volume
# ---------------
if DATA.is_file():
    import pyvista as pv

    grid = pv.read(DATA)
    title = "m4 total density (16 decades)"
else:
    from pv_hdrvol import datasets

    grid = datasets.hydrogen_orbital()
    title = "hydrogen 3d orbital (analytic)"
values = np.asarray(grid.active_scalars)
vmax = float(values.max())
vmin = float(values[values > 0].min())
print(f"{title}: {grid.dimensions} points, values {vmin:.3g} .. {vmax:.3g} "
      f"({np.log10(vmax / vmin):.1f} decades)")

# %%
# Transfer function: opacity proportional to density, on a log axis
# -------------------------------------------------------------------
points = np.logspace(np.log10(vmin), np.log10(vmax), 17)
opacity = 0.5 * points / vmax
opacity[0] = 0.0
colors = colormap_rgb("magma", np.linspace(0.3, 1.0, points.size))  # skip magma's black end
tf = hv.TransferFunction(points, colors, opacity, scale="log")
camera = hv.Camera.fit(grid, "iso")

# %%
# Render in float32 and in the 8-bit emulation
# --------------------------------------------
images = {prec: hv.render(grid, tf, camera, SIZE, precision=prec) for prec in ("float32", "uint8")}
for prec, img in images.items():
    s = img.stats()
    print(f"{prec:>7}: {s['distinct_luminance_levels']:6d} distinct luminance levels, "
          f"{s['dynamic_range_decades']:5.2f} decades, covered fraction {s['covered_fraction']:.3f}, "
          f"peak luminance {s['peak_luminance']:.3f}")

# %%
# Show both at several exposures, and as log10 luminance
# -------------------------------------------------------
# The log-luminance map and the histogram show all decades at once.
ncol = len(STOPS) + 2
fig, axes = plt.subplots(2, ncol, figsize=(3.0 * ncol, 6.4),
                         gridspec_kw={"width_ratios": [1] * (ncol - 1) + [1.3]})
bins = np.linspace(-20, 0.5, 83)
for row, (prec, img) in enumerate(images.items()):
    s = img.stats()
    for col, (stops, rgb) in enumerate(zip(STOPS, img.exposures(STOPS))):
        ax = axes[row, col]
        ax.imshow(rgb)
        ax.set_title(f"{prec}, {stops:+d} stops", fontsize=10)
    y = img.luminance
    ax = axes[row, len(STOPS)]
    with np.errstate(divide="ignore"):
        logy = np.where(y > 0, np.log10(y), np.nan)
    im = ax.imshow(logy, cmap="viridis", vmin=bins[0], vmax=0)
    ax.set_facecolor("black")
    ax.set_title(f"{prec}, log10 luminance", fontsize=10)
    fig.colorbar(im, ax=ax, fraction=0.046, pad=0.04)
    for ax in axes[row, :-1]:
        ax.set_xticks([])
        ax.set_yticks([])
    axes[row, 0].set_ylabel(f"{s['distinct_luminance_levels']} levels, {s['dynamic_range_decades']:.1f} decades")
    ax = axes[row, -1]
    lit = y[y > 0]
    ax.hist(np.log10(lit), bins=bins, color="C0" if row == 0 else "C3")
    ax.set_yscale("log")
    ax.set_xlim(bins[0], bins[-1])
    ax.set_xlabel("log10 pixel luminance")
    ax.set_title(f"{prec}: {lit.size} lit pixels", fontsize=10)
fig.suptitle(f"{title}: float32 compositing vs an 8-bit pipeline", fontsize=12)
fig.tight_layout()

# docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
out = pathlib.Path(os.environ.get("PV_HDRVOL_FIGURES", REPO / "docs" / "images")) / "hdr_vs_8bit.png"
out.parent.mkdir(parents=True, exist_ok=True)
fig.savefig(out, dpi=100)
print(f"wrote {out}")
plt.show()
