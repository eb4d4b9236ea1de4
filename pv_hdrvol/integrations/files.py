"""Volume and mesh files, read with ``pyvista.read``: what ``pv-hdrvol render``,
``pv-hdrvol view`` and ``pv_hdrvol.view(path)`` open, with one message per problem.

Every error names the file: a missing one is a :class:`FileNotFoundError`, a folder an
:class:`IsADirectoryError`, an extension not read here, a file the reader cannot parse,
a dataset of another kind or a missing array a :class:`ValueError`.
"""
from __future__ import annotations

import errno
import os
import pathlib

#: Extensions read here (with ``pyvista.read``); the command's help is made from it.
READABLE = (".vti", ".vtk", ".vtu", ".nrrd", ".nhdr", ".mha", ".mhd", ".cube")
#: Of those, the ones that hold tetrahedral meshes (``.vtk`` holds either kind).
MESH_FORMATS = (".vtu", ".vtk")
#: Of those, the ones that hold image data (``.vtk`` holds either kind): what proxies are made of.
IMAGE_FORMATS = tuple(ext for ext in READABLE if ext != ".vtu")


def readable_path(path, formats=READABLE):
    """``path`` as a :class:`pathlib.Path` of an existing file whose extension is one of
    ``formats``."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"path must be a str or os.PathLike; got {type(path).__name__}")
    p = pathlib.Path(path)
    if not p.exists():
        raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), str(p))
    if p.is_dir():
        raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR) + " (a volume or mesh file is needed)",
                                str(p))
    if p.suffix.lower() not in formats:
        raise ValueError(f"cannot read {str(p)!r}: unknown extension {p.suffix!r}; use one of {', '.join(formats)}")
    return p


def read_dataset(path, formats=READABLE):
    """The ``pyvista.ImageData`` or ``pyvista.UnstructuredGrid`` in file ``path``."""
    import pyvista as pv

    p = readable_path(path, formats)
    try:
        dataset = pv.read(p)
    except Exception as exc:  # readers raise anything from OSError to ValueError
        raise ValueError(f"cannot read {str(p)!r}: {exc}") from None
    if not isinstance(dataset, (pv.ImageData, pv.UnstructuredGrid)):
        raise ValueError(f"{str(p)!r} holds a {type(dataset).__name__}; pv_hdrvol renders image data (ImageData) and "
                         f"tetrahedral meshes (UnstructuredGrid)")
    return dataset


def read_volume(path, scalars=None, preference="point", formats=READABLE):
    """The :class:`~pv_hdrvol.GridVolume` or :class:`~pv_hdrvol.TetMesh` of array
    ``scalars`` (default: the active scalars) in file ``path``.

    Raises
    ------
    FileNotFoundError, IsADirectoryError
        ``path`` is missing or a folder.
    ValueError
        Its extension is not one of ``formats``, ``pyvista.read`` cannot read it, it
        holds neither image data nor an unstructured grid, or it has no such array
        (:class:`~pv_hdrvol.ScalarsError`, which names the arrays there are). The
        messages about the file name it.
    """
    import pyvista as pv

    from ..data.grid import volume_from_dataset
    from ..data.tets import tetmesh_from_dataset

    dataset = read_dataset(path, formats)
    if isinstance(dataset, pv.UnstructuredGrid):
        return tetmesh_from_dataset(dataset, scalars=scalars, preference=preference)
    return volume_from_dataset(dataset, scalars=scalars, preference=preference)
