"""
Defaults that show the data: every dataset of ../shared/data with no transfer function
=======================================================================================

``hv.render(data)`` (and ``grid.hdrvol.render()``, the VTK algorithm, ``pv-hdrvol
render FILE``) chooses the transfer function from the data
(``pv_hdrvol.data.transfer.auto_transfer_function``):

- the histogram's dominant low mode (air in CT, the floor of a density) stays
  transparent, so pixels outside the data's support stay empty;
- colours and opacity span the structure, from past that mode to the 99.9th percentile;
- a log axis when the positive values span more than three decades, with opacity in
  proportion to the value (a density's faint decades stay faint, and the HDR image
  keeps them);
- the opacity is as high as keeps the densest rays (the 95th percentile of a grid's
  columns; a mesh's average ray) at a transmittance of 0.25;
- CT-like (integer) data: the most voluminous class above the air (soft tissue,
  dentin) is a dim veil keeping a transmittance of 0.8, the denser classes take the
  colours and the opacity;
- a signed field (here the hydrogen 3d_z2 wavefunction psi, both signs over eight
  decades): a symmetric symlog range, diverging colours, opacity by magnitude and
  zero transparent.

This example renders each volume and mesh with that default, unshaded and shaded, and
tone maps with Reinhard's operator.

Run::

    python3 examples/plot_defaults.py      # writes docs/images/defaults_contact_sheet.png
"""
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pyvista as pv  # noqa: E402

import pv_hdrvol as hv  # noqa: E402
from pv_hdrvol.raycast.grid import as_volume, default_transfer_function  # noqa: E402

try:
    REPO = Path(__file__).resolve().parents[1]
except NameError:  # sphinx-gallery runs examples without __file__, in examples/
    REPO = Path.cwd().resolve().parent
DATA = Path(os.environ.get("PV_HDRVOL_DATA", REPO.parent / "shared" / "data"))
# the figures go to docs/images (PV_HDRVOL_FIGURES elsewhere: the docs build sets it)
OUT = Path(os.environ.get("PV_HDRVOL_FIGURES", REPO / "docs" / "images"))
FILES = ["structured/engine_256x256x128_uint8.vti", "structured/bonsai_256x256x256_uint8.vti",
         "structured/tooth_103x94x161_uint8.nrrd", "structured/ct_head_120x120x130_uint8.vtk",
         "structured/headsq_64x64x93_int16le.nhdr", "hdr/hydrogen_64x64x64_float32.vti",
         "hdr/m4_total_density_25x22x31_float32.vti", "unstructured/spx_12936tets.vtk",
         "unstructured/bluntfin_187395tets.vtu", "unstructured/post_513375tets.vtu",
         "unstructured/fea_bracket_56786tets.vtu"]
SIZE = (200, 200)


def signed_field():
    """The hydrogen 3d_z2 wavefunction psi (signed: the sign of 3 z^2 - r^2 times
    sqrt(|psi|^2)), a signed field spanning eight decades, on a 64^3 grid."""
    values, spacing, origin = hv.datasets.hydrogen_orbital_array(3, 2, 0, size=64)
    n = values.shape[0]
    c = origin[0] + spacing[0] * np.arange(n)
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    return hv.volume_from_array(np.sign(3 * z * z - (x * x + y * y + z * z)) * np.sqrt(values), spacing=spacing,
                                origin=origin)


def main():
    fig, axes = plt.subplots(4, 6, figsize=(15, 10.8))
    for k, path in enumerate(FILES + ["psi_3dz2 (signed)"]):
        if path in FILES:
            ds = pv.read(DATA / path)
            data = as_volume(ds) if isinstance(ds, pv.ImageData) else hv.tetmesh_from_dataset(ds)
        else:
            data = ds = signed_field()
        tf = default_transfer_function(data)
        camera = hv.Camera.fit(data.bounds, "iso")
        for j, shade in enumerate((False, True)):
            img = hv.render(ds, None, camera, SIZE, shade=shade, progress_bar=False)
            ax = axes.flat[2 * k + j]
            ax.imshow(img.tonemap("reinhard").rgb8)
            ax.set_title(f"{Path(path).stem[:24]}{' shaded' if shade else ''}\n{tf.scale} [{tf.vmin:.3g}, "
                         f"{tf.vmax:.3g}], a={tf.opacities.max():.3g}", fontsize=7)
    for ax in axes.flat:
        ax.set_axis_off()
    fig.tight_layout()
    OUT.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT / "defaults_contact_sheet.png", dpi=80)
    print("wrote", OUT / "defaults_contact_sheet.png")


if __name__ == "__main__":
    main()
