"""
Visibility culling with plenoptic opacity functions: what the opacity buffer sees
==================================================================================

For each block of 16³ cells and 36 × 36 sample view directions, a plenoptic opacity
function (POF) stores the smallest opacity the block shows over its screen footprint.
At render time the blocks are composited front to back into an opacity buffer with
those lower bounds, and a block is culled when every pixel it may touch is at 0.95.

This example shows, for the engine (thin metal walls) and a synthetic dense ball, at
the isometric orthographic view (256²):

1. the render (shaded, Reinhard tone mapping);
2. the POF opacity buffer after culling: where it reaches 0.95 (white) a block
   behind can be culled;
3. per pixel, how many non-empty blocks the oracle (the blocks the ray caster
   samples below the threshold) and the POF culling keep along the pixel's ray:
   the difference is what an exact culling could still remove.

Run::

    python3 examples/plot_culling.py      # writes docs/images/culling_buffer.png
"""
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.culling.cull import block_boxes, visible_blocks  # noqa: E402
from pv_hdrvol.culling.reference import ert_oracle  # noqa: E402

try:
    REPO = Path(__file__).resolve().parents[1]
except NameError:  # sphinx-gallery runs examples without __file__, in examples/
    REPO = Path.cwd().resolve().parent
sys.path.insert(0, str(REPO / "benchmarks"))
from bench_cull_views import scenes  # noqa: E402

# the figures go to docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", REPO / "docs" / "images"))
SIZE = (256, 256)


def blocks_per_pixel(volume, keep, block_size, camera):
    """Per pixel, the number of blocks in ``keep`` whose box the pixel's ray crosses."""
    rays = camera.rays(SIZE)
    lo, hi = block_boxes(volume, block_size, np.nonzero(keep.reshape(-1))[0])
    count = np.zeros(rays.origins.shape[0], dtype=np.int64)
    with np.errstate(divide="ignore", invalid="ignore"):
        for a, b in zip(lo, hi):
            ta, tb = (a - rays.origins) / rays.directions, (b - rays.origins) / rays.directions
            near = np.nan_to_num(np.minimum(ta, tb), nan=-np.inf).max(axis=1)
            far = np.nan_to_num(np.maximum(ta, tb), nan=np.inf).min(axis=1)
            count += far > near
    return count.reshape(SIZE[1], SIZE[0])


def main():
    fig, axes = plt.subplots(2, 3, figsize=(12, 8.4))
    for row, (name, volume, bases, k) in enumerate(scenes(["engine", "ball"])):
        pof = hv.PlenopticOpacity.compute(volume, bases)
        camera = hv.Camera.fit(volume.bounds, "iso", parallel_projection=True)
        tf = hv.TransferFunction.family(bases, k)
        image = hv.render(volume, tf, camera, SIZE, shade=True, progress_bar=False)
        result = visible_blocks(pof, volume, camera, SIZE, k)
        oracle = ert_oracle(volume, tf, camera, SIZE, nonempty=result.nonempty)
        stats = result.statistics
        axes[row, 0].imshow(image.tonemap("reinhard").rgb)
        axes[row, 0].set_title(f"{name}")
        axes[row, 1].imshow(result.opacity, cmap="gray", vmin=0, vmax=0.95)
        axes[row, 1].set_title(f"POF opacity buffer ({np.mean(result.opacity >= 0.95):.0%} of pixels at 0.95)")
        extra = blocks_per_pixel(volume, result.visible & ~oracle, pof.block_size, camera)
        shown = axes[row, 2].imshow(extra, cmap="magma")
        axes[row, 2].set_title(f"blocks kept but never sampled: {int((result.visible & ~oracle).sum())} "
                               f"of {stats['visible']}", fontsize=9)
        fig.colorbar(shown, ax=axes[row, 2], fraction=0.046, label="per pixel's ray")
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    fig.tight_layout()
    OUT.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT / "culling_buffer.png", dpi=80)
    print("wrote", OUT / "culling_buffer.png")


if __name__ == "__main__":
    main()
