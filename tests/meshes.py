"""Test helpers: tetrahedral meshes built with numpy (no VTK), exact ray-box lengths, and a
CTH-like rectilinear grid of cell data (PyVista)."""
import itertools

import numpy as np

import pv_hdrvol as hv

WHITE = [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]


def box_mesh(shape, spacing=1.0, origin=(0.0, 0.0, 0.0), field=None, shared=True):
    """Points, tets and point values of a box of ``shape`` (cells along x, y, z), each
    cube split into the 6 tetrahedra of its Kuhn triangulation (conforming between
    cubes). ``shared=False`` gives every cube its own 8 points (duplicates)."""
    nx, ny, nz = shape
    perms = list(itertools.permutations(range(3)))
    pts, tets = [], []
    index = {}
    for i, j, k in itertools.product(range(nx), range(ny), range(nz)):
        local = {}
        for corner in itertools.product((0, 1), repeat=3):
            key = (i + corner[0], j + corner[1], k + corner[2])
            if shared and key in index:
                local[corner] = index[key]
                continue
            local[corner] = len(pts)
            index.setdefault(key, len(pts))
            pts.append(key)
        for perm in perms:
            c = [0, 0, 0]
            tet = [local[tuple(c)]]
            for axis in perm:
                c[axis] = 1
                tet.append(local[tuple(c)])
            tets.append(tet)
    p = np.asarray(pts, dtype=np.float64) * spacing + np.asarray(origin)
    values = field(p) if field is not None else np.ones(len(p))
    return p, np.asarray(tets, dtype=np.int64), values


def slab_length(origins, directions, lo, hi):
    """Length of each ray inside the box [lo, hi] (0 when it misses)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / directions
        ta = (np.asarray(lo) - origins) * inv
        tb = (np.asarray(hi) - origins) * inv
    t0 = np.nanmax(np.minimum(ta, tb), axis=1)
    t1 = np.nanmin(np.maximum(ta, tb), axis=1)
    t0 = np.maximum(t0, 0.0)
    return np.maximum(t1 - t0, 0.0)


def constant_tf(opacity):
    return hv.TransferFunction([0.0, 2.0], WHITE, [opacity, opacity])


def oblique_camera(center, distance=10.0, parallel=True, scale=3.0):
    direction = np.array([0.31, -0.52, 0.79])
    direction /= np.linalg.norm(direction)
    return hv.Camera(tuple(np.asarray(center) + distance * direction), tuple(center), (0.0, 0.0, 1.0),
                     parallel_projection=parallel, parallel_scale=scale)


def cth_like_grid():
    """A CTH-like ``pyvista.RectilinearGrid``: uneven cells along x and y, and the values
    on the cells (cell data ``"density"``)."""
    import pyvista as pv

    xs = np.cumsum(np.r_[0.0, np.linspace(0.2, 0.6, 15)])
    ys = np.cumsum(np.r_[0.0, np.linspace(0.5, 0.25, 12)])
    zs = np.linspace(0.0, 3.0, 10)
    rect = pv.RectilinearGrid(xs, ys, zs)
    cz, cy, cx = np.meshgrid(*(np.arange(n - 1) for n in (len(zs), len(ys), len(xs))), indexing="ij")
    rect.cell_data["density"] = (np.cos(0.5 * cx) * np.sin(0.6 * cy) + 0.1 * cz).ravel()
    return rect
