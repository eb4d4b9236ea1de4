"""
Tone-mapping gallery: one HDR render, every operator, and the detail each keeps
================================================================================

HDR VolVis (Yuan et al.) renders in high precision and then asks which tone-mapping
operator shows the most of the data on an 8-bit screen. This example renders the
hydrogen orbital density (6 decades) and the m4 total electron density (16 decades)
from ../shared/data in float64, maps each render with every operator, and prints the
share of visible local contrasts each one keeps
(:func:`pv_hdrvol.image.detail.detail_preserved`), with the conventional 8-bit
pipeline (``precision="uint8"``) as the baseline. It also draws the exposure bracket
and the pseudocolour view of the first render (the paper's Fig. 4).

Run::

    python3 examples/plot_tonemap_gallery.py            # writes docs/images/tonemap_*.png
"""
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.image.detail import detail_preserved  # noqa: E402
from pv_hdrvol.image.views import plot_exposures, plot_pseudocolor  # noqa: E402

try:
    REPO = Path(__file__).resolve().parents[1]
except NameError:  # sphinx-gallery runs examples without __file__, in examples/
    REPO = Path.cwd().resolve().parent
DATA = Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data")) / "hdr"
# the figures go to docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", REPO / "docs" / "images"))
SIZE = 384

OPERATORS = [
    ("linear", {}), ("reinhard", {}), ("drago", {}),
    ("reinhard local", {"local": True}), ("durand", {}), ("fattal", {}),
]
SCENES = {
    "hydrogen (6 decades)": ("hydrogen_64x64x64_float32.vti", 1e-6, 1.0, 0.2),
    "m4 density (16 decades)": ("m4_total_density_25x22x31_float32.vti", 1e-12, 0.5, 0.05),
}


def renders(name):
    file, lo, hi, alpha = SCENES[name]
    grid = pv.read(DATA / file)
    tf = hv.TransferFunction.ramp(lo, hi, scale="log", cmap="magma", opacity=(0.0, 0.5))
    kw = dict(size=(SIZE, SIZE), global_alpha=alpha, progress_bar=False)
    return hv.render(grid, tf, precision="float64", **kw), hv.render(grid, tf, precision="uint8", **kw)


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    rows = []
    fig, axes = plt.subplots(len(SCENES), len(OPERATORS) + 1, figsize=(2.4 * (len(OPERATORS) + 1), 2.7 * len(SCENES)))
    for r, name in enumerate(SCENES):
        ref, img8 = renders(name)
        base = hv.tonemap(img8, "linear", exposure_stops=0.0)  # an 8-bit buffer is shown as it is
        d8 = detail_preserved(ref, base)
        axes[r, 0].imshow(base.rgb8)
        axes[r, 0].set_title(f"8-bit pipeline\n{d8:.2f}", fontsize=8)
        row = {"scene": name, "8-bit pipeline": d8}
        for c, (label, params) in enumerate(OPERATORS, start=1):
            op = label.split()[0]
            out = hv.tonemap(ref, op, **params)
            d = detail_preserved(ref, out)
            row[label] = d
            axes[r, c].imshow(out.rgb8)
            axes[r, c].set_title(f"{label}\n{d:.2f}", fontsize=8)
        axes[r, 0].set_ylabel(name, fontsize=8)
        rows.append(row)
        if r == 0:
            plot_exposures(ref, stops=(-8, -6, -4, -2, 0, 2), columns=6).savefig(OUT / "tonemap_bracket.png", dpi=80)
            plot_pseudocolor(ref).savefig(OUT / "tonemap_pseudocolor.png", dpi=80)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle("Detail kept (share of visible local contrasts still shown, same sign)", fontsize=9)
    fig.tight_layout()
    fig.savefig(OUT / "tonemap_gallery.png", dpi=80)
    header = ["scene", "8-bit pipeline"] + [label for label, _ in OPERATORS]
    print("| " + " | ".join(header) + " |")
    print("|---" * len(header) + "|")
    for row in rows:
        print("| " + " | ".join([row["scene"]] + [f"{row[h]:.3f}" for h in header[1:]]) + " |")


if __name__ == "__main__":
    main()
