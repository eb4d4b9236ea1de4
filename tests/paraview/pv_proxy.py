"""A proxy folder written from a ParaView pipeline in pvbatch (the in-situ use: the
volume exists only here), then read back without the volume.

Run by tests/paraview/run.py inside pvbatch (see there); not collected by the main suite.
"""
import json

import numpy as np
import pytest
from paraview import servermanager, simple

import pv_hdrvol as hv
from pv_hdrvol.integrations.vtk_algorithm import HDRProxyWriter


def test_pvbatch_pipeline_writes_a_proxy_folder_that_loads_without_the_volume(tmp_path):
    pytest.importorskip("OpenEXR")
    source = simple.Wavelet(WholeExtent=[-12, 12, -12, 12, -12, 12])
    image = servermanager.Fetch(source)  # the volume, as a ParaView filter's input sees it
    writer = HDRProxyWriter()
    writer.SetInputDataObject(image)
    writer.SetImageSize(48, 40)
    writer.SetIntervals(8)
    writer.SetLayers([150.0])
    writer.SetMultiPerspective(True)
    writer.SetTraining(2)
    writer.SetClusters(4)
    writer.SetFileName(str(tmp_path / "wavelet.proxy"))
    writer.Update()  # returns None in ParaView 5.11's VTK
    assert writer.GetLastError() is None, writer.GetLastError()
    made = writer.proxies
    out = writer.GetOutput()
    assert out.GetDimensions() == (48, 40, 1)

    p = hv.load_proxies(tmp_path / "wavelet.proxy")
    assert (p.size, p.intervals, p.n_layers, p.model.clusters) == ((48, 40), 8, 1, made.model.clusters)
    # what was written is what was made, to float32
    np.testing.assert_allclose(p.atten, made.atten, rtol=1e-6, atol=1e-7)
    np.testing.assert_array_equal(p.model.lut(), made.model.lut())
    # the identity synthesis is the reference render itself
    img = p.synthesize()
    np.testing.assert_array_equal(img.rgba, p.rgba)
    # the Cinema index names the files
    rows = (tmp_path / "wavelet.proxy" / "data.csv").read_text().splitlines()
    assert rows[0].split(",")[-3:] == ["FILE", "FILE_proxies", "FILE_parameters"]
    meta = json.loads((tmp_path / "wavelet.proxy" / "proxies.json").read_text())
    assert meta["format"] == "pv_hdrvol proxies" and meta["pole_scale"] == 1.0
