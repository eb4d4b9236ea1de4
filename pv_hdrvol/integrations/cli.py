"""The ``pv-hdrvol`` command: render volumes to OpenEXR from a shell.

::

    pv-hdrvol render volume.vti --scalars density -o out.exr --png out.png --size 800 600
    pv-hdrvol render volume.vti -o out.exr --png figure.png --tonemap drago --colorbar
    pv-hdrvol render volume.vti -o out.exr --tolerance 1e-3
    pv-hdrvol demo -o outdir --size 128
    pv-hdrvol info out.exr
    pv-hdrvol convert big.raw big.ome.zarr --raw-shape 1024 1024 1024 --raw-dtype float32

User errors (missing files, unknown scalars, invalid options) end with an
argparse-style message on stderr and exit status 2, without a traceback.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import shlex
import sys

from .. import __version__
from ..data.transfer import SCALES
from ..image.tonemap import OPERATORS
from ..params import BLENDINGS, DEVICES, PRECISIONS

from ..data.files import BLOCK_FORMATS, IMAGE_FORMATS, MESH_FORMATS, READABLE  # what render and view read; proxies: images

VIEWS = ("iso", "xy", "yx", "xz", "zx", "yz", "zy")


class UserError(Exception):
    """A problem with the command line or the files it names (exit status 2)."""


def _size(values):
    if len(values) == 1:
        return values[0], values[0]
    if len(values) == 2:
        return values[0], values[1]
    raise UserError(f"--size takes N or W H; got {len(values)} numbers: {' '.join(map(str, values))}")


def _add_render_options(p):
    p.add_argument("--size", type=int, nargs="+", default=[512], metavar="N",
                   help="image size: N (square) or W H (default 512)")
    p.add_argument("--step", type=float, default=None, help="sample distance in voxels (default 0.5)")
    p.add_argument("--precision", choices=PRECISIONS, default=None, help="compositing precision (default float32)")
    p.add_argument("--tolerance", type=float, default=None, metavar="TOL",
                   help="the accuracy you accept instead of --step and --precision: the RMS error of the linear RGB "
                        "image against the converged render, relative to its peak, in (0, 0.5], e.g. 1e-3; the "
                        "renderer chooses the step, termination, table size and precision (pv-hdrvol info prints "
                        "them)")
    p.add_argument("--global-alpha", type=float, default=None, help="opacity multiplier in (0, 1]")
    p.add_argument("--blending", choices=BLENDINGS, default=None,
                   help="composite (default), maximum/minimum intensity projection, average, or additive (X-ray); "
                        "projections also store the projected value (EXR channel V)")
    p.add_argument("--view", default=None, metavar="VIEW", help=f"camera direction, one of {', '.join(VIEWS)}")
    p.add_argument("--device", choices=DEVICES, default=None,
                   help="where an image volume renders: cpu (default) or cuda (an NVIDIA GPU through numba-cuda: "
                        "pip install 'pv_hdrvol[gpu]')")
    g = p.add_argument_group("lenses (image volumes; pv_hdrvol.Magnifier and Fisheye)")
    g.add_argument("--magnifier", type=float, nargs=4, default=None, metavar=("COL", "ROW", "RADIUS", "FACTOR"),
                   help="a circular magnifier centred at pixel (COL, ROW), RADIUS pixels, magnifying FACTOR times")
    g.add_argument("--fisheye", type=float, default=None, metavar="DEGREES",
                   help="an equidistant fisheye of this field of view over the whole image")
    g = p.add_argument_group("shading (Blinn-Phong by the gradient; composite blending)")
    g.add_argument("--shade", action="store_true", default=None, help="light the volume (default: unlit)")
    g.add_argument("--ambient", type=float, default=None, help="ambient weight (default 0.1)")
    g.add_argument("--diffuse", type=float, default=None, help="diffuse weight (default 0.7)")
    g.add_argument("--specular", type=float, default=None, help="specular weight (default 0.2)")
    g.add_argument("--specular-power", type=float, default=None, help="specular exponent (default 10)")
    g.add_argument("--light", type=float, nargs=3, action="append", default=None, metavar=("X", "Y", "Z"),
                   help="a white light from this world direction (repeatable; default: a headlight)")
    g = p.add_argument_group("clipping (grids, meshes and blocks; cut exactly, VTK's convention)")
    g.add_argument("--clip-plane", type=float, nargs=6, action="append", default=None,
                   metavar=("OX", "OY", "OZ", "NX", "NY", "NZ"),
                   help="cut the volume with the plane through (OX, OY, OZ) of normal (NX, NY, NZ), keeping the side "
                        "the normal points to (repeatable)")
    g.add_argument("--crop-box", type=float, nargs=6, default=None,
                   metavar=("XMIN", "XMAX", "YMIN", "YMAX", "ZMIN", "ZMAX"), help="keep only this world box")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="show a progress bar (default: when stderr is a terminal)")


def add_transfer_function_options(parser):
    """Add ``--cmap``, ``--clim``, ``--opacity`` and ``--scale`` to ``parser``: the Python
    API's ``cmap=``, ``clim=``, ``opacity=``, ``scale=`` (:func:`transfer_function_words`
    reads them), shared by ``pv-hdrvol render`` and ``python -m pv_hdrvol.parallel render``."""
    tf = parser.add_argument_group("transfer function (default: chosen from the data, as the Python API chooses; "
                                   "each option replaces one choice; the Python API's cmap=, clim=, opacity=, "
                                   "scale=)")
    tf.add_argument("--cmap", default=None, help="matplotlib colormap name (default magma, without its black end)")
    tf.add_argument("--clim", nargs=2, default=None, metavar=("LOW", "HIGH"),
                    help="where colours and opacity start and end; 'auto' keeps the default's end (default: past "
                         "the histogram's background mode, to the 99.9th percentile)")
    tf.add_argument("--opacity", nargs="+", default=None, metavar="A",
                    help="opacity over one voxel: one number, numbers spread evenly from LOW to HIGH, or a "
                         "PyVista curve name (linear, sigmoid, geom_r, ...) (default: 0, rising to what keeps "
                         "the densest rays readable)")
    tf.add_argument("--scale", choices=SCALES, default=None,
                    help="axis (default: log when the positive data span > 3 decades)")


def transfer_function_words(args):
    """``--cmap``, ``--clim``, ``--opacity``, ``--scale`` (:func:`add_transfer_function_options`)
    as the keywords ``cmap=``, ``clim=``, ``opacity=``, ``scale=`` of
    :func:`~pv_hdrvol.raycast.grid.resolve_render_options` (``None`` where not given),
    which gives them their meaning.

    Raises
    ------
    ValueError
        A ``--clim`` end (other than ``auto``) or an ``--opacity`` among several that is
        not a number, named with its option.
    """
    return {"cmap": args.cmap, "clim": _clim(args.clim), "opacity": _opacity(args.opacity), "scale": args.scale}


def _add_preview_options(p, png_option):
    g = p.add_argument_group(f"PNG preview ({png_option})")
    g.add_argument("--tonemap", choices=sorted(OPERATORS), default=None, metavar="NAME",
                   help=f"tone-mapping operator of the preview, one of {', '.join(sorted(OPERATORS))} "
                        f"(pv_hdrvol.tonemap with its default parameters; default: auto exposure and clamp)")
    g.add_argument("--colorbar", action="store_true",
                   help="add the transfer function's colour bar, ticks in data units (log ticks on a log axis), "
                        "to the right of the preview (needs matplotlib)")


def build_parser():
    """The ``argparse`` parser of ``pv-hdrvol``: one builder per sub-command (render, view, demo,
    info, proxy, convert, paraview), each adding its parser to ``sub``."""
    parser = argparse.ArgumentParser(prog="pv-hdrvol", description="High-dynamic-range volume rendering to OpenEXR.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    _add_render_command(sub)
    _add_view_command(sub)
    _add_demo_command(sub)
    _add_info_command(sub)
    _add_proxy_command(sub)
    _add_convert_command(sub)
    _add_paraview_command(sub)
    return parser


def _add_render_command(sub):
    """Add ``pv-hdrvol render``: a volume or mesh file to a float OpenEXR image."""
    p = sub.add_parser("render", help=f"render a volume or mesh file ({', '.join(READABLE)})",
                       description="Render an image volume or a tetrahedral mesh read with pyvista.read to a float "
                                   "OpenEXR image. Gaussian cube files (.cube) are rendered as pyvista.read gives "
                                   "them: in grid index units (spacing 1, origin 0, axis-aligned), without the "
                                   "cube's own origin, step and axis directions (a note on stderr says so). "
                                   "Camera: perspective, 30-degree vertical view angle, framing the data's bounding "
                                   "sphere from --view (default iso); orthographic with --pof (POF culling assumes "
                                   "parallel rays). python -m pv_hdrvol.parallel render uses the same camera.")
    p.add_argument("file", metavar="FILE",
                   help=f"image volume, rectilinear or curvilinear grid, tetrahedral mesh or blocks of those, "
                        f"one of {', '.join(READABLE)} (meshes: {', '.join(MESH_FORMATS)}; blocks, rendered as one "
                        f"scene: {', '.join(BLOCK_FORMATS)})")
    p.add_argument("--scalars", default=None, metavar="NAME", help="array to render (default: active scalars)")
    p.add_argument("-o", "--output", default=None, metavar="OUT.exr",
                   help="output image, .exr or .npy (default: FILE's stem + .exr in the current directory)")
    p.add_argument("--png", default=None, metavar="OUT.png",
                   help="also write an 8-bit preview (auto exposure, or --tonemap)")
    _add_render_options(p)
    _add_preview_options(p, "--png")
    add_transfer_function_options(p)
    p.set_defaults(handler=_cmd_render, subparser=p)
    g = p.add_argument_group("visibility culling (image volumes; an orthographic camera; docs/culling.md)")
    g.add_argument("--pof", default=None, metavar="FILE.npz",
                   help="plenoptic opacity functions of this volume (python -m pv_hdrvol.parallel pof): render the "
                        "family of their bases and skip the blocks they show hidden")
    g.add_argument("--k", type=float, nargs="+", default=None, metavar="K",
                   help="the family's weights, one per basis of --pof (default all 1)")


def _add_view_command(sub):
    """Add ``pv-hdrvol view``: the interactive Qt viewer on a file or a store."""
    p = sub.add_parser("view", help="explore a volume or mesh file in a window (Qt)",
                       description="Open the interactive viewer (pv_hdrvol.viewer.qt.HDRViewer): orbit, edit the "
                                   "transfer function, tone-map, probe HDR values, a magnifier lens, save EXR/PNG. "
                                   "Needs Qt (pip install 'pv_hdrvol[gui]') and a display.")
    p.add_argument("file", metavar="FILE", help=f"image volume, rectilinear or curvilinear grid, tetrahedral mesh or "
                                                f"blocks of those, one of {', '.join(READABLE)}; or a "
                                                f"multiresolution store (a folder, 'pv-hdrvol convert'), rendered "
                                                f"out of core: coarse levels while the view moves, finer as they load")
    p.add_argument("--scalars", default=None, metavar="NAME", help="array to render (default: active scalars)")
    p.add_argument("--tf", default=None, metavar="FILE.json",
                   help="transfer function to start from: the editor's JSON, a TransferFunction's JSON or a "
                        "ParaView preset file (its first preset, rescaled onto the data's range as ParaView's "
                        "ApplyPreset does; a preset pv_hdrvol wrote keeps its own range)")
    p.add_argument("--precision", choices=("float32", "float64"), default="float32",
                   help="compositing precision (default float32)")
    p.set_defaults(handler=_cmd_view, subparser=p)


def _add_demo_command(sub):
    """Add ``pv-hdrvol demo``: the hydrogen orbital, no input needed."""
    p = sub.add_parser("demo", help="render the hydrogen 3d_z2 orbital (no input needed)",
                       description="Render pv_hdrvol.datasets.hydrogen_orbital() with its demo transfer function "
                                   "and write demo.exr and demo.png.")
    p.add_argument("-o", "--output-dir", default=".", metavar="DIR", help="directory for demo.exr and demo.png")
    p.add_argument("--orbital", type=int, nargs=3, default=(3, 2, 0), metavar=("N", "L", "M"),
                   help="quantum numbers (default 3 2 0)")
    p.add_argument("--grid", type=int, default=64, metavar="N", help="volume points per axis (default 64)")
    _add_render_options(p)
    _add_preview_options(p, "demo.png")
    p.set_defaults(handler=_cmd_demo, subparser=p)


def _add_info_command(sub):
    """Add ``pv-hdrvol info``: an image's statistics, render settings and metadata."""
    p = sub.add_parser("info", help="print the statistics, render settings and metadata of an image",
                       description="Print the statistics, render settings and metadata of an image written by "
                                   "pv-hdrvol (.exr, .hdr, .npy). The settings re-render the image in Python: "
                                   "pv_hdrvol.load(FILE).settings().render(data).")
    p.add_argument("file", metavar="FILE.exr", help="image file (.exr, .hdr or .npy)")
    p.add_argument("--json", action="store_true",
                   help="print the metadata as JSON instead (all of the settings: every control point)")
    p.set_defaults(handler=_cmd_info, subparser=p)


def _add_proxy_command(sub):
    """Add ``pv-hdrvol proxy`` and its actions ``make`` and ``view``."""
    p = sub.add_parser("proxy", help="proxy images: make them from a volume, synthesise images from them",
                       description="Visualization by proxy (docs/proxy.md): 'make' casts a volume once into a "
                                   "proxy folder (multi-channel OpenEXR, JSON, a Cinema index); 'view' synthesises "
                                   "an image from the folder alone: another opacity per intensity interval, a "
                                   "rotated view, lighting, enhancement.")
    psub = p.add_subparsers(dest="proxy_command", metavar="ACTION", required=True)
    _add_proxy_make_command(psub)
    _add_proxy_view_command(psub)


def _add_proxy_make_command(psub):
    """Add ``pv-hdrvol proxy make``: cast a volume file into a proxy folder."""
    q = psub.add_parser("make", help="cast a volume file into a proxy folder")
    q.add_argument("file", metavar="FILE", help=f"image volume, one of {', '.join(IMAGE_FORMATS)} (proxies are made "
                                                f"of image data: not of tetrahedral meshes)")
    q.add_argument("output", metavar="FOLDER", help="proxy folder to write (created)")
    q.add_argument("--scalars", default=None, metavar="NAME", help="array to use (default: active scalars)")
    q.add_argument("--size", type=int, nargs="+", default=[512], metavar="N",
                   help="image size: N (square) or W H (default 512)")
    q.add_argument("--view", default="iso", metavar="VIEW",
                   help=f"direction of the parallel view, one of {', '.join(VIEWS)} (default iso)")
    q.add_argument("--intervals", type=int, default=16, metavar="L", help="intensity intervals (default 16)")
    g = q.add_mutually_exclusive_group()
    g.add_argument("--layers", type=float, nargs="+", default=None, metavar="ISO",
                   help="isovalues of depth layers")
    g.add_argument("--peaks", type=int, default=None, metavar="K",
                   help="K depth layers at the highest peaks of the opacity")
    q.add_argument("--multi-perspective", action="store_true",
                   help="also cast along the distortion camera's 45-degree rays (rotation up to 60 degrees)")
    q.add_argument("--training", type=int, default=3, metavar="N",
                   help="training renders of the colour model (default 3; 0: no model)")
    q.add_argument("--clusters", type=int, default=24, metavar="K", help="clusters of the colour model (default 24)")
    q.add_argument("--step", type=float, default=0.5, help="sample distance in voxels (default 0.5)")
    q.set_defaults(handler=_cmd_proxy_make, subparser=q)


def _add_proxy_view_command(psub):
    """Add ``pv-hdrvol proxy view``: the proxy viewer, or one image synthesised from a folder."""
    q = psub.add_parser("view", help="explore a proxy folder in a window, or synthesise an image from it",
                        description="Without -o: open the proxy viewer (Qt; pip install 'pv_hdrvol[gui]'), "
                                    "with sliders for each interval's opacity, the view, lighting, layers and "
                                    "enhancement. With -o: synthesise one image from the folder (no volume "
                                    "needed) and write it (.exr keeps it linear; .png tone-maps it).")
    q.add_argument("folder", metavar="FOLDER", help="proxy folder (pv-hdrvol proxy make)")
    q.add_argument("-o", "--output", default=None, metavar="OUT", help="image to write: .exr, .npy or .png")
    q.add_argument("--opacity", nargs="+", default=None, metavar="I=K",
                   help="scale the extinction of interval I by K (0 removes it), e.g. --opacity 3=0.2 7=0")
    q.add_argument("--rotate", type=float, nargs=2, default=None, metavar=("AZIMUTH", "ELEVATION"),
                   help="turn the view about the focal point, degrees")
    q.add_argument("--light", type=float, nargs=3, action="append", default=None, metavar=("X", "Y", "Z"),
                   help="relight with a white light from this world direction (repeatable)")
    q.add_argument("--headlight", action="store_true", help="relight with a headlight")
    q.add_argument("--enhance", type=float, default=None, metavar="LAMBDA",
                   help="depth-aware enhancement strength (paper Eq. 11)")
    q.add_argument("--layer", nargs=5, action="append", default=None, metavar=("J", "R", "G", "B", "OPACITY"),
                   help="draw depth layer J in this colour and opacity instead of the volume (repeatable)")
    q.add_argument("--ambient-occlusion", type=float, default=None, metavar="STRENGTH",
                   help="layers: proxy ambient occlusion (paper Eq. 5)")
    q.set_defaults(handler=_cmd_proxy_view, subparser=q)


def _add_convert_command(sub):
    """Add ``pv-hdrvol convert``: a volume file to a multiresolution OME-Zarr store."""
    p = sub.add_parser("convert", help="write a volume as a multiresolution OME-Zarr store (volumes larger than "
                                       "memory)",
                       description="Write a volume file as a multiresolution OME-Zarr 0.5 store "
                                   "(pv_hdrvol.write_multiscale): every level 2x coarser than the one below, in "
                                   "64^3 chunks with per-chunk value ranges, read a shard at a time so the volume "
                                   "never has to fit in memory. IN is a .raw file (x fastest; give --raw-shape and "
                                   "--raw-dtype) or an image volume (" + ", ".join(IMAGE_FORMATS) + ").")
    p.add_argument("file", metavar="IN", help="volume file: .raw or " + ", ".join(IMAGE_FORMATS))
    p.add_argument("output", metavar="OUT.ome.zarr", help="the store's folder (must not exist; see --overwrite)")
    p.add_argument("--raw-shape", type=int, nargs=3, default=None, metavar=("NZ", "NY", "NX"),
                   help="points of a .raw file along z, y, x (x fastest in the file)")
    p.add_argument("--raw-dtype", default=None, metavar="DTYPE",
                   help="numpy dtype of a .raw file: float32, uint16, '>f4' (big-endian), ...")
    p.add_argument("--scalars", default=None, metavar="NAME", help="array of an image file (default: active scalars)")
    p.add_argument("--spacing", type=float, nargs=3, default=None, metavar=("X", "Y", "Z"),
                   help="distance between points (default: the file's, else 1)")
    p.add_argument("--origin", type=float, nargs=3, default=None, metavar=("X", "Y", "Z"),
                   help="position of the first point (default: the file's, else 0)")
    p.add_argument("--downsample", choices=("mean", "mode"), default="mean",
                   help="how each level is made from the one below: 2x2x2 mean (default), or the most frequent "
                        "value (label volumes)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing store at OUT.ome.zarr")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="show a progress bar (default: when stderr is a terminal)")
    p.set_defaults(handler=_cmd_convert, subparser=p)


def _add_paraview_command(sub):
    """Add ``pv-hdrvol paraview``: the shell lines that load the ParaView plugin."""
    p = sub.add_parser("paraview", help="print the environment that loads the ParaView plugin",
                       description="Print shell lines that make ParaView (GUI, pvpython, pvbatch) load the "
                                   "pv_hdrvol plugin: PV_PLUGIN_PATH names paraview_plugin/, and PYTHONPATH the "
                                   "shim that ParaView 5.11 needs on Python 3.11 (harmless elsewhere). Use: "
                                   "eval \"$(pv-hdrvol paraview)\" then paraview, pvpython or pvbatch. "
                                   "ParaView's own Python needs numpy and numba (Debian: python3-numba).")
    p.add_argument("--shell", choices=("sh", "fish", "cmd"), default="sh",
                   help="syntax of the lines (default sh: bash, zsh)")
    p.add_argument("--site", default=None, metavar="DIR",
                   help="also put DIR on PYTHONPATH: extra packages for ParaView's Python, such as OpenEXR for "
                        ".exr files (/usr/bin/python3 -m pip install --no-deps --target DIR OpenEXR) and zarr for "
                        "*.ome.zarr stores (docs/paraview.md lists the pinned versions)")
    p.set_defaults(handler=_cmd_paraview, subparser=p)


def main(argv=None):
    """Run ``pv-hdrvol`` with ``argv`` (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 on success. User errors raise ``SystemExit(2)`` after an argparse-style
        message (``pv-hdrvol render: error: ...``) on stderr.

    Examples
    --------
    >>> main(["info", "missing.exr"])
    Traceback (most recent call last):
    SystemExit: 2
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        args.handler(args)
    except UserError as exc:
        args.subparser.error(str(exc))
    return 0


# -- commands -------------------------------------------------------------------------
def _check_tolerance(args):
    """``--tolerance`` chooses what ``--step`` and ``--precision`` set: refuse them
    together as argparse refuses mutually exclusive options, before any work."""
    if args.tolerance is None:
        return
    given = [flag for flag, value in (("--step", args.step), ("--precision", args.precision)) if value is not None]
    if given:
        raise UserError(f"argument --tolerance: not allowed with argument {given[0]}")


def _cmd_render(args):
    _check_tolerance(args)
    path = _readable_file(args.file)
    output = pathlib.Path(args.output) if args.output else pathlib.Path(path.stem + ".exr")
    png = _check_outputs(output, args.png)
    if png is None and (args.colorbar or args.tonemap):
        option = "--colorbar" if args.colorbar else "--tonemap"
        raise UserError(f"{option} styles the PNG preview; add --png OUT.png")
    volume = _read_volume(path, args)
    try:
        words = transfer_function_words(args)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    tf = cull = None
    if args.pof is not None:
        tf, cull = _culling(args, volume, words)
    elif args.k is not None:
        raise UserError("--k weighs the bases of --pof; give --pof FILE.npz")
    image, tf = _render(args, volume, tf, default_view="iso", cull=cull, words=words)  # tf: the colour bar's
    image.metadata["source_file"] = str(path)
    _write(image, output, png, args, tf, volume.name.strip())
    shape = f"{volume.n_cells} tets" if hasattr(volume, "n_cells") else "x".join(map(str, volume.dims))
    # .strip(): pyvista names a cube's array after its comment line (" SCF Total Density\n")
    _print_stats(image, f"{path.name} ({volume.name.strip()}, {shape})")
    _print_tolerance(image.metadata.get("tolerance"))


def _readable_file(name, formats=READABLE):
    """``name`` as an existing path with an extension ``pyvista.read`` reads here."""
    from ..data.files import readable_path

    path = _existing_file(name)
    try:
        return readable_path(path, formats)
    except ValueError as exc:  # "cannot read 'x.txt': unknown extension '.txt'; use one of ..."
        raise UserError(str(exc)) from None


def _read_volume(path, args):
    """The image volume or tetrahedral mesh of array ``args.scalars`` in file ``path``
    (:func:`pv_hdrvol.data.files.read_volume`, as ``pv_hdrvol.view(path)`` reads it)."""
    from ..data.files import read_volume

    try:
        volume = read_volume(path, scalars=args.scalars)
    except (OSError, ValueError, TypeError) as exc:  # each names the file, or the arrays there are
        raise UserError(str(exc)) from None
    if path.suffix.lower() == ".cube" and tuple(volume.spacing) == (1.0, 1.0, 1.0) \
            and tuple(volume.origin) == (0.0, 0.0, 0.0):  # index units: what pyvista 0.4x's reader gives
        print(f"{args.subparser.prog}: note: {_cube_note(path)}", file=sys.stderr)
    return volume


def _open_store(path, args):
    """The multiresolution store at folder ``path``, opened out of core."""
    from ..outofcore.render import open_multiscale

    if args.scalars is not None:
        raise UserError(f"--scalars picks an array of a dataset; the store {str(path)!r} holds one")
    try:
        return open_multiscale(path)
    except (OSError, ValueError) as exc:  # names what a zarr.json pv_hdrvol did not write lacks
        raise UserError(str(exc)) from None


def _cmd_view(args):
    from ..data.files import is_store

    store = is_store(args.file)
    path = pathlib.Path(os.path.abspath(args.file)) if store else _readable_file(args.file)
    tf = None
    tf_path = None if args.tf is None else _existing_file(args.tf)
    volume = _open_store(path, args) if store else _read_volume(path, args)
    if tf_path is not None:
        from ..editor.model import TransferFunctionModel, coarsest_values

        try:
            # a ParaView preset (stored on 0-1) lands on the data's range, as ParaView's ApplyPreset (out of
            # core: the coarsest level's, which the default function and the editor's histogram use too)
            values = coarsest_values(volume) if store else volume.values
            model = TransferFunctionModel.load(tf_path, values)
        except (ValueError, TypeError, KeyError, IndexError, AttributeError) as exc:
            raise UserError(f"cannot read the transfer function {str(tf_path)!r}: {exc}") from None
        tf = model.transfer_function()
    try:
        # the viewer is a later stage than this front end: imported only for this command
        from ..viewer.qt import view
    except ImportError as exc:
        raise UserError(f"the viewer needs Qt and pyvistaqt (pip install 'pv_hdrvol[gui]'): {exc}") from None
    view(volume, tf, title=f"pv_hdrvol: {path.name}", precision=args.precision)


def _cmd_demo(args):
    from ..datasets import demo_transfer_function, hydrogen_orbital

    _check_tolerance(args)
    n, l, m = args.orbital  # noqa: E741
    try:
        grid = hydrogen_orbital(n, l, m, size=args.grid)
    except (ValueError, TypeError) as exc:
        raise UserError(str(exc)) from None
    out_dir = pathlib.Path(args.output_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise UserError(f"--output-dir {str(out_dir)!r} exists and is not a directory")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--output-dir: cannot create {str(out_dir)!r}: {exc.strerror}") from None
    for name in ("demo.exr", "demo.png"):
        _check_writable("--output-dir", out_dir / name)
    tf = demo_transfer_function(vmax=float(grid["probability_density"].max()))
    # the side view shows the nodal cones of the default 3d_z2 orbital as dark wedges;
    # zoom: the cube's corners hold almost nothing visible
    image, _ = _render(args, grid, tf, default_view="xz", zoom=1.5)
    image.metadata["source"] = f"pv_hdrvol.datasets.hydrogen_orbital(n={n}, l={l}, m={m}, size={args.grid})"
    _write(image, out_dir / "demo.exr", out_dir / "demo.png", args, tf, "probability density")
    _print_stats(image, f"hydrogen orbital n={n} l={l} m={m} on {args.grid}^3 points")
    _print_tolerance(image.metadata.get("tolerance"))


def _cmd_proxy_make(args):
    path = _existing_file(args.file)
    if path.suffix.lower() not in IMAGE_FORMATS and path.suffix.lower() in MESH_FORMATS:
        raise UserError(f"{str(path)!r} is a mesh file; proxies are made of image volumes (the proxy pass marches "
                        f"voxels): use one of {', '.join(IMAGE_FORMATS)}, or render the mesh with pv-hdrvol render")
    path = _readable_file(args.file, IMAGE_FORMATS)
    out = pathlib.Path(args.output)
    if out.exists() and not out.is_dir():
        raise UserError(f"{str(out)!r} exists and is not a folder")
    if args.view not in VIEWS:
        raise UserError(f"--view must be one of {', '.join(VIEWS)}; got {args.view!r}")
    volume = _read_volume(path, args)
    from ..data.tets import is_unstructured

    if is_unstructured(volume):  # a TetMesh has values too
        raise UserError(f"{str(path)!r} holds a tetrahedral mesh; proxies are made of image volumes (the proxy pass "
                        f"marches voxels): render the mesh with pv-hdrvol render")
    from ..proxy.generate import make_proxies

    layers = args.peaks if args.peaks is not None else args.layers
    try:
        proxies = make_proxies(volume, args.view, _size(args.size), intervals=args.intervals, layers=layers,
                               multi_perspective=args.multi_perspective, training=args.training,
                               clusters=args.clusters, step=args.step, progress_bar=None)
        proxies.save(out)
    except (ValueError, TypeError) as exc:
        raise UserError(str(exc)) from None
    except OSError as exc:
        raise UserError(f"cannot write: {exc}") from None
    st = proxies.storage()
    print(f"wrote {out}: {proxies!r}")
    print(f"  {st['proxy_bytes'] / 2**20:.1f} MiB of proxies for {st['volume_bytes'] / 2**20:.1f} MiB of volume "
          f"(ratio {st['ratio']:.3g}); {proxies.info['seconds']:.1f} s")


def _cmd_proxy_view(args):
    from ..params import Light
    from ..proxy.proxies import load_proxies

    if args.output is None:
        if any(x is not None and x is not False for x in (args.opacity, args.rotate, args.light, args.enhance,
                                                          args.layer, args.ambient_occlusion)) or args.headlight:
            raise UserError("the options set one image to write: give -o OUT, or none of them for the window")
        try:
            proxies = load_proxies(args.folder)
        except (FileNotFoundError, ValueError) as exc:  # a missing or broken folder
            raise UserError(str(exc)) from None
        try:
            from ..proxy.qt import view
        except ImportError as exc:
            raise UserError(f"the proxy viewer needs Qt (pip install 'pv_hdrvol[gui]'): {exc}") from None
        view(proxies, title=f"pv_hdrvol proxies: {args.folder}")
        return
    out = pathlib.Path(args.output)
    if out.suffix.lower() not in (".exr", ".npy", ".png"):
        raise UserError(f"output {str(out)!r} must end in .exr, .npy or .png")
    _check_writable("-o/--output", out)
    scale = None
    if args.opacity:
        scale = {}
        for item in args.opacity:
            try:
                i, k = item.split("=")
                scale[int(i)] = float(k)
            except ValueError:
                raise UserError(f"--opacity takes I=K (an interval and a scale); got {item!r}") from None
    lights = [Light(tuple(d)) for d in args.light or ()] + ([Light()] if args.headlight else [])
    layers = None
    if args.layer:
        layers = {}
        for j, r, g, b, a in args.layer:
            try:
                layers[int(j)] = ((float(r), float(g), float(b)), float(a))
            except ValueError:
                raise UserError(f"--layer takes J R G B OPACITY (numbers); got {' '.join((j, r, g, b, a))}") \
                    from None
    try:
        proxies = load_proxies(args.folder)
        image = proxies.synthesize(scale, rotate=args.rotate, light=lights or None, enhance=args.enhance,
                                   layers=layers, ambient_occlusion=args.ambient_occlusion)
    except (FileNotFoundError, ValueError, TypeError) as exc:
        raise UserError(str(exc)) from None
    try:
        image.save_png(out) if out.suffix.lower() == ".png" else image.save(out)
    except OSError as exc:
        raise UserError(f"cannot write: {exc}") from None
    print(f"wrote {out}")


def _cmd_convert(args):
    import time

    import numpy as np

    path = _existing_file(args.file)
    raw = path.suffix.lower() == ".raw"
    if raw and (args.raw_shape is None or args.raw_dtype is None):
        raise UserError(f"{str(path)!r} is a .raw file: give --raw-shape NZ NY NX and --raw-dtype")
    if not raw:
        if args.raw_shape is not None or args.raw_dtype is not None:
            raise UserError(f"--raw-shape and --raw-dtype describe a .raw file; {str(path)!r} has its own")
        path = _readable_file(args.file, IMAGE_FORMATS)
    if raw:
        try:
            np.dtype(args.raw_dtype)
        except TypeError:
            raise UserError(f"--raw-dtype: {args.raw_dtype!r} is not a numpy dtype (float32, uint16, '>f4', ...)") \
                from None
    out = pathlib.Path(args.output)
    if out.exists() and not args.overwrite:
        raise UserError(f"{str(out)!r} exists; add --overwrite to replace it")
    from ..outofcore.store import write_multiscale

    start = time.perf_counter()
    try:
        store = write_multiscale(path, out, shape=args.raw_shape, dtype=args.raw_dtype, spacing=args.spacing,
                                 origin=args.origin, scalars=args.scalars, downsample=args.downsample,
                                 overwrite=args.overwrite, progress_bar=args.progress)
    except (ValueError, TypeError, FileExistsError) as exc:
        raise UserError(str(exc)) from None
    except OSError as exc:
        raise UserError(f"cannot write {str(out)!r}: {exc}") from None
    seconds = time.perf_counter() - start
    print(f"wrote {out}: {store.n_levels} levels of {store.dtype} ({store.downsample}), chunks of {store.chunk}^3")
    for level, lv in enumerate(store.levels):
        print(f"  level {level}: {'x'.join(map(str, lv.dims))} points, {lv.dtype}, "
              f"{int(np.prod(lv.chunks))} chunks")
    print(f"  value range {store.value_range[0]:.6g} .. {store.value_range[1]:.6g}; {seconds:.2f} s")


def _cmd_info(args):
    from ..image.hdr import HDRImage

    path = _existing_file(args.file)
    try:
        image = HDRImage.load(path)
    except ValueError as exc:  # names the file: unknown extension, not an EXR, truncated...
        raise UserError(str(exc)) from None
    except Exception as exc:  # anything else a corrupt or foreign file may cause
        raise UserError(f"cannot read {str(path)!r}: {exc}") from None
    if args.json:
        print(json.dumps(image.metadata, indent=2, sort_keys=True))
        return
    _print_stats(image, path.name)
    settings = image.metadata.get("settings")
    if isinstance(settings, dict):
        _print_settings(settings)
    record = image.metadata.get("tolerance")
    _print_tolerance(record)
    rest = {k: v for k, v in image.metadata.items() if k != "settings" and not (k == "tolerance" and
                                                                                 isinstance(record, dict))}
    if rest:
        print("metadata:")
        for key in sorted(rest):
            print(f"  {key}: {rest[key]}")
    elif not settings:
        print("metadata: none")


# -- helpers ----------------------------------------------------------------------------
def _existing_file(name):
    path = pathlib.Path(name)
    if not path.exists():
        raise UserError(f"file not found: {name!r}")
    if not path.is_file():
        raise UserError(f"not a file: {name!r}")
    return path


def _number(option, text):
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{option}: {text!r} is not a number") from None


def _clim(ends):
    """``--clim LOW HIGH`` as ``clim=``: numbers, ``auto`` for the default's end."""
    if ends is None:
        return None
    return tuple(None if e.lower() == "auto" else _number("--clim", e) for e in ends)


def _opacity(words):
    """``--opacity`` as ``opacity=``: one PyVista curve name, or numbers."""
    if words is None:
        return None
    if len(words) == 1:
        try:
            return float(words[0])
        except ValueError:
            return words[0]  # a curve name; the core names the known ones if it is not
    return [_number("--opacity", w) for w in words]


def _lens(args):
    """The lens of ``--magnifier`` or ``--fisheye`` (not both), or None."""
    from ..rays.lenses import Fisheye, Magnifier

    if args.magnifier is not None and args.fisheye is not None:
        raise UserError("--magnifier and --fisheye are two lenses; give one")
    if args.magnifier is not None:
        col, row, radius, factor = args.magnifier
        return Magnifier((col, row), radius=radius, factor=factor)
    if args.fisheye is not None:
        return Fisheye(args.fisheye)
    return None


def _culling(args, volume, words):
    """``(family, pof)`` of ``--pof`` and ``--k``."""
    from ..culling.pof import PlenopticOpacity
    from ..data.transfer import TransferFunction

    if any(value is not None for value in words.values()):
        raise UserError("--pof renders the family of its bases: leave out --cmap, --clim, --opacity and --scale")
    if hasattr(volume, "n_cells"):
        raise UserError("--pof culls blocks of image data; tetrahedral meshes have none")
    path = _existing_file(args.pof)
    try:
        pof = PlenopticOpacity.load(path)
        pof.check_volume(volume)
        family = TransferFunction.family(pof.bases, args.k)
    except (ValueError, TypeError, OSError, KeyError) as exc:
        raise UserError(f"--pof {str(path)!r}: {exc}") from None
    return family, pof


def _render(args, volume, tf, default_view, zoom=1.0, cull=None, words=None):
    """``(image, tf)``: ``volume`` rendered as the options say, and the transfer function
    it was rendered with. ``tf``, the transfer function's ``words`` and the render
    options become the function and ``RenderOptions`` through
    :func:`~pv_hdrvol.raycast.grid.resolve_render_options`, and ``--view`` frames the
    data through :func:`~pv_hdrvol.rays.camera.fit_camera`, as in ``hv.render``."""
    from .. import render
    from ..raycast.grid import resolve_render_options
    from ..raycast.memory import RenderMemoryError
    from ..rays.camera import fit_camera

    names = ("step", "precision", "tolerance", "global_alpha", "blending", "shade", "ambient", "diffuse", "specular",
             "specular_power", "device")
    options = {name: getattr(args, name) for name in names if getattr(args, name) is not None}
    if args.light is not None:
        options["lights"] = [tuple(d) for d in args.light]
    if args.clip_plane is not None:
        options["clip_planes"] = [(tuple(p[:3]), tuple(p[3:])) for p in args.clip_plane]
    if args.crop_box is not None:
        options["crop_box"] = tuple(args.crop_box)
    progress = sys.stderr.isatty() if args.progress is None else args.progress
    try:
        size = _size(args.size)
        tf, options = resolve_render_options(volume, tf, **(words or {}), **options)
        # culling's visibility order and block opacities are the orthographic ones
        camera = fit_camera(volume, args.view or default_view, zoom=zoom, parallel_projection=cull is not None)
        image = render(volume, tf, camera, size, options=options, lens=_lens(args), cull=cull, progress_bar=progress)
        return image, tf
    except (ValueError, TypeError, RenderMemoryError) as exc:  # a too large --size is a user error too
        raise UserError(str(exc)) from None


def _check_outputs(output, png):
    """Check the output names and folders before spending time on a render; returns
    ``png`` as a path."""
    if output.suffix.lower() not in (".exr", ".npy"):
        raise UserError(f"output {str(output)!r} must end in .exr or .npy")
    _check_writable("-o/--output", output)
    if png is None:
        return None
    png = pathlib.Path(png)
    if png.suffix.lower() != ".png":
        raise UserError(f"--png {str(png)!r} must end in .png")
    _check_writable("--png", png)
    return png


def _check_writable(option, path):
    from ..image.io import check_writable

    try:
        check_writable(path)
    except OSError as exc:  # e.g. "cannot write 'a/b.exr': no such folder: 'a'"
        raise UserError(f"{option}: {exc.strerror}: {exc.filename!r}") from None


def _cube_note(path):
    """What ``pyvista.read`` leaves out of a Gaussian cube file's geometry."""
    detail = ""
    try:  # lines 4-6 of the header: points along each axis and that axis's step vector
        with open(path) as f:
            lines = [f.readline() for _ in range(6)]
        steps = [math.hypot(*(float(x) for x in line.split()[1:4])) for line in lines[3:6]]
        detail = f" (steps {', '.join(f'{s:.6g}' for s in steps)})"
    except (OSError, ValueError, TypeError):
        pass
    return (f"{path.name} is rendered as pyvista.read gives it, in grid index units (spacing 1, origin 0, "
            f"axis-aligned); the cube's origin, step{detail} and axis directions are not applied")


def _write(image, output, png, args, tf, label):
    try:
        image.save(output)
        print(f"wrote {output}")
        if png is not None:
            _write_preview(image, png, args, tf, label)
            print(f"wrote {png}")
    except OSError as exc:
        raise UserError(f"cannot write: {exc}") from None


def _write_preview(image, png, args, tf, label):
    """The PNG preview: auto exposure and clamp (default) or ``--tonemap``, with ``--colorbar``."""
    if args.tonemap is None and not args.colorbar:
        image.save_png(png)
        return
    picture = image.tonemap(args.tonemap).rgb8 if args.tonemap else image.to_display()
    if args.colorbar:
        from ..image.colorbar import save_png_with_colorbar  # matplotlib only when asked for

        save_png_with_colorbar(png, picture, tf, label=label or None)
    else:
        from ..image.io import write_png

        write_png(png, picture)


def _print_settings(stored):
    """The ``"settings"`` metadata entry, readably (``info --json`` prints all of it)."""
    from ..settings import RenderSettings

    try:
        s = RenderSettings.from_dict(stored)
    except (ValueError, TypeError) as exc:
        print(f"render settings: unreadable ({exc})")
        return
    tf, cam = s.tf, s.camera
    print("render settings (pv_hdrvol.load(FILE).settings()):")
    print(f"  size:               {s.size[0]}x{s.size[1]}")
    if cam is None:
        print("  camera:             none (rendered from rays)")
    else:
        projection = (f"parallel, scale {cam.parallel_scale!r}" if cam.parallel_projection
                      else f"perspective, view angle {cam.view_angle!r} degrees")
        print(f"  camera:             position {_vec(cam.position)}, focal point {_vec(cam.focal_point)}, "
              f"view up {_vec(cam.view_up)}, {projection}")
    print(f"  transfer function:  {tf.values.size} control points over [{tf.vmin!r}, {tf.vmax!r}], "
          f"scale {tf.scale}" + (f" (linthresh {tf.linthresh!r})" if tf.scale == "symlog" else "")
          + f", colours in {tf.color_space}, opacity {tf.opacities.min():.6g} to {tf.opacities.max():.6g}, "
          f"table of {tf.table_size} entries")
    options = stored.get("options", {})
    print(f"  options:            {', '.join(f'{k}={v!r}' for k, v in options.items())}")
    if s.keywords:
        print(f"  keywords:           {', '.join(f'{k}={v!r}' for k, v in s.keywords.items())}")
    if stored.get("not_stored"):
        print(f"  not stored:         {', '.join(stored['not_stored'])} (settings() needs partial=True)")


def _print_tolerance(record):
    """The knobs a ``tolerance=`` render chose (``metadata["tolerance"]``), readably;
    nothing for a render without one."""
    if not isinstance(record, dict):
        return
    print(f"tolerance {record.get('tolerance')!r}, the knobs the renderer chose:")
    if "step" in record:
        print(f"  step:               {record['step']:.6g} voxels")
    if "tau_max" in record:
        print(f"  tau_max:            {record['tau_max']:.6g}")
    for key, label in (("termination", "termination"), ("table_size", "table size"), ("precision", "precision"),
                       ("estimated_error", "estimated error")):
        if key in record:
            value = record[key]
            text = f"{value:.6g}" if isinstance(value, float) else str(value)
            print(f"  {label + ':':<20}{text}" + (" of the peak (RMS)" if key == "estimated_error" else ""))
    if "pilot_pixels" in record:
        order = record.get("order")
        rungs = ", ".join(f"{r:g}" for r in record.get("rungs", []))
        print(f"  pilot:              {record['pilot_pixels']} pixels, rungs {rungs}, "
              f"order {'not converged' if order is None else f'{order:.3g}'}, {record.get('pilot_seconds', 0.0):.3g} s")


def paraview_environment():
    """``{variable: folder}`` to prepend for ParaView: the plugin folder on
    ``PV_PLUGIN_PATH`` and the getargspec shim on ``PYTHONPATH``.

    Raises
    ------
    UserError
        This installation has no ``paraview_plugin/`` folder beside the package (it
        ships with the source tree: install with ``pip install -e``).
    """
    plugin = pathlib.Path(__file__).resolve().parents[2] / "paraview_plugin"
    if not (plugin / "pv_hdrvol_plugin.py").is_file() or not (plugin / "shim" / "sitecustomize.py").is_file():
        raise UserError(f"no ParaView plugin beside this installation of pv_hdrvol (looked in {plugin}); it comes "
                        f"with the source tree: git clone, then python3 -m pip install -e .")
    return {"PV_PLUGIN_PATH": str(plugin), "PYTHONPATH": str(plugin / "shim")}


def _cmd_paraview(args):
    environment = paraview_environment()
    if args.site is not None:
        site = pathlib.Path(args.site).expanduser().resolve()
        if not site.is_dir():
            raise UserError(f"--site {args.site!r} is not a folder")
        environment["PYTHONPATH"] += os.pathsep + str(site)
    for name, folder in environment.items():
        if args.shell == "fish":
            print(f"set -gx {name} {shlex.quote(folder)} ${name}")
        elif args.shell == "cmd":
            print(f"set {name}={folder};%{name}%")
        else:
            print(f"export {name}={shlex.quote(folder)}${{{name}:+:${name}}}")


def _vec(v):
    return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"


def _print_stats(image, title):
    s = image.stats()
    rows, cols = s["shape"]
    print(f"{title}: {cols}x{rows} {s['dtype']}")
    print(f"  peak luminance:             {s['peak_luminance']:.6g}")
    print(f"  min non-zero luminance:     {s['min_nonzero_luminance']:.6g}")
    print(f"  dynamic range:              {s['dynamic_range_decades']:.2f} decades")
    print(f"  covered fraction:           {s['covered_fraction']:.4f}")
    print(f"  distinct luminance levels:  {s['distinct_luminance_levels']}")
    if s["nan_pixels"]:
        print(f"  NaN pixels:                 {s['nan_pixels']}")
    culling = image.metadata.get("culling")
    if isinstance(culling, dict):
        print(f"  culled blocks:              {culling['culled']} of {culling['nonempty']} non-empty "
              f"({culling['culled_fraction']:.1%}), in {culling['seconds'] * 1e3:.1f} ms")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
