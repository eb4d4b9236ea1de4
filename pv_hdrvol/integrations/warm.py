"""Compile the ray caster's common variants ahead of their first use, in a process of
their own, so that an application's first Shade or Tolerance does not stop it for the
half minute numba takes to compile (numba 0.56, 2 cores: 37-39 s in ParaView's GUI).

numba compiles each variant of a kernel (precision, shading, the kind of data, the
tolerance's choices) on its first call and keeps it in its on-disk cache
(``NUMBA_CACHE_DIR``), where any later process loads it in about a second. This module
makes those first calls on tiny inputs through the same VTK algorithm the ParaView
plugin runs::

    python -m pv_hdrvol.integrations.warm [--variants grid shaded-grid ...]

and :func:`start_in_background` starts that once per cache and version of the source
(a stamp file in the cache folder says it is done), at the lowest CPU priority. The
plugin calls it when it loads.
"""
from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import time

#: The variants compiled, by name: ``(data, {HDRVolumeRenderer setter: value})``;
#: ``data`` "grid" is a uint8 image, "float-grid" a float32 one, "tets" a tetrahedral
#: mesh (the kinds ParaView's readers give most often).
VARIANTS = {
    "grid": ("grid", {}),
    "float-grid": ("float-grid", {}),
    "shaded-grid": ("grid", {"SetShade": True}),
    "tolerance-grid": ("grid", {"SetTolerance": 0.01}),
    "tets": ("tets", {}),
    "shaded-tets": ("tets", {"SetShade": True}),
}


def _image(dtype):
    import numpy as np
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonDataModel import vtkImageData

    n = 6
    z, y, x = np.mgrid[0:n, 0:n, 0:n]
    values = ((x + 2 * y + 3 * z) * (250.0 / (6 * (n - 1)))).astype(dtype)
    image = vtkImageData()
    image.SetDimensions(n, n, n)
    array = numpy_to_vtk(values.reshape(-1), deep=True)
    array.SetName("values")
    image.GetPointData().SetScalars(array)
    return image


def _tets():
    from vtkmodules.vtkFiltersGeneral import vtkDataSetTriangleFilter

    split = vtkDataSetTriangleFilter()  # the image's voxels as tetrahedra, its point data kept
    split.SetInputData(_image("float32"))
    split.Update()
    return split.GetOutput()


def _data(kind):
    if kind == "tets":
        return _tets()
    return _image("float32" if kind == "float-grid" else "uint8")


def warm(names=None, *, say=print):
    """Render each variant of ``names`` (default all of :data:`VARIANTS`) once, 8x8
    pixels: numba compiles it, or loads it from its cache. ``say``: a line per variant
    with the seconds it took. Returns ``{name: seconds}``."""
    from .vtk_algorithm import HDRVolumeRenderer

    taken = {}
    for name in VARIANTS if names is None else names:
        if name not in VARIANTS:
            raise ValueError(f"unknown variant {name!r}; the variants are {sorted(VARIANTS)}")
        kind, settings = VARIANTS[name]
        started = time.perf_counter()
        renderer = HDRVolumeRenderer()
        renderer.SetInputDataObject(0, _data(kind))
        renderer.SetImageSize(8, 8)
        renderer.SetCamera("iso")
        for setter, value in settings.items():
            getattr(renderer, setter)(value)
        renderer.Update()
        if renderer.GetLastError():
            raise RuntimeError(f"warming {name} failed: {renderer.GetLastError()}")
        taken[name] = time.perf_counter() - started
        say(f"pv_hdrvol warm: {name} in {taken[name]:.1f} s")
    return taken


def source_key():
    """What the cache's contents depend on: numba's version and pv_hdrvol's source files
    (names, sizes, modification times), hashed."""
    import numba

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    digest = hashlib.sha256(f"numba {numba.__version__} python {sys.version_info[:2]}".encode())
    for folder, dirs, files in sorted(os.walk(root)):
        dirs.sort()
        for name in sorted(files):
            if name.endswith(".py"):
                info = os.stat(os.path.join(folder, name))
                digest.update(f"{os.path.relpath(os.path.join(folder, name), root)} {info.st_size} "
                              f"{info.st_mtime_ns}".encode())
    return digest.hexdigest()[:16]


def stamp_path(cache_dir):
    """The file that says the variants of this source are in ``cache_dir``."""
    return os.path.join(cache_dir, f"pv_hdrvol-warm-{source_key()}.done")


def start_in_background(cache_dir, python=None, env=None):
    """Start ``python -m pv_hdrvol.integrations.warm`` (at the lowest priority, detached,
    its output in ``cache_dir/pv_hdrvol-warm.log``) unless ``cache_dir`` has the stamp of
    this source; the process writes the stamp when it is done. Returns the Popen, or
    None when there is nothing to do."""
    if os.path.exists(stamp_path(cache_dir)):
        return None
    os.makedirs(cache_dir, exist_ok=True)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = dict(os.environ if env is None else env, NUMBA_CACHE_DIR=cache_dir)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (root, env.get("PYTHONPATH", "")) if p)
    log = open(os.path.join(cache_dir, "pv_hdrvol-warm.log"), "a")
    try:
        process = subprocess.Popen([python or sys.executable, "-m", "pv_hdrvol.integrations.warm", "--stamp"],
                                   env=env, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                                   start_new_session=True)
    finally:
        log.close()
    # the lowest priority, set from here: a preexec_fn is unsafe in a threaded process
    # such as ParaView's GUI; the import of numba takes longer than this gap
    try:
        os.setpriority(os.PRIO_PROCESS, process.pid, 19)
    except OSError:
        pass
    return process


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", nargs="+", choices=sorted(VARIANTS), default=None,
                        help="the variants to compile (default: all)")
    parser.add_argument("--stamp", action="store_true", help="write the stamp file into NUMBA_CACHE_DIR when done")
    args = parser.parse_args(argv)
    warm(args.variants)
    if args.stamp:
        from numba.core import config

        if config.CACHE_DIR:
            with open(stamp_path(config.CACHE_DIR), "w") as f:
                f.write(" ".join(sorted(args.variants or VARIANTS)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
