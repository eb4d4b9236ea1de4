"""A battery of pinned scenes, rendered and compared bit for bit across a change of code.

A refactoring that must change no pixel renders this battery with the tree before the
change and again after each step, on the same machine (numba's code is deterministic on
one machine, not across processors):

    python3 tests/pixel_battery.py write /tmp/battery-before.npz     # the tree before
    python3 tests/pixel_battery.py check /tmp/battery-before.npz     # after each step

``check`` prints each scene's largest difference (RGBA and depth) and exits 1 unless
every array is equal bit for bit (NaN in the same places counts as equal). The scenes
cover every path a frame takes: image volumes in float32 and float64, shading, a maximum
projection, a clip plane, a magnifier lens, tetrahedra in float32 and float64, a
rectilinear grid with cell data, two image blocks as one scene, and a multiresolution
store rendered out of core at level 0. Not collected by pytest (no ``test_`` prefix).
"""
import argparse
import os
import sys
import tempfile

import numpy as np

SIZE = (48, 40)


def _field(shape):
    z, y, x = np.meshgrid(*(np.linspace(-1.0, 1.0, n) for n in shape), indexing="ij")
    r2 = x * x + 1.3 * y * y + 0.7 * z * z
    return np.exp(-3.0 * r2) + 0.25 * np.sin(4.0 * x) * np.cos(3.0 * y) * z


def scenes():
    """``{name: callable() -> HDRImage}``: the pinned scenes. Built here from numpy and
    PyVista alone, not from the tests' helpers: the battery is written with the tree
    before a change, whose helpers may differ."""
    import pyvista as pv

    import pv_hdrvol as hv

    values = _field((20, 22, 24))
    tf = hv.TransferFunction.ramp(-0.3, 1.1, cmap="viridis", opacity=(0.0, 0.5))
    grid = pv.ImageData(dimensions=(24, 22, 20), spacing=(0.5, 0.45, 0.55), origin=(-1.0, 0.5, 2.0))
    grid.point_data["f"] = values.ravel()  # x fastest: values are (z, y, x)
    bounds = grid.bounds
    camera = hv.Camera.fit(bounds, "iso")

    def grid_render(**kw):
        return lambda: hv.render(grid, tf, camera, SIZE, **kw)

    out = {
        "uniform_float32": grid_render(precision="float32"),
        "uniform_float64": grid_render(precision="float64"),
        "shaded": grid_render(shade=True),
        "maximum": grid_render(blending="maximum"),
        "clip_plane": grid_render(clip_planes=hv.ClipPlane(grid.center, (1.0, 0.3, -0.2))),
        "magnifier": grid_render(lens=hv.Magnifier((24.0, 20.0), radius=12.0, transition=4.0, factor=2.0)),
        "default_tf": lambda: hv.render(grid, None, camera, SIZE),
    }

    # tetrahedra: a uniform grid's cells split into tets, a twisted field on its points
    mesh = pv.ImageData(dimensions=(7, 6, 5), spacing=(1.0, 1.1, 0.9)).cast_to_unstructured_grid().triangulate()
    p = mesh.points
    mesh.point_data["g"] = np.sin(0.9 * p[:, 0]) * np.cos(0.7 * p[:, 1]) + 0.3 * p[:, 2]
    mesh_tf = hv.TransferFunction.ramp(-1.0, 2.2, cmap="plasma", opacity=(0.0, 0.6))
    mesh_camera = hv.Camera.fit(mesh.bounds, "iso")
    for precision in ("float32", "float64"):
        out[f"tets_{precision}"] = (lambda p=precision: hv.render(mesh, mesh_tf, mesh_camera, SIZE, precision=p))

    # a CTH-like rectilinear grid with cell data
    xs = np.cumsum(np.r_[0.0, np.linspace(0.2, 0.6, 15)])
    ys = np.cumsum(np.r_[0.0, np.linspace(0.5, 0.25, 12)])
    zs = np.linspace(0.0, 3.0, 10)
    rect = pv.RectilinearGrid(xs, ys, zs)
    cz, cy, cx = np.meshgrid(*(np.arange(n - 1) for n in (len(zs), len(ys), len(xs))), indexing="ij")
    rect.cell_data["density"] = (np.cos(0.5 * cx) * np.sin(0.6 * cy) + 0.1 * cz).ravel()
    rect_tf = hv.TransferFunction.ramp(-1.0, 1.9, cmap="magma", opacity=(0.0, 0.7))
    out["rectilinear_cells"] = lambda: hv.render(rect, rect_tf, hv.Camera.fit(rect.bounds, "iso"), SIZE,
                                                 preference="cell")

    # two image blocks as one scene
    a = pv.ImageData(dimensions=(12, 12, 12), spacing=(0.5, 0.5, 0.5))
    a.point_data["f"] = _field((12, 12, 12)).ravel()
    b = pv.ImageData(dimensions=(10, 12, 12), spacing=(0.5, 0.5, 0.5), origin=(5.5, 0.0, 0.0))
    b.point_data["f"] = (0.8 * _field((12, 12, 10))).ravel()
    blocks = pv.MultiBlock([a, b])
    out["two_image_blocks"] = lambda: hv.render(blocks, tf, hv.Camera.fit(blocks.bounds, "iso"), SIZE)

    # a multiresolution store out of core, at level 0
    def store():
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "battery.ome.zarr")
            hv.write_multiscale(_field((80, 72, 88)).astype(np.float32), path)
            with hv.open_multiscale(path) as ooc:
                cam = hv.Camera.fit(ooc.bounds, "iso")
                return ooc.render(tf, cam, SIZE, screen_error=1e-6)  # every block at level 0

    out["store_level0"] = store
    return out


def render_all(names=None):
    arrays = {}
    for name, make in scenes().items():
        if names and name not in names:
            continue
        img = make()
        arrays[f"{name}/rgba"] = np.asarray(img.rgba)
        arrays[f"{name}/depth"] = np.asarray(img.depth)
        print(f"  {name:20s} alpha max {float(np.nanmax(img.rgba[..., 3])):.6f}", flush=True)
    return arrays


def compare(reference, current):
    """Lines of a report and whether every array is equal bit for bit."""
    lines, equal = [], True
    for key in sorted(reference):
        ref = reference[key]
        if key not in current:
            lines.append(f"{key:32s} MISSING")
            equal = False
            continue
        cur = current[key]
        same = ref.shape == cur.shape and ref.dtype == cur.dtype and np.array_equal(ref, cur, equal_nan=True)
        if same:
            lines.append(f"{key:32s} equal")
            continue
        equal = False
        if ref.shape != cur.shape or ref.dtype != cur.dtype:
            lines.append(f"{key:32s} DIFFERS: {ref.dtype}{ref.shape} against {cur.dtype}{cur.shape}")
        else:
            finite = np.isfinite(ref) & np.isfinite(cur)
            diff = float(np.max(np.abs(ref[finite] - cur[finite]))) if finite.any() else 0.0
            lines.append(f"{key:32s} DIFFERS: max |difference| {diff:.3g}, "
                         f"{int(np.count_nonzero(ref != cur))} of {ref.size} values")
    return lines, equal


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("write", "check"))
    parser.add_argument("path")
    parser.add_argument("--only", nargs="*", help="scene names (default: all)")
    args = parser.parse_args(argv)
    import pv_hdrvol

    print(f"pv_hdrvol from {os.path.dirname(pv_hdrvol.__file__)}")
    current = render_all(args.only)
    if args.mode == "write":
        np.savez(args.path, **current)
        print(f"wrote {len(current)} arrays to {args.path}")
        return 0
    with np.load(args.path) as f:
        reference = {k: f[k] for k in f.files if not args.only or k.split("/")[0] in args.only}
    lines, equal = compare(reference, current)
    print("\n".join(lines))
    print("bit for bit equal" if equal else "DIFFERENT")
    return 0 if equal else 1


if __name__ == "__main__":
    sys.exit(main())
