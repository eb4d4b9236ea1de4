"""Inside pvbatch: time to the first HDR Volume Render image, then the render time of the
filter against ``hv.render`` of the same data, camera and transfer function in the same
process. Prints one JSON line. Run by benchmarks/bench_paraview.py (see there).
"""
import json
import os
import statistics
import sys
import time

T0 = time.perf_counter()
from paraview import servermanager, simple  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = {"engine": ("structured/engine_256x256x128_uint8.vti", "ImageFile"),
        "bluntfin": ("unstructured/bluntfin_187395tets.vtu", "Density")}


def main(name, size, repeats, data_root, transfer_function="pv_hdrvol default"):
    path, array = DATA[name]
    simple.LoadPlugin(os.path.join(ROOT, "paraview_plugin", "pv_hdrvol_plugin.py"), ns=vars(simple))
    t_plugin = time.perf_counter() - T0
    reader = simple.OpenDataFile(os.path.join(data_root, path))
    reader.UpdatePipeline()
    t_read = time.perf_counter() - T0
    render = simple.HDRVolumeRender(Input=reader, ImageSize=[size, size], Camera="iso",
                                    TransferFunction=transfer_function)
    render.Scalars = ["POINTS", array]
    render.UpdatePipeline()
    t_first = time.perf_counter() - T0
    error = render.GetClientSideObject().GetLastError()
    if error:
        raise RuntimeError(error)

    import numba

    import pv_hdrvol as hv

    image = hv.HDRImage.from_pyvista(servermanager.Fetch(render))
    settings = image.settings()
    data = servermanager.Fetch(reader)
    hv.render(data, settings.tf, settings.camera, (size, size), scalars=array, progress_bar=False)  # warm
    in_paraview, direct = [], []
    for i in range(repeats):  # alternate, so that load changes hit both alike
        render.GlobalAlpha = 1.0 - 0.01 * (i + 1)  # a property change: the filter re-executes
        t = time.perf_counter()
        render.UpdatePipeline()
        in_paraview.append(time.perf_counter() - t)
        t = time.perf_counter()
        hv.render(data, settings.tf, settings.camera, (size, size), scalars=array, progress_bar=False,
                  global_alpha=1.0 - 0.01 * (i + 1))
        direct.append(time.perf_counter() - t)
    print(json.dumps({"data": name, "size": size, "numba": numba.__version__,
                      "cache": os.environ.get("NUMBA_CACHE_DIR"), "transfer_function": transfer_function,
                      "t_plugin": t_plugin, "t_read": t_read,
                      "t_first_image": t_first, "render_paraview": statistics.median(in_paraview),
                      "render_hv": statistics.median(direct)}), flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    main(args[0], int(args[1]), int(args[2]), args[3], *args[4:5])
    sys.stdout.flush()
    os._exit(0)
