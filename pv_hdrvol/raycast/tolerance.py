"""Say the accuracy, get the render: the knobs chosen for ``RenderOptions.tolerance``.

The tolerance is the RMS error of the linear, premultiplied RGB image against the
converged render (every pixel, three channels), relative to the image's brightest
channel value. Given it, the renderer picks what trades time for accuracy:

- **precision**: float64. Its compositing is plain sums; float32's needs compensated
  (Kahan) sums and measured slower here (engine 512², step 0.5: float64 0.168 s,
  float32 0.209 s; bonsai equal), and float32's own error (below 1e-6 of the peak) is
  far below any tolerance allowed.
- **step** (image volumes) or **tau_max** (tetrahedral meshes): by Richardson
  extrapolation on a *pilot*, the same view at a few thousand pixels rendered on a
  ladder of halving steps. Successive differences ``d_k = |I_k - I_{k+1}|`` shrink by
  ``rho = 2^-p`` where the sampling error behaves as ``C h^p``; the error of ``I_k``
  is then ``d_k / (1 - rho)``, and the step whose error is the sampling's share of the
  tolerance is ``h_k (share tol / e_k)^(1/p)``. The ladder goes on until that step is
  no finer than its finest rung (the choice interpolates between rendered steps, never
  extrapolates below them). The order ``p`` is measured, not assumed: the midpoint rule
  on a smooth field converges with ``p = 2``, sharp transfer functions and thin
  features slower.
- **early termination** and **table size**: each given a share of the tolerance
  (a ray stopped at transmittance ``T`` misses at most ``T`` times the brightest
  colour; a table is sized by :meth:`TransferFunction.required_table_size`), then
  *measured* together on the pilot at the chosen step against no termination and the
  function's own table; if they took more than their share, the render keeps the
  defaults for both.

The estimate (sampling + the measured bias of termination and table) and every choice
go into ``metadata["tolerance"]``; the same input chooses the same knobs, so renders
stay deterministic.
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from ..data.transfer import TransferFunction

#: pixels of the pilot image (about; a regular subset of the image's rays): a 64th of
#: the image, at least 1,024 and at most 4,096
PILOT_PIXELS = (1024, 4096)
PILOT_SHARE = 1.0 / 64.0
#: the sampling error's share of the tolerance; termination and table share the rest
STEP_SHARE = 0.6
TERMINATION_SHARE = 0.1
TABLE_SHARE = 0.1
#: steps of the ladder, in voxels of the smallest spacing (coarsest first)
GRID_LADDER = tuple(8.0 * 0.5 ** k for k in range(10))  # 8 ... 1/64
#: tau_max of the ladder for tetrahedral meshes (TAU_MAX = 0.25 is the default)
MESH_LADDER = (1.0, 0.5, 0.25, 0.125, 0.0625, 0.03125, 0.015625)
#: a ratio of successive differences at or above this is not yet convergence
RHO_CONVERGING = 0.9
#: orders above 2 are not believed: the midpoint rule converges as h^2 on smooth
#: integrands, and a faster ratio is a lucky pair of coarse differences (hydrogen,
#: view along z: a measured order 3 chose a step whose error was 1.01x the tolerance)
RHO_MIN = 2.0 ** -2
#: the termination chosen never exceeds this (the default is 1e-6)
MAX_TERMINATION = 1e-2


#: a pilot render expected to take fewer samples than this runs on one thread: a
#: parallel launch costs more than such a render when the machine is busy (engine,
#: 256^2, 1e-3, load 1.8 on 2 cores: pilots 0.083-0.107 s on two threads, 0.015-0.023 s
#: on one)
PILOT_SERIAL_SAMPLES = 2_000_000


class _threads:
    """Run the body on ``n`` numba threads (``None``: as many as now)."""

    def __init__(self, n):
        self.n = n

    def __enter__(self):
        import numba

        self.before = numba.get_num_threads()
        if self.n is not None:
            numba.set_num_threads(min(self.n, self.before))

    def __exit__(self, *exc):
        import numba

        numba.set_num_threads(self.before)


class ToleranceWarning(UserWarning):
    """The tolerance could not be met within the ladder's finest step."""


def rms(a, b):
    """RMS of ``a - b`` over every entry."""
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    return float(np.sqrt(np.mean(d * d))) if d.size else 0.0


def pilot_stride(width, height):
    """Every ``s``-th row and column make the pilot: a 64th of the image's pixels, at
    least 1,024 and at most 4,096 (as far as the image has them)."""
    pixels = min(max(width * height * PILOT_SHARE, PILOT_PIXELS[0]), PILOT_PIXELS[1])
    return max(1, int(math.floor(math.sqrt(width * height / pixels))))


def ladder_choice(render, ladder, target):
    """Choose a knob (a step or ``tau_max``) whose error is at most ``target``.

    ``render(h)`` gives the pilot's RGB (any shape, float64) for knob value ``h``;
    ``ladder`` is decreasing (coarse first). Returns ``(h, estimate, record)``: the
    largest ``h`` whose extrapolated error is ``target`` (at most ``ladder[0]``), the
    estimated error of the render at ``h`` relative to the pilot's peak, and what was
    rendered: ``record["rungs"]`` the knob values, ``record["differences"]`` the
    relative ``d_k``, ``record["order"]`` the measured ``p`` (None where it never
    converged), ``record["peak"]``.
    """
    images = [np.asarray(render(ladder[0]), dtype=np.float64)]
    peak = float(images[0].max(initial=0.0))
    diffs = []
    record = {"rungs": [float(ladder[0])], "differences": [], "order": None, "peak": peak}
    best = None
    for k in range(1, len(ladder)):
        images.append(np.asarray(render(ladder[k]), dtype=np.float64))
        record["rungs"].append(float(ladder[k]))
        peak = float(images[-1].max(initial=0.0))  # the finest rung's: coarse ones may overshoot
        record["peak"] = peak
        diffs.append(rms(images[-2], images[-1]))
        if peak <= 0.0:
            continue  # nothing visible yet
        rel = [d / peak for d in diffs]  # relative to the finest rung's peak
        record["differences"] = rel
        if len(rel) < 2:
            continue
        # the slower of the last two ratios: conservative in both the error and its order
        ratios = [rel[i + 1] / rel[i] if rel[i] > 0 else 0.0 for i in range(len(rel) - 1)]
        rho = max(ratios[-2:])
        if rel[-1] == 0.0 and rel[-2] == 0.0:
            # nothing changes between three rungs: the coarsest already converged
            return float(ladder[0]), 0.0, record
        if not rho < RHO_CONVERGING:
            continue
        rho = max(rho, RHO_MIN)
        p = -math.log2(rho)
        record["order"] = p
        h_prev = ladder[k - 1]
        e_prev = rel[-1] / (1.0 - rho)  # error of the rung before the finest
        h_star = h_prev * (target / e_prev) ** (1.0 / p) if e_prev > 0 else math.inf
        if h_star >= ladder[k]:
            h = min(h_star, ladder[0])
            return float(h), float(e_prev * (h / h_prev) ** p), record
        best = (float(ladder[k]), float(rho * e_prev))
    if peak <= 0.0:
        return float(ladder[0]), 0.0, record
    if best is None:  # never converged: the finest rung, its error the last difference
        best = (float(ladder[-1]), float(diffs[-1] / peak) if diffs else math.inf)
    return best[0], best[1], record


def _table_for(tf, tolerance):
    """``tf`` with the table size its share of ``tolerance`` needs, or ``tf`` itself
    where that is its own size (a :class:`TransferFunction`; anything else as it is)."""
    if type(tf) is not TransferFunction:
        return tf
    size = tf.required_table_size(max(TABLE_SHARE * tolerance, 1e-7))
    if size == tf.table_size:
        return tf
    return TransferFunction(tf.values, tf.colors, tf.opacities, scale=tf.scale, linthresh=tf.linthresh,
                            color_space=tf.color_space, table_size=size)


def _termination_for(tolerance, peak, c_max):
    """The termination whose bound ``T c_max`` is its share of ``tolerance * peak``."""
    if not (peak > 0 and c_max > 0):
        return MAX_TERMINATION
    return float(min(MAX_TERMINATION, TERMINATION_SHARE * tolerance * peak / c_max))


def _brightest(tf, opts):
    """The largest colour a sample can emit (lit: with the specular term)."""
    c = float(np.max(tf.colors)) if hasattr(tf, "colors") else 1.0
    if opts.shade:
        c = c * (opts.ambient + opts.diffuse * len(opts.light_list)) + opts.specular * len(opts.light_list)
    return c


def _choose(pilot_rgb, ladder, knob, tf, opts, pilot_pixels, t0, unmet):
    """The knobs of a tolerance render, from ``pilot_rgb(tf, value, termination)`` (the
    pilot's RGB with ``knob`` at ``value``): ``(value, termination, tf, record)``, the
    function being ``tf`` or a smaller table of it, ``record`` the image's
    ``metadata["tolerance"]``. Warns (``unmet(value, estimate)`` says how) when the
    estimate exceeds the tolerance."""
    tol = opts.tolerance
    tf_fast = _table_for(tf, tol)
    c_max = _brightest(tf, opts)
    knobs = {}

    def rung(value):
        # the first (coarsest) rung runs without termination and sets it from its peak
        if not knobs:
            rgb = pilot_rgb(tf_fast, value, 0.0)
            knobs["termination"] = _termination_for(tol, float(rgb.max(initial=0.0)), c_max)
            return rgb
        return pilot_rgb(tf_fast, value, knobs["termination"])

    value, estimate, stats = ladder_choice(rung, ladder, STEP_SHARE * tol)
    termination = knobs["termination"]
    peak = stats["peak"]
    # a ray stopped at transmittance T misses at most T c_max: within its share by choice.
    # A table smaller than the function's own is measured at the chosen value
    bias = _termination_for(tol, peak, c_max) * c_max / peak if peak > 0 else 0.0
    if tf_fast is not tf and tf_fast.table_size < tf.table_size and peak > 0:
        bias = rms(pilot_rgb(tf_fast, value, termination), pilot_rgb(tf, value, 0.0)) / peak
        if bias > (1.0 - STEP_SHARE) * tol:
            tf_fast = tf
            bias = TERMINATION_SHARE * tol
    estimate += bias
    stats["knob_bias"] = float(bias)
    stats["pilot_pixels"] = int(pilot_pixels)
    if estimate > tol:
        warnings.warn(f"tolerance={tol:g} not met: {unmet(value, estimate)}", ToleranceWarning, stacklevel=4)
    record = {"tolerance": float(tol), "estimated_error": float(estimate),
              "pilot_seconds": float(time.perf_counter() - t0), knob: float(value), "termination": float(termination),
              "precision": "float64", "table_size": int(getattr(tf_fast, "table_size", 0))}
    record.update(stats)
    return value, termination, tf_fast, record


def execute_grid(plan, camera, size, *, lens=None, block_mask=None, cull=None, window=None, progress=None,
                 progress_bar=None,
                 chunk_seconds=None, far=None):
    """``GridPlan.execute`` for a plan whose options carry a ``tolerance``: choose the
    knobs on a pilot, then render with them."""
    from ..rays.camera import Rays, check_window, fit_camera
    from .frame import check_far, window_rays

    opts = plan.options
    t0 = time.perf_counter()
    camera = fit_camera(plan.source, camera)  # as the plan frames it
    if lens is not None:
        rays = lens.rays(camera, size)
    elif isinstance(camera, Rays):
        rays = camera
    else:
        rays = camera.rays(size)
    far_all = check_far(far, rays.width, rays.height).reshape(-1)
    if window is not None:
        col, row, w, h = check_window(window, rays.width, rays.height)
        if far_all.size:
            far_all = far_all.reshape(rays.height, rays.width)[row:row + h, col:col + w].reshape(-1)
        rays = window_rays(rays, window)
    s = pilot_stride(rays.width, rays.height)
    rows = np.arange(s // 2, rays.height, s)
    cols = np.arange(s // 2, rays.width, s)
    pick = (rows[:, None] * rays.width + cols[None, :]).reshape(-1)
    pilot_far = np.ascontiguousarray(far_all[pick].reshape(rows.size, cols.size)) if far_all.size else None
    pilot = Rays(np.ascontiguousarray(rays.origins[pick]), np.ascontiguousarray(rays.directions[pick]),
                 cols.size, rows.size, None if rays.lod is None else np.ascontiguousarray(np.asarray(rays.lod)[pick]))

    diagonal = float(np.linalg.norm(np.asarray(plan.source.dims, dtype=np.float64) - 1.0))  # voxels

    def child(tf, step, termination):
        o = opts.replace(tolerance=None, step=step, termination=termination, precision="float64")
        return type(plan)(plan.source, tf, o, labels=plan.labels, label_styles=plan.label_styles)

    def pilot_rgb(tf, step, termination):
        samples = pick.size * diagonal / step
        with _threads(1 if samples < PILOT_SERIAL_SAMPLES else None):
            img = child(tf, step, termination).execute(pilot, block_mask=block_mask, far=pilot_far,
                                                       progress_bar=False)
        return np.asarray(img.rgba[..., :3], dtype=np.float64)

    step, termination, tf_fast, record = _choose(
        pilot_rgb, GRID_LADDER, "step", plan.tf, opts, int(pick.size), t0,
        lambda h, e: f"the finest step tried ({h:g} voxels) has an estimated error of {e:.3g}")
    img = child(tf_fast, step, termination).execute(
        camera, size, lens=lens, block_mask=block_mask, cull=cull, window=window, progress=progress,
        progress_bar=progress_bar, chunk_seconds=chunk_seconds, far=far)
    img.metadata["tolerance"] = record
    img.metadata["settings"] = plan_settings(plan, img.metadata["settings"])
    return img


def plan_settings(plan, settings):
    """The settings of a tolerance render: the options as the user gave them (with
    ``tolerance``), so that replaying them chooses again, and the same knobs."""
    from ..settings import options_to_dict

    out = dict(settings)
    out["options"] = options_to_dict(plan.options)
    out["tf"] = plan.tf.to_dict()
    return out


def execute_mesh(plan, camera, size, *, progress=None, progress_bar=None, view=None, chunk_seconds=None, far=None):
    """``TetPlan.execute_with_view`` for a plan whose options carry a ``tolerance``:
    choose ``tau_max``, termination, table and precision on a pilot (the same camera
    at a coarser size), then render. Returns ``(image, view)``."""
    from .._validate import as_size
    from ..rays.camera import Camera, as_camera
    from .frame import check_far

    opts = plan.options
    t0 = time.perf_counter()
    camera = as_camera(camera, plan.mesh.bounds)
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a Camera, a view name or a PyVista/VTK camera (not Rays: a tetrahedral "
                        f"render makes its own rays); got {type(camera).__name__}")
    width, height = as_size(size)
    far_all = check_far(far, width, height)
    s = pilot_stride(width, height)
    pilot_size = (max(1, width // s), max(1, height // s))
    pilot_far = None
    if far_all.size:  # each pilot pixel takes the limit of the full pixel nearest its centre
        rows = np.minimum((np.arange(pilot_size[1]) + 0.5) * height / pilot_size[1], height - 1).astype(np.int64)
        cols = np.minimum((np.arange(pilot_size[0]) + 0.5) * width / pilot_size[0], width - 1).astype(np.int64)
        pilot_far = np.ascontiguousarray(far_all.reshape(height, width)[rows[:, None], cols[None, :]])

    def child(tf, tau, termination):
        o = opts.replace(tolerance=None, termination=termination, precision="float64")
        return type(plan)(plan.mesh, tf, o, tau_max=tau)

    def pilot_rgb(tf, tau, termination):
        with _threads(1):  # a few thousand rays: one thread (see PILOT_SERIAL_SAMPLES)
            img = child(tf, tau, termination).execute(camera, pilot_size, progress_bar=False, far=pilot_far)
        return np.asarray(img.rgba[..., :3], dtype=np.float64)

    tau, termination, tf_fast, record = _choose(
        pilot_rgb, MESH_LADDER, "tau_max", plan.tf, opts, int(pilot_size[0] * pilot_size[1]), t0,
        lambda h, e: f"the finest tau_max tried ({h:g}) has an estimated error of {e:.3g}")
    img, view = child(tf_fast, tau, termination).execute_with_view(
        camera, size, progress=progress, progress_bar=progress_bar, view=view, chunk_seconds=chunk_seconds, far=far)
    img.metadata["tolerance"] = record
    img.metadata["settings"] = plan_settings(plan, img.metadata["settings"])
    # replayed, the settings choose again: tau_max stays the plan's (the default)
    img.metadata["settings"]["keywords"] = {**img.metadata["settings"].get("keywords", {}), "tau_max": plan.tau_max}
    return img, view
