"""Render the cases of tests/gpu/test_gpu.py with device="cuda" under numba-cuda's CUDA
simulator and save them for the test to compare with the CPU's renders.

Run with NUMBA_ENABLE_CUDASIM=1 (the simulator is chosen when numba.cuda is first
imported, so it needs a process of its own): ``python sim_renders.py OUT.npz
[--front-ends]`` (the last also renders through the PyVista accessor, the VTK
algorithm and the CLI, GPU and CPU, and saves their differences).
"""
import json
import sys

import numpy as np

import pv_hdrvol as hv
from pv_hdrvol.raycast.grid import GridPlan
from pv_hdrvol.raycast.tets import TetPlan

N = 16  # a 16^3 volume, 16^2 images: the simulator runs each CUDA thread as Python


def volume():
    """A blob over a faint background, four decades, with a NaN corner."""
    z, y, x = np.mgrid[0:N, 0:N, 0:N].astype(np.float64)
    rng = np.random.default_rng(7)
    v = 1e-3 + 10.0 * np.exp(-((x - 7.3) ** 2 + (y - 8.1) ** 2 + (z - 6.6) ** 2) / 12.0) + 1e-3 * rng.random(x.shape)
    v[:3, :3, :3] = np.nan
    return v


def mesh():
    """The blob on a 7^3 lattice of cubes cut into six tetrahedra each (Kuhn's split)."""
    import itertools

    n = 7
    g = np.arange(n, dtype=np.float64)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    tets = []
    for k, j, i in itertools.product(range(n - 1), repeat=3):
        for order in itertools.permutations(range(3)):
            c = [i, j, k]
            path = [(c[2] * n + c[1]) * n + c[0]]
            for axis in order:
                c[axis] += 1
                path.append((c[2] * n + c[1]) * n + c[0])
            tets.append(path)
    values = 1e-3 + np.exp(-((points - [3.1, 2.9, 3.3]) ** 2).sum(1) / 3.0)
    return hv.tetmesh_from_arrays(points, np.array(tets, dtype=np.int64), values)


def half_mask():
    """Blocks (4^3 cells) to render: the half at x >= 8."""
    mask = np.ones((4, 4, 4), bool)
    mask[:, :, :2] = False
    return mask


def front_ends(folder):
    """max |GPU - CPU| / peak through the PyVista accessor, the VTK algorithm, the viewer's
    progressive renderer (its full frame; a volume and a mesh) and the CLI."""
    import subprocess

    import pyvista as pv
    from vtkmodules.util.numpy_support import vtk_to_numpy

    from pv_hdrvol.integrations.vtk_algorithm import HDRVolumeRenderer

    def err(a, b):
        return float(np.abs(np.asarray(a, np.float64) - b).max() / np.abs(b).max())

    grid = pv.ImageData(dimensions=(N, N, N))
    grid.point_data["v"] = volume().ravel()
    out = {"accessor": err(grid.hdrvol.render(size=(N, N), device="cuda").rgba, grid.hdrvol.render(size=(N, N)).rgba)}
    rgba = {}
    for device in ("cuda", "cpu"):
        alg = HDRVolumeRenderer()
        alg.SetInputDataObject(grid)
        alg.SetImageSize(N, N)
        alg.SetDevice(device)
        alg.Update()
        rgba[device] = vtk_to_numpy(alg.GetOutputDataObject(0).GetPointData().GetArray("rgba")).copy()
    out["vtk"] = err(rgba["cuda"], rgba["cpu"])
    from pv_hdrvol.viewer.progressive import ProgressiveRenderer

    for name, data in (("progressive", hv.volume_from_array(volume())), ("progressive mesh", mesh())):
        camera = hv.Camera.fit(data.bounds, "iso")
        full = {device: ProgressiveRenderer(data, device=device, factor=2).frames(camera, (N, N))[-1].image.rgba
                for device in ("cuda", "cpu")}
        out[name] = err(full["cuda"], full["cpu"])
    path = f"{folder}/blob.vti"
    grid.save(path)
    for device in ("cuda", "cpu"):
        subprocess.run([sys.executable, "-m", "pv_hdrvol.integrations.cli", "render", path, "--size", str(N),
                        "--device", device, "-o", f"{folder}/{device}.exr"], check=True, capture_output=True)
    gpu, cpu = hv.load(f"{folder}/cuda.exr"), hv.load(f"{folder}/cpu.exr")
    out["cli"] = err(gpu.rgba, cpu.rgba)
    out["cli_device"] = gpu.metadata["device"]["gpu"]
    return out


def far_image():
    return np.where(np.arange(N * N).reshape(N, N) % 3 == 0, 14.0, np.inf)


def cases():
    """name -> (GridPlan keywords, or TetPlan ones with ``mesh=True``; execute keywords)."""
    iso = hv.Camera.fit((0, N - 1) * 3, "iso")
    side = hv.Camera.fit((0, N - 1, 0, N - 1, 0, N - 1), "xz", parallel_projection=True)
    mesh_iso = hv.Camera.fit((0, 6) * 3, "iso")
    clip = dict(clip_planes=[((7.0, 7.0, 7.0), (1.0, 0.3, 0.0))], crop_box=(0, 15, 2, 13, 0, 15))
    return {
        "float64": (dict(precision="float64"), dict(camera=iso)),
        "float32": (dict(precision="float32"), dict(camera=iso)),
        "float32 parallel": (dict(precision="float32"), dict(camera=side)),
        "float32 shaded": (dict(precision="float32", shade=True), dict(camera=iso)),
        "float64 shaded interpolated, two lights": (
            dict(precision="float64", shade=True, shade_gradient="interpolated", lights=[(1, 0, 0), (0, 1, 1)],
                 specular_power=7.5), dict(camera=iso)),
        "float32 clipped and cropped": (dict(precision="float32", **clip), dict(camera=iso)),
        "float64 far": (dict(precision="float64"), dict(camera=iso, far=far_image())),
        "float64 magnifier": (dict(precision="float64"),
                              dict(camera=iso, lens=hv.Magnifier((8, 8), 5, 2.0, antialias=False))),
        "float32 faint (global_alpha 1e-6, no termination)": (
            dict(precision="float32", global_alpha=1e-6, step=0.1, termination=0.0), dict(camera=iso)),
        "float64 no skipping, no termination": (
            dict(precision="float64", skip_empty=False, termination=0.0), dict(camera=iso)),
        "float32 in chunks (progress watched)": (dict(precision="float32"), dict(camera=iso, progress=lambda f: True)),
        "tolerance=1e-2 (the knobs it chooses)": (dict(tolerance=1e-2), dict(camera=iso)),
        "float32 block mask": (dict(precision="float32"), dict(camera=iso, block_mask=half_mask())),
        "float64 maximum": (dict(precision="float64", blending="maximum"), dict(camera=iso)),
        "float32 minimum": (dict(precision="float32", blending="minimum"), dict(camera=iso)),
        "float64 average": (dict(precision="float64", blending="average"), dict(camera=iso)),
        "float32 additive, clipped": (dict(precision="float32", blending="additive", **clip), dict(camera=iso)),
        "mesh float64": (dict(mesh=True, precision="float64"), dict(camera=mesh_iso)),
        "mesh float32 shaded": (dict(mesh=True, precision="float32", shade=True), dict(camera=mesh_iso)),
        "mesh float32 clipped, far": (
            dict(mesh=True, precision="float32", clip_planes=[((3.0, 3.0, 3.0), (1.0, 0.3, 0.0))]),
            dict(camera=mesh_iso, far=np.full((N, N), mesh_iso.distance))),
    }


def render(plan_kw, exec_kw, device):
    if plan_kw.get("mesh"):
        plan_kw = dict(plan_kw)
        del plan_kw["mesh"]
        return TetPlan(mesh(), None, **plan_kw, device=device).execute(size=(N, N), **exec_kw)
    plan = GridPlan(volume(), None, **plan_kw, device=device)
    return plan.execute(size=(N, N), **exec_kw)


def count(img):
    """Samples a grid render took, or cells a mesh render crossed."""
    return img.metadata["samples"] if "samples" in img.metadata else img.metadata["cells"]


def main(out):
    arrays, meta = {}, {}
    for i, (name, (plan_kw, exec_kw)) in enumerate(cases().items()):
        img = render(plan_kw, exec_kw, "cuda")
        arrays[f"{i}_rgba"], arrays[f"{i}_depth"] = img.rgba, img.depth
        arrays[f"{i}_samples"] = np.array(count(img))
        if img.value is not None:
            arrays[f"{i}_value"] = img.value
        meta[name] = img.metadata["device"]
    # a camera orbit: the second frame uploads no volume, table or skip structure again
    plan = GridPlan(volume(), None, precision="float32", device="cuda")
    frames = [plan.execute(hv.Camera.fit((0, N - 1) * 3, view), (N, N)) for view in ("iso", "xy", "yz")]
    meta["orbit"] = [f.metadata["device"]["uploaded_bytes"] for f in frames]
    if "--front-ends" in sys.argv:
        import os

        meta["front ends"] = front_ends(os.path.dirname(out))
    np.savez(out, **arrays)
    with open(out + ".json", "w") as f:
        json.dump(meta, f)


if __name__ == "__main__":
    main(sys.argv[1])
