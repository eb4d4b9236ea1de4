"""pv_hdrvol: high-dynamic-range volume rendering for PyVista, VTK and ParaView.

Public names only, re-exported from the stages that define them (``data`` -> ``rays``
-> ``raycast`` -> ``image`` -> ... -> ``integrations``; docs/development.md draws them).
``render``, ``view`` and ``add_hdr_volume`` come from :mod:`pv_hdrvol.dispatch`. Nothing
inside the package imports this module.
"""
from . import datasets
from .culling.bound import OcclusionBound
from .culling.cull import Culling
from .culling.pof import PlenopticOpacity
from .data.grid import GridVolume, ScalarsError, volume_from_array, volume_from_dataset, volume_from_rectilinear
from .data.tets import TetMesh, tetmesh_from_arrays, tetmesh_from_dataset
from .data.transfer import TransferFunction, TransferFunctionFamily
from .editor.model import TransferFunctionModel
from .gpu import DeviceUnavailableError
from .image.hdr import HDRImage, load
from .image.tonemap import ToneMapped, tonemap
from .image.upsample import upsample
from .outofcore.render import MultiscaleVolume, open_multiscale
from .outofcore.store import MultiscaleStore, write_multiscale
from .parallel.render import render_parallel
from .params import PRECISIONS, ClipPlane, Light, RenderOptions
from .proxy.generate import VolumeDistortionCamera, make_proxies
from .proxy.proxies import ProxyFormatError, ProxySet, load_proxies
from .rays.camera import Camera, Rays
from .rays.lenses import FeatureLens, Fisheye, Lens, Magnifier, SamplingRateLens
from .raycast.grid import BlockGrid, EmptyRenderWarning, render_volume
from .raycast.blocks import render_blocks
from .raycast.layers import DepthLayers, depth_layers
from .raycast.tets import render_tets
from .settings import RenderSettings
from .dispatch import add_hdr_volume, render, view

__version__ = "0.1.0"


def __getattr__(name):
    # the notebook editor needs ipywidgets: imported on first use, not with the package
    if name == "TransferFunctionEditor":
        from .viewer.notebook import TransferFunctionEditor

        return TransferFunctionEditor
    raise AttributeError(f"module 'pv_hdrvol' has no attribute {name!r}")


__all__ = [
    "datasets", "BlockGrid", "Camera", "Culling", "DepthLayers", "EmptyRenderWarning", "FeatureLens", "Fisheye",
    "ClipPlane", "GridVolume", "HDRImage", "Lens", "Light", "Magnifier", "OcclusionBound", "PRECISIONS", "PlenopticOpacity", "Rays",
    "RenderOptions", "RenderSettings", "SamplingRateLens", "ScalarsError", "TetMesh", "ToneMapped",
    "TransferFunction", "TransferFunctionFamily", "TransferFunctionModel", "depth_layers", "load", "render", "render_blocks", "render_parallel",
    "render_tets", "render_volume", "tetmesh_from_arrays", "tetmesh_from_dataset", "tonemap", "upsample",
    "volume_from_array", "volume_from_dataset", "volume_from_rectilinear", "view", "add_hdr_volume", "TransferFunctionEditor",
    "make_proxies", "load_proxies", "ProxySet", "ProxyFormatError", "VolumeDistortionCamera",
    "MultiscaleStore", "MultiscaleVolume", "open_multiscale", "write_multiscale", "DeviceUnavailableError",
]
