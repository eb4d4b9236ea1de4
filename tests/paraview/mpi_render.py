"""HDR Volume Render under MPI: ``mpiexec -n N pvbatch --mpi --symmetric`` this file.

With the Color Map Editor's function, each rank's reader reads only its piece of the
image (VTK's extent translator's), the rank renders it, and rank 0 holds the whole
image, equal to ``pv_hdrvol.render`` of the whole dataset to 1e-5; the other ranks an
empty image. A curvilinear grid (``$PV_HDRVOL_MPI_CURVI``) is read by pieces too and
rendered as tetrahedra where it lives. Without a function given (pv_hdrvol's default reads every value) and for a
tetrahedral mesh, rank 0 reads and renders everything, bit for bit ``pv_hdrvol.render``.
No rank renders a piece as if it were the whole. A level of a multiresolution store
(``$PV_HDRVOL_MPI_STORE``) renders as the whole store, out of core, on rank 0. Exits
non-zero on any rank that finds
otherwise. Run by tests/integrations/test_paraview.py with 2 and 3 ranks.
"""
import os
import sys

import numpy as np
from paraview import servermanager, simple
from vtkmodules.vtkIOXML import vtkXMLImageDataReader, vtkXMLUnstructuredGridReader

import pv_hdrvol as hv

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
DATA = os.environ.get("PV_HDRVOL_DATA", os.path.join(os.path.dirname(ROOT), "shared", "data"))
CASES = [("structured/engine_256x256x128_uint8.vti", "ImageFile", vtkXMLImageDataReader),
         ("unstructured/bluntfin_187395tets.vtu", "Density", vtkXMLUnstructuredGridReader)]


def main():
    controller = servermanager.vtkProcessModule.GetProcessModule().GetGlobalController()
    rank, size = controller.GetLocalProcessId(), controller.GetNumberOfProcesses()
    assert size > 1, "run under mpiexec -n 2 (or more) pvbatch --mpi --symmetric"
    simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))
    where_the_data_lives(rank, size)
    store_out_of_core(controller, rank)
    for redistribute in (False, True):
        mesh_where_it_lives(rank, size, redistribute)
    for name, array, whole_reader in CASES:
        reader = simple.OpenDataFile(os.path.join(DATA, name))
        reader.UpdatePipeline()
        piece = reader.GetClientSideObject().GetOutputDataObject(0).GetNumberOfPoints()  # before the render
        render = simple.HDRVolumeRender(Input=reader, ImageSize=[32, 24], Camera="iso",
                                        TransferFunction="pv_hdrvol default")
        render.Scalars = ["POINTS", array]
        render.UpdatePipeline()
        out = render.GetClientSideObject().GetOutputDataObject(0)
        if rank != 0:
            assert out.GetNumberOfPoints() == 0, (rank, name, out.GetNumberOfPoints())
            print(f"rank {rank}: {name}: a piece of {piece} points, an empty image", flush=True)
            continue
        whole = whole_reader()
        whole.SetFileName(os.path.join(DATA, name))
        whole.Update()
        if name.endswith(".vti"):  # an image splits by extent (a one-piece .vtu goes to rank 0 whole)
            assert piece < whole.GetOutput().GetNumberOfPoints(), "the reader did not split the image"
        got = hv.HDRImage.from_pyvista(out)
        expected = hv.render(whole.GetOutput(), None, "iso", (32, 24), scalars=array, progress_bar=False)
        assert got.rgba[..., 3].max() > 0.05
        np.testing.assert_array_equal(got.rgba, expected.rgba)
        print(f"rank 0: {name}: a piece of {piece} points; the whole image, equal to hv.render of the whole "
              f"dataset", flush=True)
        simple.Delete(render)
        simple.Delete(reader)
    color_map_editor(rank, size)
    curvilinear_where_it_lives(rank, size)
    curvilinear_where_it_lives(rank, size, "rectilinear")


def curvilinear_where_it_lives(rank, size, kind="curvilinear"):
    """A curvilinear grid (.vts of $PV_HDRVOL_MPI_CURVI, written by the test) with its
    colour map: each rank's reader reads its piece of the extent, the rank splits it
    into the tetrahedra a whole render makes (the lattice decides, so pieces agree on
    their shared faces), the mesh path cuts them into boxes, and rank 0's composite is
    hv.render of the whole grid to 1e-10 (float64). ``kind="rectilinear"``: a graded
    rectilinear grid (.vtr of $PV_HDRVOL_MPI_RECT), each piece sampling the whole
    grid's lattice, to the early termination's 2e-6."""
    from vtkmodules.vtkIOXML import vtkXMLRectilinearGridReader, vtkXMLStructuredGridReader

    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    path = os.environ["PV_HDRVOL_MPI_CURVI" if kind == "curvilinear" else "PV_HDRVOL_MPI_RECT"]
    reader = simple.OpenDataFile(path)
    render = simple.HDRVolumeRender(Input=reader, ImageSize=[48, 40], Camera="iso", Precision="float64")
    render.Scalars = ["POINTS", "f"]
    lut, opacity = simple.GetColorTransferFunction("f"), simple.GetOpacityTransferFunction("f")
    render.UpdatePipeline()
    piece = reader.GetClientSideObject().GetOutputDataObject(0)
    out = render.GetClientSideObject().GetOutputDataObject(0)
    whole = vtkXMLStructuredGridReader() if kind == "curvilinear" else vtkXMLRectilinearGridReader()
    whole.SetFileName(path)
    whole.Update()
    cells = whole.GetOutput().GetNumberOfCells()
    assert piece.GetNumberOfCells() < cells, (rank, piece.GetExtent())  # its piece, not the whole grid
    if rank != 0:
        assert out.GetNumberOfPoints() == 0
        print(f"rank {rank}: {kind} piece {piece.GetExtent()} of {cells} cells, rendered", flush=True)
        simple.Delete(render)
        return
    tf = transfer_function_from_vtk(lut.GetClientSideObject(), opacity.GetClientSideObject())
    expected = hv.render(whole.GetOutput(), tf, "iso", (48, 40), scalars="f", precision="float64", progress_bar=False)
    got = hv.HDRImage.from_pyvista(out)
    assert expected.rgba[..., 3].max() > 0.5
    difference = float(np.abs(got.rgba - expected.rgba).max())
    assert difference <= (1e-10 if kind == "curvilinear" else 2e-6), difference
    print(f"rank 0: {kind} piece {piece.GetExtent()} of {cells} cells; the whole image of {size} pieces, within "
          f"{difference:.1e} of hv.render", flush=True)
    simple.Delete(render)
    simple.Delete(reader)


def where_the_data_lives(rank, size):
    """The engine CT with its colour map: each rank reads its extent only (about 1/size
    of the volume), rank 0 composites the whole image."""
    from pv_hdrvol.integrations.vtk_pieces import piece_extent
    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    name, array, whole_reader = CASES[0]
    reader = simple.OpenDataFile(os.path.join(DATA, name))
    render = simple.HDRVolumeRender(Input=reader, ImageSize=[48, 40], Camera="iso")
    render.Scalars = ["POINTS", array]
    lut, opacity = simple.GetColorTransferFunction(array), simple.GetOpacityTransferFunction(array)
    render.UpdatePipeline()
    piece = reader.GetClientSideObject().GetOutputDataObject(0)
    whole_extent = (0, 255, 0, 255, 0, 127)
    assert piece.GetExtent() == piece_extent(whole_extent, rank, size, 0), (rank, piece.GetExtent())
    memory = piece.GetActualMemorySize()  # kB
    out = render.GetClientSideObject().GetOutputDataObject(0)
    if rank != 0:
        assert out.GetNumberOfPoints() == 0
        print(f"rank {rank}: read its piece {piece.GetExtent()}, {memory} kB; rendered it", flush=True)
        return
    whole = whole_reader()
    whole.SetFileName(os.path.join(DATA, name))
    whole.Update()
    whole_memory = whole.GetOutput().GetActualMemorySize()
    assert memory < 1.1 * whole_memory / size, (memory, whole_memory)
    tf = transfer_function_from_vtk(lut.GetClientSideObject(), opacity.GetClientSideObject())
    expected = hv.render(whole.GetOutput(), tf, "iso", (48, 40), scalars=array, progress_bar=False)
    got = hv.HDRImage.from_pyvista(out)
    assert expected.rgba[..., 3].max() > 0.5
    difference = float(np.abs(got.rgba.astype(np.float64) - expected.rgba).max())
    assert difference <= 1e-5, difference
    assert got.metadata["pieces"] == size
    print(f"rank 0: read its piece {piece.GetExtent()}, {memory} kB of the whole {whole_memory} kB; the whole "
          f"image of {size} pieces, within {difference:.1e} of hv.render", flush=True)
    simple.Delete(render)
    simple.Delete(reader)


def mesh_where_it_lives(rank, size, redistribute):
    """The Blunt Fin's tetrahedra with their colour map, read on rank 0 (a one-piece file)
    or spread by RedistributeDataSet: the filter cuts the bounds into one box per rank,
    moves every cell to each box it meets, each rank renders the segments in its box,
    rank 0 composites; a second view renders the cells already moved."""
    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    name, array, whole_reader = CASES[1]
    reader = simple.OpenDataFile(os.path.join(DATA, name))
    source = simple.RedistributeDataSet(Input=reader) if redistribute else reader
    render = simple.HDRVolumeRender(Input=source, ImageSize=[48, 40], Camera="iso")
    render.Scalars = ["POINTS", array]
    lut, opacity = simple.GetColorTransferFunction(array), simple.GetOpacityTransferFunction(array)
    render.UpdatePipeline()
    given = source.GetClientSideObject().GetOutputDataObject(0)
    rendered = render.GetClientSideObject().GetLastPiece()
    cells = rendered.GetNumberOfCells()
    how = "RedistributeDataSet" if redistribute else "the reader"
    out = render.GetClientSideObject().GetOutputDataObject(0)
    first = hv.HDRImage.from_pyvista(out) if rank == 0 else None
    render.Camera = "xy"  # another view: the cells stay where they were moved
    render.UpdatePipeline()
    assert render.GetClientSideObject().GetLastPiece() is rendered
    turned = hv.HDRImage.from_pyvista(out) if rank == 0 else None
    total = 187395
    assert cells < 1.25 * total / size, (rank, cells)  # its box's cells and those that cross a cut
    line = (f"{name} from {how}: given {given.GetNumberOfCells()} cells, rendered {cells} "
            f"({rendered.GetActualMemorySize()} kB)")
    if rank != 0:
        assert out.GetNumberOfPoints() == 0
        print(f"rank {rank}: {line}", flush=True)
        simple.Delete(render)
        return
    whole = whole_reader()
    whole.SetFileName(os.path.join(DATA, name))
    whole.Update()
    tf = transfer_function_from_vtk(lut.GetClientSideObject(), opacity.GetClientSideObject())
    difference = 0.0
    for got, view in ((first, "iso"), (turned, "xy")):
        expected = hv.render(whole.GetOutput(), tf, view, (48, 40), scalars=array, progress_bar=False)
        assert expected.rgba[..., 3].max() > 0.5
        difference = max(difference, float(np.abs(got.rgba.astype(np.float64) - expected.rgba).max()))
    assert difference <= 1e-5, difference
    print(f"rank 0: {line}; the whole image of {size} boxes, within {difference:.1e} of hv.render "
          f"(whole mesh {whole.GetOutput().GetActualMemorySize()} kB)", flush=True)
    simple.Delete(render)


def color_map_editor(rank, size):
    """Without a view, Scalars set after the filter is made (as a script does): every rank
    takes the array's colour map, the ranks render their pieces with it; SaveData (.exr)
    and HDR Tone Map work on every rank (rank 0 writes, the others hold no image; the
    writer asks each rank for its piece, so every reader holds only its own)."""
    from pv_hdrvol.integrations.vtk_pieces import piece_extent
    from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

    name, array, whole_reader = CASES[0]
    reader = simple.OpenDataFile(os.path.join(DATA, name))
    render = simple.HDRVolumeRender(Input=reader, ImageSize=[32, 24], Camera="iso")
    render.Scalars = ["POINTS", array]
    lut = simple.GetColorTransferFunction(array)
    assert render.LookupTable == lut, (rank, render.LookupTable)
    assert render.ScalarOpacityFunction == simple.GetOpacityTransferFunction(array)
    render.UpdatePipeline()
    out = render.GetClientSideObject().GetOutputDataObject(0)
    folder = os.environ["PV_HDRVOL_MPI_OUT"]
    simple.SaveData(os.path.join(folder, "render.exr"), proxy=simple.OutputPort(render, 0))
    simple.SaveData(os.path.join(folder, "render.png"), proxy=simple.OutputPort(render, 0))
    # the writer asked for this rank's piece: the reader holds only that, on every rank
    read = reader.GetClientSideObject().GetOutputDataObject(0).GetExtent()
    assert read == piece_extent((0, 255, 0, 255, 0, 127), rank, size, 0), (rank, read)
    tonemap = simple.HDRToneMap(Input=simple.OutputPort(render, 0))
    tonemap.UpdatePipeline()
    shown = tonemap.GetClientSideObject().GetOutputDataObject(0)
    if rank != 0:
        assert out.GetNumberOfPoints() == 0 and shown.GetNumberOfPoints() == 0
        print(f"rank {rank}: the array's colour map; no image, nothing written", flush=True)
        return
    whole = whole_reader()
    whole.SetFileName(os.path.join(DATA, name))
    whole.Update()
    tf = transfer_function_from_vtk(lut.GetClientSideObject(), simple.GetOpacityTransferFunction(array)
                                    .GetClientSideObject())
    expected = hv.render(whole.GetOutput(), tf, "iso", (32, 24), scalars=array, progress_bar=False)
    got = hv.HDRImage.from_pyvista(out)
    np.testing.assert_allclose(got.rgba, expected.rgba, rtol=0, atol=1e-5)
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOImage import vtkPNGReader

    png = vtkPNGReader()
    png.SetFileName(os.path.join(folder, "render.png"))
    png.Update()
    np.testing.assert_array_equal(vtk_to_numpy(png.GetOutput().GetPointData().GetScalars()),
                                  vtk_to_numpy(out.GetPointData().GetArray("tonemapped")))  # what the view shows
    saved = hv.load(os.path.join(folder, "render.exr"))
    np.testing.assert_array_equal(saved.rgba, got.rgba.astype(np.float32))
    assert shown.GetPointData().GetArray("tonemapped") is not None
    print("rank 0: the array's colour map, within 1e-5 of hv.render with it; render.exr and render.png written",
          flush=True)


def store_out_of_core(controller, rank):
    """A level of a multiresolution store (``$PV_HDRVOL_MPI_STORE``, written here by rank
    0) with the array's colour map: rank 0 renders the whole store out of core,
    ``open_multiscale(...).render`` bit for bit; the other ranks output empty images."""
    path = os.environ["PV_HDRVOL_MPI_STORE"]
    if rank == 0:
        z, y, x = np.mgrid[0:70, 0:80, 0:90].astype(np.float32)
        values = np.exp(-((x - 45) ** 2 + (y - 40) ** 2 + (z - 35) ** 2) / 500.0).astype(np.float32)
        hv.write_multiscale(values, path, spacing=(0.5, 0.75, 1.0), name="blob", progress_bar=False, overwrite=True)
    controller.Barrier()
    reader = simple.OpenDataFile(path)
    reader.Level = 1
    lut = simple.GetColorTransferFunction("blob")
    pwf = simple.GetOpacityTransferFunction("blob")
    lut.RGBPoints = [0.0, 0.0, 0.0, 0.3, 1.0, 1.0, 1.0, 1.0]
    pwf.Points = [0.0, 0.0, 0.5, 0.0, 1.0, 0.6, 0.5, 0.0]
    render = simple.HDRVolumeRender(Input=reader, ImageSize=[48, 40], Camera="iso", LookupTable=lut,
                                    ScalarOpacityFunction=pwf)
    render.Scalars = ["POINTS", "blob"]
    for size in ((48, 40), (40, 32)):  # the second execution: the reader's field data there from the start
        render.ImageSize = list(size)
        render.UpdatePipeline()
        out = render.GetClientSideObject().GetOutputDataObject(0)
        if rank != 0:
            assert out.GetNumberOfPoints() == 0, out.GetNumberOfPoints()
            continue
        from pv_hdrvol.integrations.vtk_transfer import transfer_function_from_vtk

        tf = transfer_function_from_vtk(lut.GetClientSideObject(), pwf.GetClientSideObject())
        with hv.open_multiscale(path) as volume:
            expected = volume.render(tf, hv.Camera.fit(volume.bounds, "iso"), size)
        got = hv.HDRImage.from_pyvista(out)
        assert got.rgba[..., 3].max() > 0.2
        np.testing.assert_array_equal(got.rgba, expected.rgba)
    print(f"rank {rank}: a store's level in: " + ("the store out of core, open_multiscale's render bit for bit"
                                                   if rank == 0 else "no image"), flush=True)
    simple.Delete(render)
    simple.Delete(reader)


if __name__ == "__main__":
    try:
        main()
    except BaseException:
        import traceback

        traceback.print_exc()
        sys.stdout.flush()
        os._exit(1)
    sys.stdout.flush()
