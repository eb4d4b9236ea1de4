"""HDR Volume Render under MPI: ``mpiexec -n N pvbatch --mpi --symmetric`` this file.

Each rank's reader holds a piece of the volume; the filter must not render a piece as if
it were the whole. Rank 0 must hold the whole image, equal to ``pv_hdrvol.render`` of
the whole dataset; the other ranks an empty image. Exits non-zero on any rank that
finds otherwise. Run by tests/test_paraview.py.
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
    color_map_editor(rank)


def color_map_editor(rank):
    """Without a view, Scalars set after the filter is made (as a script does): every rank
    takes the array's colour map, rank 0 renders with it; SaveData (.exr) and HDR
    Tone Map work on every rank (rank 0 writes, the others hold no image)."""
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
    np.testing.assert_array_equal(got.rgba, expected.rgba)
    np.testing.assert_array_equal(hv.load(os.path.join(folder, "render.exr")).rgba, expected.rgba.astype(np.float32))
    assert shown.GetPointData().GetArray("tonemapped") is not None
    print(f"rank 0: the array's colour map, equal to hv.render with it; render.exr written",
          flush=True)


if __name__ == "__main__":
    try:
        main()
    except BaseException:
        import traceback

        traceback.print_exc()
        sys.stdout.flush()
        os._exit(1)
    sys.stdout.flush()
