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

#: Extensions read here (with ``pyvista.read``; ``.vtpc`` with VTK's reader); the command's
#: help is made from it.
READABLE = (".vti", ".vtk", ".vtu", ".vtr", ".vts", ".vtm", ".vtpc", ".vtpd", ".pvti", ".pvtr", ".pvtu", ".nrrd",
            ".nhdr", ".mha", ".mhd", ".cube")
#: Of those, the ones that hold meshes: tetrahedra, other cells split, or curvilinear
#: grids (``.vtk`` holds either kind).
MESH_FORMATS = (".vtu", ".pvtu", ".vts", ".vtk")
#: Of those, the ones that hold several blocks (rendered as one scene).
BLOCK_FORMATS = (".vtm", ".vtpc", ".vtpd")
#: Of those, the ones that may hold image data (``.vtk`` holds either kind): what proxies are made of.
IMAGE_FORMATS = (".vti", ".pvti", ".vtk", ".nrrd", ".nhdr", ".mha", ".mhd", ".cube")


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


def is_store(path):
    """Whether ``path`` is a folder with a ``zarr.json``: a multiresolution store to open
    with :func:`~pv_hdrvol.open_multiscale` (which says so if it is a Zarr store that
    pv_hdrvol did not write), not a proxy folder."""
    return os.path.isdir(path) and os.path.isfile(os.path.join(path, "zarr.json"))


def read_dataset(path, formats=READABLE):
    """The dataset in file ``path``: image data, a rectilinear, curvilinear or
    unstructured grid, or several blocks of those (:mod:`pv_hdrvol.data.kinds`)."""
    import pyvista as pv

    from .kinds import SUPPORTED, data_kind

    p = readable_path(path, formats)
    try:
        dataset = _read_vtpc(p) if p.suffix.lower() == ".vtpc" else pv.read(p)
    except Exception as exc:  # readers raise anything from OSError to ValueError
        raise ValueError(f"cannot read {str(p)!r}: {exc}") from None
    try:
        data_kind(dataset)
    except TypeError:
        raise ValueError(f"{str(p)!r} holds a {type(dataset).__name__}; pv_hdrvol renders {SUPPORTED}") from None
    return dataset


def _read_vtpc(p):
    """The ``vtkPartitionedDataSetCollection`` of a ``.vtpc`` file (``pyvista.read`` has no
    reader of them); a file VTK cannot parse is an error, not an empty collection."""
    from vtkmodules.vtkCommonCore import vtkCommand
    from vtkmodules.vtkIOXML import vtkXMLPartitionedDataSetCollectionReader

    errors = []
    reader = vtkXMLPartitionedDataSetCollectionReader()
    reader.GetExecutive().AddObserver(vtkCommand.ErrorEvent, lambda *args: errors.append(1))
    reader.AddObserver(vtkCommand.ErrorEvent, lambda *args: errors.append(1))
    reader.SetFileName(str(p))
    reader.Update()
    if errors or reader.GetOutput() is None:
        raise ValueError("VTK's reader of .vtpc files failed to parse it")
    return reader.GetOutput()


def read_volume(path, scalars=None, preference="point", formats=READABLE):
    """The :class:`~pv_hdrvol.GridVolume` or :class:`~pv_hdrvol.TetMesh` of array
    ``scalars`` (default: the active scalars) in file ``path``
    (:func:`pv_hdrvol.data.kinds.as_renderable`): the blocks of a ``.vtm``, ``.vtpc`` or
    ``.vtpd`` file gathered onto one volume or merged into one mesh.

    Raises
    ------
    FileNotFoundError, IsADirectoryError
        ``path`` is missing or a folder.
    ValueError
        Its extension is not one of ``formats``, ``pyvista.read`` cannot read it, it
        holds no dataset pv_hdrvol renders, its blocks do not make one volume or
        mesh, or it has no such array
        (:class:`~pv_hdrvol.ScalarsError`, which names the arrays there are). The
        messages about the file itself name it.
    """
    from .kinds import as_renderable

    return as_renderable(read_dataset(path, formats), scalars=scalars, preference=preference)
