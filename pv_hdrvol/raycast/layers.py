"""Reference depth layers at full resolution: the guide of joint bilateral upsampling.

For a tetrahedral mesh, the layers are the depths at which each pixel's ray crosses
the mesh boundary, front to back (depth peeling of the boundary faces: entry and exit
surfaces of non-convex meshes), and the thickness is the length of the ray inside the
mesh; the boundary faces are rasterised by the kernel that gives the ray caster its
entry faces (``_layer_kernels``: edge functions, which are the Plücker tests up to a
positive factor), so a render and its layers cover the same pixels. For an image
volume, the reference is the depth of an isosurface (the first point along the ray
where the value reaches ``isovalue``) or, given a transfer
function, where the accumulated opacity first reaches a threshold (Callahan & Silva's
suggestion for structured volumes).
"""
from __future__ import annotations

import time

import numpy as np

from .._validate import as_int, as_real, as_size
from ..data.tets import as_tetmesh, is_unstructured
from ..image.upsample import DepthLayers  # re-exported: the layers' type lives with their reader
from ..rays.camera import Camera


def depth_layers(data, camera=None, size=(512, 512), *, max_layers=4, scalars=None, preference="point",
                 isovalue=None, tf=None, threshold=0.05, **options):
    """Full-resolution depth layers of a mesh's boundary, or a reference depth of a volume.

    Parameters
    ----------
    data : tetrahedral mesh (pyvista.UnstructuredGrid, vtkUnstructuredGrid, TetMesh) or
        image volume (anything :func:`~pv_hdrvol.render` accepts)
    camera : Camera, optional
        Default ``Camera.fit(data, "iso")``.
    size : int or (width, height)
    max_layers : int
        Meshes: keep at most this many layers (front to back); the result has fewer
        when no pixel has more (``DepthLayers.layers_needed`` tells how many exist).
    isovalue : float, optional
        Volumes: the depth where the value first reaches ``isovalue``.
    tf : TransferFunction, optional
        Volumes without ``isovalue``: the depth where the accumulated opacity of a
        render with ``tf`` first reaches ``threshold``.
    **options
        Render options for volumes (``step=``, ``precision=``...).

    Returns
    -------
    DepthLayers
        For a mesh also with :attr:`DepthLayers.thickness`, found in the same pass.
    """
    max_layers = as_int("max_layers", max_layers, low=1)
    t0 = time.perf_counter()
    if is_unstructured(data):
        from .tets import boundary_layers, mesh_layers

        if isovalue is not None or tf is not None:
            raise ValueError("isovalue= and tf= pick a reference for image volumes; a mesh's reference is its "
                             "boundary")
        mesh = as_tetmesh(data, scalars=scalars, preference=preference)
        if camera is None:
            camera = Camera.fit(mesh.bounds, "iso")
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a Camera; got {type(camera).__name__}")
        width, height = as_size(size)
        counts, t, thickness = boundary_layers(mesh, camera, (width, height), max_layers)
        k = max(1, min(max_layers, int(counts.max()) if counts.size else 0))
        return mesh_layers(mesh, (width, height), counts, t[:k], thickness, t0)
    from ..data.transfer import TransferFunction
    from .grid import as_volume, render_volume

    volume = as_volume(data, scalars=scalars, preference=preference)
    if camera is None:
        camera = Camera.fit(volume.bounds, "iso")
    if isovalue is not None:
        iso = as_real("isovalue", isovalue)
        if tf is not None:
            raise ValueError("give isovalue= or tf=, not both")
        # opaque from the isovalue up: the depth threshold is met at the first sample past it
        lo, hi = volume.value_range
        top = max(hi, iso) + max(abs(hi), 1.0)
        tf = TransferFunction([min(lo, iso) - 1.0, iso, np.nextafter(iso, np.inf), top], [[1, 1, 1]] * 4,
                              [0.0, 0.0, 1.0, 1.0])
        threshold = 0.5
        source = f"isosurface {iso:g}"
    elif tf is None:
        raise ValueError("image volumes need isovalue= or tf= to define a reference depth")
    else:
        source = f"opacity {threshold:g} of {tf!r}"
    threshold = as_real("threshold", threshold, low=0.0, high=1.0, low_open=True)
    img = render_volume(volume, tf, camera, size, depth_threshold=threshold, progress_bar=False, **options)
    depth = img.depth[None].astype(np.float64)
    counts = np.isfinite(img.depth).astype(np.int64)
    return DepthLayers(depth, counts, time.perf_counter() - t0, source)
