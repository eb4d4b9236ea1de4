"""Making proxy images from a volume: the heavy pass, run once where the volume lives.

One pass of :func:`march_proxies` along each pixel's ray keeps, per intensity interval,
the accumulated attenuation, the interval's own opacity and its entry depth, and per
isovalue the depth of its first crossing (``proxy/_kernels.py``). :func:`make_proxies`
runs it for the camera's rays (the reference render and its proxies), for the training
renders of the colour model (the same rays with the extinction of each interval
scaled), and along the rays of a :class:`VolumeDistortionCamera` (multi-perspective
proxies, for rotation).

Proxies need a parallel-projection camera: depth is then the distance from the image
plane, pixels are a fixed world size (``pitch``), and normals from depth are exact
(methods.md B.1.4). The image plane is moved, along the view, to touch the volume's
bounding sphere on the near side (which changes no pixel of a parallel view) so that
the distortion camera's rays converge on the pole line inside the volume.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from .._validate import as_int, as_real, as_size
from ..data.transfer import SCALE_CODES, scale_inverse
from ..params import PRECISION_CODES, RenderOptions
from ..raycast import _kernels as K
from ..raycast.grid import as_volume, resolve_transfer_function
from ..rays.camera import Camera, Rays
from ..rays.lenses import Lens
from . import _kernels as PK
from .proxies import RADIALITY_BINS, ProxySet, as_scale, mp_camera


@dataclass(frozen=True)
class VolumeDistortionCamera(Lens):
    """The paper's volume distortion camera (Eq. 1): rays bent towards the pole line.

    The pole line runs through the camera's position along the view direction ``v``.
    The ray of the pixel whose point ``p`` on the image plane lies at distance ``d``
    from it is aimed at ``E = position + v s d`` (``s`` = ``pole_scale``): every ray is
    tilted by ``atan(1 / s)`` towards the pole (45 degrees for the paper's ``s = 1``),
    reaches it at depth ``s d`` and goes on across it. The centre's ray is the camera's.

    Parameters
    ----------
    pole_scale : float
        ``s > 0``; ``d`` is measured in world units on the image plane.

    Examples
    --------
    >>> cam = Camera((0, 0, 10), (0, 0, 0), (0, 1, 0), parallel_projection=True, parallel_scale=2)
    >>> rays = VolumeDistortionCamera().rays(cam, (4, 4))
    >>> round(float(np.degrees(np.arccos(-rays.directions[0, 2]))), 9)
    45.0
    """

    pole_scale: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "pole_scale", as_real("pole_scale", self.pole_scale, low=0.0, low_open=True))

    def rays(self, camera, size):
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a Camera; got {type(camera).__name__}")
        if not camera.parallel_projection:
            raise ValueError("the volume distortion camera needs a parallel-projection camera "
                             "(Camera(..., parallel_projection=True)); got a perspective one")
        base = camera.rays(size)
        fwd = camera.basis()[2]
        lateral = base.origins - np.asarray(camera.position)
        d = np.sqrt(np.einsum("ij,ij->i", lateral, lateral))
        aim = fwd * (self.pole_scale * d)[:, None] - lateral
        norm = np.sqrt(np.einsum("ij,ij->i", aim, aim))
        directions = np.where(norm[:, None] > 0, aim / np.where(norm > 0, norm, 1.0)[:, None], fwd)
        return Rays(base.origins, np.ascontiguousarray(directions), base.width, base.height)


def as_proxy_camera(camera, bounds):
    """A parallel-projection :class:`Camera` from ``None`` (the iso view), a view name
    (``"xy"``, ``"iso"``, ...: :meth:`Camera.fit`) or a parallel Camera."""
    if camera is None:
        camera = "iso"
    if isinstance(camera, str):
        return Camera.fit(bounds, camera, parallel_projection=True)
    return camera


def proxy_camera(camera, bounds):
    """``camera`` (parallel projection) with its position moved along the view to the
    plane touching the bounding sphere of ``bounds`` on the near side."""
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a Camera; got {type(camera).__name__}")
    if not camera.parallel_projection:
        raise ValueError("proxies need a parallel-projection camera (Camera(..., parallel_projection=True) or "
                         "Camera.fit(data, view, parallel_projection=True)); got a perspective camera")
    b = np.asarray(bounds, dtype=np.float64)
    center = 0.5 * (b[0::2] + b[1::2])
    radius = 0.5 * float(np.linalg.norm(b[1::2] - b[0::2]))
    fwd = camera.basis()[2]
    # the focal point's depth along the view stays; the plane moves to the sphere's near side
    depth = float(np.dot(center - np.asarray(camera.focal_point), fwd)) - radius
    position = np.asarray(camera.focal_point) + fwd * depth
    if np.allclose(position, camera.focal_point):
        position = position - fwd * max(radius, 1e-9)
    return replace(camera, position=tuple(position.tolist()))


def interval_edges(tf, intervals):
    """The ``intervals + 1`` value edges of uniform intervals on ``tf``'s axis."""
    a0, a1 = tf.axis_range
    axis = np.linspace(a0, a1, intervals + 1)
    return np.asarray(scale_inverse(axis, tf.scale, tf.linthresh), dtype=np.float64)


def opacity_peaks(tf, count, samples=4096):
    """``count`` isovalues at the highest local maxima of ``tf``'s opacity (the paper's
    layers "at peaks of the user opacity function"), ascending."""
    count = as_int("count", count, low=1)
    a0, a1 = tf.axis_range
    values = np.asarray(scale_inverse(np.linspace(a0, a1, samples), tf.scale, tf.linthresh))
    op = np.asarray(tf.opacity_at(values), dtype=np.float64)
    rising = np.concatenate([[True], op[1:] > op[:-1]])
    falling = np.concatenate([op[:-1] >= op[1:], [True]])
    peaks = np.flatnonzero(rising & falling & (op > 0))
    if peaks.size == 0:
        raise ValueError(f"{tf!r} has no opacity: it has no peaks to put depth layers at")
    best = peaks[np.argsort(-op[peaks], kind="stable")[:count]]
    return np.sort(values[best])


class ProxyPass:
    """The transfer-function tables and kernel settings of one volume and function,
    validated once; :meth:`run` casts any rays with any interval scaling."""

    def __init__(self, volume, tf, intervals, isovalues, step=0.5, opacity_unit_distance=None):
        from ..raycast.grid import GridPlan

        # the grid ray caster's own tables (float64: opacity per full step, extinction)
        plan = GridPlan(volume, tf, RenderOptions(step=step, precision="float64", termination=0.0,
                                                  opacity_unit_distance=opacity_unit_distance))
        self.volume, self.tf, self.options = volume, tf, plan.options
        self.intervals = intervals
        self.isovalues = np.ascontiguousarray(isovalues, dtype=np.float64)
        self.table = np.ascontiguousarray(plan.table.reshape(-1))
        self.sigma = plan.sigma
        a0, a1 = tf.axis_range
        self.params = K.GridParams(float(plan.step_world), PRECISION_CODES["float64"], SCALE_CODES[tf.scale],
                                   float(a0), float(1.0 / (a1 - a0)), float(tf.linthresh), math.inf, 1.0, 3)
        self.values = np.ascontiguousarray(volume.values, dtype=np.float64)
        self.unit, self.step_world = plan.unit, plan.step_world

    def run(self, rays, scale=None):
        """Cast ``rays`` (world). Returns ``rgba (n, 4)``, ``atten``, ``optical depth``,
        ``entry`` (each (n, intervals)) and ``layers`` (n, isovalues): ray distances."""
        n = rays.origins.shape[0]
        scale = np.ones(self.intervals) if scale is None else np.ascontiguousarray(scale, dtype=np.float64)
        inv = 1.0 / self.volume.spacing
        origins = np.ascontiguousarray((rays.origins - self.volume.origin) * inv)
        directions = np.ascontiguousarray(rays.directions * inv)
        lo = np.zeros(3)
        hi = np.array(self.volume.dims, dtype=np.float64) - 1.0
        rgba = np.zeros((n, 4))
        atten = np.zeros((n, self.intervals))
        optical = np.zeros((n, self.intervals))
        entry = np.full((n, self.intervals), np.inf)
        layers = np.full((n, len(self.isovalues)), np.inf)
        if min(self.volume.dims) >= 2:
            PK.march_proxies(self.values, self.table, self.sigma, self.params, scale, self.isovalues, origins,
                             directions, lo, hi, rgba, atten, optical, entry, layers)
        return rgba, atten, optical, entry, layers


def training_scales(training, intervals, seed=0):
    """The extinction scales of the training renders. The first is always the transfer
    function itself (the proxies' own render); ``training`` renders in all, the others
    with each interval's extinction scaled by a factor drawn log-uniformly from
    [0.01, 1] (seeded); or, for a list of ``opacity_scale`` specs, one more render per
    spec (a spec of all ones is the first render, not repeated).

    Examples
    --------
    >>> [s.tolist() for s in training_scales([{1: 0.5}, {}], 3)]
    [[1.0, 1.0, 1.0], [1.0, 0.5, 1.0]]
    """
    if isinstance(training, (list, tuple)):
        scales = [np.ones(intervals)]
        for spec in training:
            scale = as_scale(spec, intervals, "training")
            if not np.all(scale == 1.0):
                scales.append(scale)
        return scales
    n = as_int("training", training, low=1)
    rng = np.random.default_rng(seed)
    scales = [np.ones(intervals)]
    for _ in range(n - 1):
        scales.append(10.0 ** rng.uniform(-2.0, 0.0, intervals))
    return scales


def _hit_gradients(volume, points):
    """World gradients of ``volume`` at world ``points`` (n, 3) (trilinear central differences)."""
    from scipy.ndimage import map_coordinates

    grads = np.gradient(np.asarray(volume.values, dtype=np.float64), *volume.spacing[::-1])
    idx = ((points - volume.origin) / volume.spacing)[:, ::-1].T  # (z, y, x) index coordinates
    return np.stack([map_coordinates(grads[2 - a], idx, order=1, mode="nearest") for a in range(3)], axis=1)


def radiality(volume, rays, t):
    """Histogram (counts per 5 degrees over [0, 90]) of the angle between the isosurface
    normal at each finite hit ``t`` (ray distance) and its ray (methods.md B.1.9)."""
    ok = np.isfinite(t)
    if not ok.any():
        return np.zeros(len(RADIALITY_BINS) - 1, dtype=np.int64)
    pts = rays.origins[ok] + t[ok, None] * rays.directions[ok]
    g = _hit_gradients(volume, pts)
    gn = np.linalg.norm(g, axis=1)
    good = gn > 0
    cos = np.abs(np.einsum("ij,ij->i", g[good], rays.directions[ok][good])) / gn[good]
    angle = np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))
    return np.histogram(angle, RADIALITY_BINS)[0].astype(np.int64)


def make_proxies(data, camera=None, size=(512, 512), tf=None, *, intervals=16, layers=None, multi_perspective=False,
                 pole_scale=1.0, training=3, clusters=24, seed=0, step=0.5, scalars=None, preference="point",
                 opacity_unit_distance=None, progress_bar=None):
    """Proxy images of a volume: everything later exploration needs, without the volume.

    Parameters
    ----------
    data : image volume (``pyvista.ImageData``, ``vtkImageData``, 3-D array, GridVolume)
        Not a tetrahedral mesh (a ``TypeError``): the proxy pass marches voxels.
    camera : Camera or str, optional
        A parallel-projection camera, or a view name framed with one (default "iso":
        ``Camera.fit(data, "iso", parallel_projection=True)``). Its position is moved along the view to the near
        side of the volume's bounding sphere (no pixel changes).
    size : int or (width, height)
    tf : TransferFunction, optional
        Default: the renderer's default for the data.
    intervals : int
        ``L``, uniform intervals on the transfer function's axis (paper: 16; 2..64).
    layers : sequence of float, int or None
        Isovalues of the depth layers, inside the data's range (one outside it would
        give an empty layer: a ``ValueError``); an int ``k`` puts ``k`` layers at the
        highest peaks of the opacity (:func:`opacity_peaks`); ``None``: no depth layers.
    multi_perspective : bool
        Also make proxies along the rays of a :class:`VolumeDistortionCamera`
        (``pole_scale``), which see around the object: depth layers for rotation and
        attenuation for the (experimental) rotation of the volume image.
    training : int or list
        Training renders of the colour model, the transfer function itself first: a
        count (the others with random interval scales), or a list of
        ``opacity_scale`` specs, one more render each (:func:`training_scales`).
        ``0`` fits no colour model.
    clusters : int
        ``K`` of the colour model (paper: 24; 48 for turbulent data).
    step : float
        Sampling step in voxels (the ray caster's ``step``).

    Returns
    -------
    ProxySet
    """
    from ..data.tets import is_unstructured

    t_start = time.perf_counter()
    if is_unstructured(data):  # the proxy pass marches voxels (proxy/_kernels.py): no tetrahedral version
        raise TypeError(f"proxies are made of image data (ImageData); got a tetrahedral mesh "
                        f"({type(data).__name__}): resample it onto an image first "
                        f"(pyvista.ImageData(...).sample(mesh))")
    from ..data.kinds import BLOCKS, data_kind

    if data_kind(data) == BLOCKS:
        raise TypeError(f"proxies are made of image data (ImageData); got a {type(data).__name__} of blocks: "
                        f"render it with pv_hdrvol.render, or make proxies of one image block")
    volume = as_volume(data, scalars=scalars, preference=preference)
    if volume.axes is not None:  # the proxy pass marches voxels of even spacing
        raise TypeError("proxies are made of image data (ImageData); got a rectilinear grid (uneven axes): resample "
                        "it onto an image first (pyvista.ImageData(...).sample(grid))")
    if isinstance(training, bool):
        raise TypeError(f"training must be an int or a list of opacity scales; got {training!r}")
    intervals = as_int("intervals", intervals, low=2, high=64)
    clusters = as_int("clusters", clusters, low=1)
    width, height = as_size(size)
    tf = resolve_transfer_function(volume, tf)
    camera = proxy_camera(as_proxy_camera(camera, volume.bounds), volume.bounds)
    if layers is None:
        isovalues = np.empty(0)
    elif isinstance(layers, (int, np.integer)) and not isinstance(layers, bool):
        isovalues = opacity_peaks(tf, layers)
    else:
        isovalues = np.asarray(layers, dtype=np.float64).reshape(-1)
        if not np.all(np.isfinite(isovalues)):
            raise ValueError(f"layers must be finite isovalues; got {isovalues.tolist()}")
        lo, hi = volume.value_range
        outside = isovalues[(isovalues < lo) | (isovalues > hi)] if volume.any_finite else np.empty(0)
        if outside.size:  # no ray crosses them: their layers would be all inf, silently
            raise ValueError(f"layers {', '.join(f'{v:g}' for v in outside)} outside the data range [{lo:g}, {hi:g}] "
                             f"would be empty depth layers (no ray crosses them); choose isovalues inside the range, "
                             f"or layers=k for k layers at the opacity's peaks")
    if not isinstance(multi_perspective, (bool, np.bool_)):
        raise TypeError(f"multi_perspective must be a bool; got {multi_perspective!r}")
    scales = training_scales(training, intervals, seed) if training != 0 else [np.ones(intervals)]
    fit_model = training != 0

    pp = ProxyPass(volume, tf, intervals, isovalues, step=as_real("step", step, low=0.0, low_open=True),
                   opacity_unit_distance=opacity_unit_distance)
    rays = camera.rays((width, height))
    bar = _bar(progress_bar, len(scales) + int(bool(multi_perspective)))
    rgba, atten, optical, entry, hits = pp.run(rays, scales[0])
    bar(1)
    train_atten, train_rgb = [atten.T], [rgba[:, :3]]
    for scale in scales[1:]:
        r2, a2 = pp.run(rays, scale)[:2]
        train_atten.append(a2.T)
        train_rgb.append(r2[:, :3])
        bar(1)
    model = None
    if fit_model:
        from .model import ColorModel

        model = ColorModel.fit(np.concatenate(train_atten, axis=1), np.concatenate(train_rgb, axis=0),
                               clusters=clusters, seed=seed)
    shape = (height, width)

    def planes(a):  # (n, m) -> (m, rows, cols)
        return np.ascontiguousarray(a.T.reshape((a.shape[1],) + shape))

    fwd = camera.basis()[2]
    own = -np.expm1(-optical)
    arrays = {
        "rgba": rgba.reshape(shape + (4,)),
        "atten": planes(atten), "own": planes(own), "entry": planes(entry),
        "depth": planes(hits),  # straight parallel rays start on the image plane: depth = ray distance
    }
    info = {"radiality": [radiality(volume, rays, hits[:, j]).tolist() for j in range(len(isovalues))]}
    distortion = None
    if multi_perspective:
        distortion = VolumeDistortionCamera(pole_scale)
        mrays = distortion.rays(mp_camera(camera, pole_scale), (width, height))
        _, m_atten, m_optical, m_entry, m_hits = pp.run(mrays)
        cos_t = mrays.directions @ fwd  # depth per unit of ray distance
        sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t ** 2))
        arrays.update({
            "mp_depth": planes(m_hits * cos_t[:, None]), "mp_dist": planes(m_hits * sin_t[:, None]),
            "mp_atten": planes(m_atten), "mp_own": planes(-np.expm1(-m_optical)),
            "mp_entry": planes(m_entry * cos_t[:, None]),
        })
        info["mp_radiality"] = [radiality(volume, mrays, m_hits[:, j]).tolist() for j in range(len(isovalues))]
        bar(1)
    return ProxySet(camera=camera, size=(width, height), tf=tf, edges=interval_edges(tf, intervals),
                    isovalues=isovalues, arrays=arrays, model=model, pole_scale=pole_scale if multi_perspective else None,
                    training=[s.tolist() for s in scales], info=dict(info, seconds=time.perf_counter() - t_start,
                                                                     step=pp.options.step, step_world=pp.step_world,
                                                                     opacity_unit_distance=pp.unit,
                                                                     volume_shape=list(volume.values.shape),
                                                                     volume_bytes=int(volume.values.nbytes),
                                                                     scalars=volume.name))


def _bar(progress_bar, total):
    """A callable advancing a tqdm bar by n passes (or nothing)."""
    if not progress_bar:
        return lambda n: None
    try:
        from tqdm.auto import tqdm
    except ImportError:  # pragma: no cover
        return lambda n: None
    bar = tqdm(total=total, desc="proxy passes")
    return bar.update
