"""``python -m pv_hdrvol.parallel``: POF precomputation and MPI rendering from the shell.

    python -m pv_hdrvol.parallel pof head.vti --tf skin.json --tf bone.json -o head.pof.npz
    mpiexec -n 4 python -m pv_hdrvol.parallel render head.vti --pof head.pof.npz --k 0.25,0.9 -o frame.exr

Transfer functions are JSON files of ``TransferFunction.to_dict()``. ``render`` without
``--pof`` renders every non-empty block with ``--tf`` (or the default transfer
function) and no culling. Rank 0 writes the image and prints the per-rank times.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys


def _read_volume(path, scalars):
    from ..raycast.grid import as_volume

    path = pathlib.Path(path)
    if not path.is_file():
        raise SystemExit(f"error: no such file: {str(path)!r}")
    try:
        import pyvista as pv

        dataset = pv.read(path)
    except ImportError:  # ParaView's Python has VTK but no PyVista
        from vtkmodules.vtkIOXML import vtkXMLImageDataReader

        if path.suffix.lower() != ".vti":
            raise SystemExit("error: without PyVista only .vti files can be read") from None
        reader = vtkXMLImageDataReader()
        reader.SetFileName(str(path))
        reader.Update()
        dataset = reader.GetOutput()
    from ..data.grid import volume_from_dataset

    return as_volume(volume_from_dataset(dataset, scalars=scalars))


def _read_tf(path):
    from ..data.transfer import TransferFunction

    with open(path) as f:
        return TransferFunction.from_dict(json.load(f))


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m pv_hdrvol.parallel", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("pof", help="precompute plenoptic opacity functions of a volume")
    p.add_argument("volume")
    p.add_argument("--tf", action="append", required=True, help="a basis transfer function (JSON); repeat")
    p.add_argument("--scalars")
    p.add_argument("--block-size", type=int, default=16)
    p.add_argument("--threads", type=int)
    p.add_argument("-o", "--output", required=True, help="the .npz file to write")
    r = sub.add_parser("render", help="render on the ranks of mpiexec (or alone)")
    r.add_argument("volume")
    r.add_argument("--pof", help="a .pof.npz file: cull with it; the transfer function is its bases' family")
    r.add_argument("--k", help="the family's weights, comma-separated (default all 1)")
    r.add_argument("--tf", help="a transfer function (JSON), without --pof")
    r.add_argument("--scalars")
    r.add_argument("--size", type=int, nargs=2, default=(512, 512), metavar=("W", "H"))
    r.add_argument("--view", default="iso")
    r.add_argument("--curve", default="hilbert", choices=("hilbert", "z", "contiguous", "random"))
    r.add_argument("--precision", default="float32", choices=("float32", "float64"))
    r.add_argument("--serial", action="store_true", help="no MPI (comm=None)")
    r.add_argument("-o", "--output", default="frame.exr")
    args = parser.parse_args(argv)

    import pv_hdrvol as hv

    volume = _read_volume(args.volume, args.scalars)
    if args.command == "pof":
        from ..culling.pof import PlenopticOpacity

        pof = PlenopticOpacity.compute(volume, [_read_tf(t) for t in args.tf], block_size=args.block_size,
                                       threads=args.threads, progress_bar=sys.stderr.isatty())
        pof.save(args.output)
        print(f"{args.output}: {pof.grid_shape} blocks of {pof.block_size}^3, {int(pof.nonempty.any(-1).sum())} "
              f"non-empty, {len(pof.bases)} bases")
        return 0
    from ..culling.pof import PlenopticOpacity
    from .render import render_parallel

    pof = tf = None
    if args.pof:
        pof = PlenopticOpacity.load(args.pof)
        k = None if args.k is None else [float(x) for x in args.k.split(",")]
        tf = hv.TransferFunction.family(pof.bases, k)
    elif args.tf:
        tf = _read_tf(args.tf)
    camera = hv.Camera.fit(volume.bounds, args.view, parallel_projection=True)
    image = render_parallel(volume, tf, camera, tuple(args.size), pof=pof, comm=None if args.serial else "world",
                            curve=args.curve, precision=args.precision)
    if image is not None:
        image.save(args.output)
        info = image.metadata["parallel"]
        print(f"{args.output}: {args.size[0]}x{args.size[1]}, {info['ranks']} ranks, {info['visible']} of "
              f"{info['blocks']} blocks visible, {info['seconds']:.2f} s")
        for s in info["per_rank"]:
            print(f"  rank {s['rank']}: {s['rendered']} blocks, cull {s['cull_seconds']:.3f} s, render "
                  f"{s['render_seconds']:.3f} s, composite {s['composite_seconds']:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
