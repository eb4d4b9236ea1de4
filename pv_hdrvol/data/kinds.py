"""Which ray caster renders a dataset: one classification for every front end.

- ``"grid"``: the grid ray caster (``raycast/grid.py``): ``pyvista.ImageData`` /
  ``vtkImageData`` (uniform), ``pyvista.RectilinearGrid`` / ``vtkRectilinearGrid``
  (non-uniform axes), a :class:`~pv_hdrvol.GridVolume` or a 3-D numpy array;
- ``"mesh"``: the tetrahedral ray caster (``raycast/tets.py``):
  ``pyvista.UnstructuredGrid`` / ``vtkUnstructuredGrid``, curvilinear
  ``pyvista.StructuredGrid`` / ``vtkStructuredGrid`` (each hexahedron split into five
  tetrahedra), a :class:`~pv_hdrvol.TetMesh`;
- ``"blocks"``: several datasets rendered as one scene (``raycast/blocks.py``):
  ``pyvista.MultiBlock`` / ``vtkMultiBlockDataSet``, ``vtkPartitionedDataSet`` and
  ``vtkPartitionedDataSetCollection`` (what ParaView's readers of simulation codes give).
"""
from __future__ import annotations

import numpy as np

GRID, MESH, BLOCKS = "grid", "mesh", "blocks"

#: VTK classes of uniform image data.
IMAGE_CLASSES = ("vtkImageData", "vtkStructuredPoints", "vtkUniformGrid")
#: VTK classes of each kind (composite datasets: any ``vtkCompositeDataSet``).
GRID_CLASSES = IMAGE_CLASSES + ("vtkRectilinearGrid",)
MESH_CLASSES = ("vtkUnstructuredGrid", "vtkStructuredGrid")

#: What the message of an unsupported dataset lists.
SUPPORTED = ("ImageData, RectilinearGrid, StructuredGrid, UnstructuredGrid (tetrahedra; other 3-D cells are split), "
             "MultiBlock and partitioned datasets of those, a GridVolume, a TetMesh or a 3-D numpy array")


def data_kind(data):
    """``"grid"``, ``"mesh"`` or ``"blocks"``: the ray caster that renders ``data`` (see
    the module's docstring).

    Raises
    ------
    TypeError
        ``data`` is none of those; the message says what is rendered, and for surfaces
        and point clouds how to get a volume from them.
    """
    from .grid import GridVolume
    from .tets import TetMesh

    if isinstance(data, (GridVolume, np.ndarray)):
        return GRID
    if isinstance(data, TetMesh):
        return MESH
    name = data.GetClassName() if hasattr(data, "GetClassName") else None
    if name in GRID_CLASSES:
        return GRID
    if name in MESH_CLASSES:
        return MESH
    if name is not None and data.IsA("vtkCompositeDataSet"):
        return BLOCKS
    kind = type(data).__name__  # PyVista's name for its datasets, VTK's for VTK's
    hint = ""
    if name == "vtkPolyData":
        hint = (": a surface or point cloud has no volume to render; sample it onto an ImageData "
                "(pyvista.ImageData(...).sample(data)) or interpolate it (data.interpolate)")
    raise TypeError(f"pv_hdrvol renders {SUPPORTED}; got {kind}{hint}")


def as_renderable(data, scalars=None, preference="point"):
    """The one prepared object a render plan, the viewer or the command line work with:
    a :class:`~pv_hdrvol.GridVolume` (image data, rectilinear grids, image blocks
    gathered onto one lattice) or a :class:`~pv_hdrvol.TetMesh` (meshes, curvilinear
    grids, mesh blocks merged into one), each cached per dataset.

    Raises
    ------
    TypeError
        ``data`` is not a volume (:func:`data_kind`).
    ValueError
        Image blocks that cannot be gathered onto one volume (different lattices, or
        far more space between them than points in them), and grid and mesh blocks
        together: only :func:`pv_hdrvol.render` renders those, part by part; and what
        :func:`~pv_hdrvol.data.blocks.prepare_blocks` refuses.
    """
    kind = data_kind(data)
    if kind == MESH:
        from .tets import as_tetmesh

        return as_tetmesh(data, scalars=scalars, preference=preference)
    if kind == GRID:
        from .grid import as_volume

        return as_volume(data, scalars=scalars, preference=preference)
    from .blocks import prepare_blocks

    scene = prepare_blocks(data, scalars=scalars, preference=preference)
    if scene.kind == "mesh":
        return scene.mesh
    if scene.kind == "grid":
        return scene.volume
    if scene.kind == "mixed":
        raise ValueError("this dataset mixes grid and mesh blocks, which pv_hdrvol.render(dataset) renders as one "
                         "scene part by part; the viewer, the command line, render plans and the VTK algorithm take "
                         "one volume or one mesh (render dataset[...] parts, or resample onto one ImageData)")
    raise ValueError(f"the image blocks of this dataset are rendered one by one ({scene.reason}): "
                     f"pv_hdrvol.render(dataset) renders them; the viewer, the command line, render plans and "
                     f"the VTK algorithm take blocks that gather onto one lattice (resample them onto one "
                     f"ImageData to use those)")


__all__ = ["BLOCKS", "as_renderable", "GRID", "GRID_CLASSES", "IMAGE_CLASSES", "MESH", "MESH_CLASSES", "SUPPORTED", "data_kind"]
