"""Rendering modes through PyVista, VTK, OpenEXR, and on real data (two-level CT head)."""
import numpy as np
import pytest
import pyvista as pv

import pv_hdrvol as hv
from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer

GRAY = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray")


@pytest.fixture(scope="module")
def grid():
    g = pv.ImageData(dimensions=(7, 6, 5), spacing=(1.0, 0.5, 2.0))
    g["v"] = np.random.default_rng(3).random(g.n_points)
    g["lab"] = (g.points[:, 2] > 4.0).astype(np.int32)
    return g


def test_accessor_projection_and_labels_match_render(grid):
    a = grid.hdrvol.render(scalars="v", tf=GRAY, size=12, blending="maximum", precision="float64")
    b = hv.render(grid, GRAY, size=12, scalars="v", blending="maximum", precision="float64")
    assert np.array_equal(a.value, b.value, equal_nan=True)
    c = grid.hdrvol.render(scalars="v", tf=GRAY, size=12, labels="lab", label_styles={1: "maximum"})
    d = hv.render(grid, GRAY, size=12, scalars="v", labels=grid["lab"].reshape(5, 6, 7),
                  label_styles={1: "maximum"})
    assert np.array_equal(c.rgba, d.rgba)
    assert c.metadata["label_styles"] == {"default": "composite", "1": "maximum"}
    assert grid["lab"].dtype == np.int32  # the dataset is not modified


def test_accessor_takes_a_lens(grid):
    lens = hv.Magnifier((6.5, 5.5), radius=4, transition=1.5, factor=2.5)
    a = grid.hdrvol.render(scalars="v", tf=GRAY, size=(14, 12), lens=lens, precision="float64")
    b = hv.render(grid, GRAY, hv.Camera.fit(grid, "iso"), (14, 12), scalars="v", lens=lens, precision="float64")
    assert np.array_equal(a.rgba, b.rgba)
    assert a.metadata["lens"] == repr(lens)
    plain = grid.hdrvol.render(scalars="v", tf=GRAY, size=(14, 12), precision="float64")
    assert not np.array_equal(a.rgba, plain.rgba)


def test_labels_by_name_need_a_dataset(grid):
    with pytest.raises(TypeError, match="labels may name an array of a dataset only; got the name 'lab' with a "
                                        "ndarray"):
        hv.render(np.zeros((3, 3, 3)), GRAY, size=4, labels="lab")


class ShiftLens:
    """A minimal lens: the camera's rays moved sideways by one world unit."""

    def rays(self, camera, size):
        r = camera.rays(size)
        return r._replace(origins=r.origins + [1.0, 0.0, 0.0])

    def __repr__(self):
        return "ShiftLens()"


def test_vtk_algorithm_blending_lens_and_labels(grid):
    alg = HDRVolumeRenderer()
    alg.SetInputDataObject(grid)
    alg.SetScalars("v")
    alg.SetImageSize(10, 8)
    alg.SetTransferFunction(GRAY)
    alg.SetPrecision("float64")
    alg.SetBlending("maximum")
    assert alg.GetBlending() == "maximum"
    assert alg.Update()
    out = hv.HDRImage.from_pyvista(alg.GetOutput())
    ref = hv.render(grid, GRAY, size=(10, 8), scalars="v", blending="maximum", precision="float64")
    assert np.array_equal(out.value, ref.value, equal_nan=True)
    alg.SetBlending("composite")
    alg.SetLens(ShiftLens())
    assert alg.Update()
    out = hv.HDRImage.from_pyvista(alg.GetOutput())
    cam = hv.Camera.fit(grid, "iso")
    ref = hv.render(grid, GRAY, cam, (10, 8), scalars="v", lens=ShiftLens(), precision="float64")
    assert np.array_equal(out.rgba, ref.rgba)
    assert out.metadata["lens"] == "ShiftLens()"
    alg.SetLens(None)
    alg.SetLabels("lab", {1: "minimum"})
    assert alg.GetLabels() == ("lab", {1: "minimum"})
    assert alg.Update()
    out = hv.HDRImage.from_pyvista(alg.GetOutput())
    ref = hv.render(grid, GRAY, size=(10, 8), scalars="v", labels="lab", label_styles={1: "minimum"},
                    precision="float64")
    assert np.array_equal(out.rgba, ref.rgba)
    with pytest.raises(TypeError, match="the lens must have a rays\\(camera, size\\) method, or be None; got int"):
        alg.SetLens(3)
    with pytest.raises(ValueError, match="gradient_opacity must be \\(low, high\\) with high > low >= 0"):
        alg.SetGradientOpacity((2.0, 1.0))


def test_render_rejects_a_lens_without_rays_or_camera():
    with pytest.raises(TypeError, match="lens must have a rays\\(camera, size\\) method; got str"):
        hv.render(np.zeros((3, 3, 3)), GRAY, size=4, lens="magnifier")
    r = hv.Camera().rays(4)
    with pytest.raises(TypeError, match="a lens needs a Camera; got Rays"):
        hv.render(np.zeros((3, 3, 3)), GRAY, r, lens=ShiftLens())


def test_value_image_survives_exr_and_vtk(tmp_path, grid):
    pytest.importorskip("OpenEXR")
    img = hv.render(grid, GRAY, size=12, scalars="v", blending="additive", precision="float64")
    path = img.save(tmp_path / "xray.exr")
    back = hv.load(path)
    assert np.array_equal(back.value, img.value.astype(np.float32), equal_nan=True)
    again = hv.HDRImage.from_pyvista(img.to_pyvista())
    assert np.array_equal(again.value, img.value, equal_nan=True)
    plain = hv.load(hv.render(grid, GRAY, size=4, scalars="v").save(tmp_path / "plain.exr"))
    assert plain.value is None


@pytest.mark.data
def test_two_level_ct_head_bone_by_mip(shared_data):
    """CT head split at 100 into soft tissue (0) and bone (1). Bone by maximum with a constant
    opacity of 0.5, soft tissue invisible: each bone segment a ray crosses adds 0.5 of the
    remaining transmittance, so every pixel's opacity is exactly 1 - 0.5**n for n segments
    -- and the skull gives many rays two or more segments (front and back).

    Measured (64x64, side view): 13.4 % of the pixels see bone, 10.2 % two or more
    segments (the head covers 42 % of the image)."""
    head = pv.read(shared_data / "structured" / "ct_head_120x120x130_uint8.vtk")
    vol = hv.volume_from_dataset(head)
    labels = (vol.values > 100).astype(np.uint8)
    soft = hv.TransferFunction([0.0, 255.0], [[1.0, 0.8, 0.7]] * 2, [0.0, 0.0])
    bone = hv.TransferFunction([0.0, 255.0], [[1.0, 1.0, 1.0]] * 2, [0.5, 0.5])
    cam = hv.Camera.fit(vol, "yz")
    img = hv.render(vol, soft, cam, 64, precision="float64", labels=labels, label_styles={1: (bone, "maximum")},
                    progress_bar=False)
    alpha = img.rgba[..., 3]
    n = np.log2(1.0 / np.maximum(1.0 - alpha, 1e-300))
    assert np.allclose(n, np.round(n), atol=1e-9)
    counts = np.bincount(np.round(n).astype(int).ravel())
    assert counts[1:].sum() > 0.10 * alpha.size  # rays through bone
    assert counts[2:].sum() > 0.08 * alpha.size  # through the skull twice, at least
    # with every label composited by one TF, two-level rendering is the plain render
    tf = hv.TransferFunction.ramp(0.0, 255.0, cmap="gray", opacity=(0.0, 0.05))
    plain = hv.render(vol, tf, cam, 48, precision="float32")
    same = hv.render(vol, tf, cam, 48, precision="float32", labels=labels, label_styles={1: tf})
    assert np.array_equal(plain.rgba, same.rgba)
