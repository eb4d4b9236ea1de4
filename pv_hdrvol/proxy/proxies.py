"""A set of proxy images: what exploration needs without the volume, and its folder.

On disk a proxy set is a folder (a Cinema Spec D database): ``proxies.exr`` holds every
image as float32 channels (HDR kept), ``proxies.json`` the camera, the transfer
function, the interval edges, the isovalues and the colour model's table,
``data.csv`` the Cinema index and ``preview.png`` the tone-mapped reference render.
"""
from __future__ import annotations

import csv
import json
import math
import os
import pathlib
from dataclasses import replace

import numpy as np

from .._validate import as_int, as_real
from ..data.transfer import TransferFunction
from ..image.hdr import HDRImage
from ..params import Light
from ..rays.camera import Camera
from . import synthesis as S

FORMAT = "pv_hdrvol proxies"
VERSION = 1
#: channel groups: per interval (I), per layer (L); "mp_" groups are multi-perspective
INTERVAL_GROUPS = ("atten", "own", "entry")
LAYER_GROUPS = ("depth",)
MP_INTERVAL_GROUPS = ("mp_atten", "mp_own", "mp_entry")
MP_LAYER_GROUPS = ("mp_depth", "mp_dist")
#: rotations beyond these many degrees (the larger of azimuth and elevation) are refused:
#: single-perspective proxies hold only the surface seen from the original view, the
#: 45-degree rays of the distortion camera reach surfaces up to about 45 degrees beyond
#: it (docs/proxy.md has the measured correlation per angle)
MAX_ROTATION = {"single": 30.0, "multi": 60.0}


#: bins of the radiality histogram (methods.md B.1.9): 18 of 5 degrees over [0, 90]
RADIALITY_BINS = np.linspace(0.0, 90.0, 19)


def mp_camera(camera, pole_scale):
    """The camera whose image the multi-perspective proxies fill: ``camera`` with a view
    widened so that its distorted rays cover what ``camera`` shows.

    A ray tilted by ``atan(1 / s)`` from the pixel at distance ``d`` from the pole has
    come ``z / s`` closer to the pole at depth ``z``; at the focal point's depth ``D``
    the rays cover the camera's view (half height ``h``) when ``d`` reaches
    ``h + D / s``: the pixels around the ring ``d = D / s`` look at the focal point from
    all sides."""
    depth = float(np.dot(np.asarray(camera.focal_point) - np.asarray(camera.position), camera.basis()[2]))
    return replace(camera, parallel_scale=camera.parallel_scale + max(depth, 0.0) / pole_scale)


def as_scale(spec, intervals, name="opacity_scale"):
    """An extinction scale per interval from a dict ``{interval: k}``, a sequence of
    ``intervals`` numbers or ``None`` (all 1)."""
    out = np.ones(intervals)
    if spec is None:
        return out
    if isinstance(spec, dict):
        for key, k in spec.items():
            i = as_int(f"{name} interval", key)
            if not 0 <= i < intervals:
                raise ValueError(f"{name}: interval {key!r} is out of range; these proxies have intervals "
                                 f"0..{intervals - 1}")
            out[i] = as_real(f"{name}[{key}]", k, low=0.0)
        return out
    arr = np.asarray(spec, dtype=np.float64).reshape(-1)
    if arr.shape != (intervals,):
        raise ValueError(f"{name} must be a dict {{interval: k}} or {intervals} numbers; got {len(arr)} numbers")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name} must hold finite numbers >= 0; got {arr.tolist()}")
    return arr


class ProxyFormatError(ValueError):
    """A proxy folder is missing a part or its parts disagree."""


def _channel(group, k):
    prefix = "mp." if group.startswith("mp_") else ""
    base = group[3:] if group.startswith("mp_") else group
    return f"{prefix}{base}.{'L' if base in ('depth', 'dist') else 'I'}{k:02d}"


class ProxySet:
    """Proxy images of one volume, camera and transfer function (:func:`make_proxies`,
    :func:`load_proxies`).

    Attributes
    ----------
    camera : Camera
        Parallel projection; depth is measured from the plane through its position.
    size : (width, height)
    tf : TransferFunction
    edges : ndarray (intervals + 1,)
        Value edges of the intensity intervals (uniform on the function's axis).
    isovalues : ndarray (layers,)
    rgba : ndarray (rows, cols, 4)
        The reference render (linear, premultiplied).
    atten, own, entry : ndarray (intervals, rows, cols)
        Accumulated attenuation, own opacity and entry depth of each interval.
    depth : ndarray (layers, rows, cols)
        Depth of each isovalue's first crossing (``inf``: none).
    model : ColorModel or None
    pole_scale : float or None
        Multi-perspective proxies exist when set (``mp_depth``, ``mp_dist``, ...).
    """

    def __init__(self, *, camera, size, tf, edges, isovalues, arrays, model=None, pole_scale=None, training=(),
                 info=None):
        self.camera, self.size, self.tf = camera, tuple(size), tf
        self.edges = np.asarray(edges, dtype=np.float64)
        self.isovalues = np.asarray(isovalues, dtype=np.float64)
        self.arrays = dict(arrays)
        self.model, self.pole_scale = model, pole_scale
        self.training = [list(map(float, s)) for s in training]
        self.info = dict(info or {})

    # -- what is held ---------------------------------------------------------------
    def __getattr__(self, name):
        arrays = self.__dict__.get("arrays", {})
        if name in arrays:
            return arrays[name]
        raise AttributeError(f"{type(self).__name__!s} has no attribute {name!r}")

    @property
    def intervals(self):
        return len(self.edges) - 1

    @property
    def n_layers(self):
        return len(self.isovalues)

    @property
    def multi_perspective(self):
        return self.pole_scale is not None

    @property
    def mp_camera(self):
        """The camera of the multi-perspective images (a wider view: :func:`mp_camera`)."""
        return mp_camera(self.camera, self.pole_scale) if self.multi_perspective else None

    @property
    def pitch(self):
        """World units per pixel."""
        return 2.0 * self.camera.parallel_scale / self.size[1]

    def interval_of(self, value):
        """The interval holding data ``value``."""
        i = int(np.searchsorted(self.edges, value, side="right")) - 1
        return min(max(i, 0), self.intervals - 1)

    def storage(self):
        """Bytes of the proxies (float32 channels, the colour model) against the volume's."""
        channels = sum(a.size // (self.size[0] * self.size[1]) for a in self.arrays.values())
        proxy = channels * self.size[0] * self.size[1] * 4
        lut = 0 if self.model is None else self.model.lut().size * 8
        volume = int(self.info.get("volume_bytes", 0))
        return {"channels": int(channels), "proxy_bytes": int(proxy + lut), "volume_bytes": volume,
                "ratio": (proxy + lut) / volume if volume else math.nan}

    def __repr__(self):
        w, h = self.size
        model = "no colour model" if self.model is None else f"K={self.model.clusters}"
        mp = f", multi-perspective (pole_scale {self.pole_scale:g})" if self.multi_perspective else ""
        return (f"ProxySet({w}x{h}, {self.intervals} intervals, {self.n_layers} layers{mp}, {model}, "
                f"{self.storage()['channels']} channels)")

    # -- exploration ----------------------------------------------------------------
    def attenuation(self, opacity_scale=None, rotate=None):
        """``(atten, entry)``, each (intervals, rows, cols): the attenuation after an
        opacity change (``opacity_scale`` as :meth:`synthesize`'s) and the entry depths,
        for the view turned by ``rotate``. The corrected slab model
        (``model.propagate_corrected``) with each interval's own opacity and entry
        depth; a turn first warps each interval's slab (experimental)."""
        from .model import propagate_corrected

        scale = as_scale(opacity_scale, self.intervals)
        if self._rotation(rotate) is None:
            if np.all(scale == 1.0):
                return self.atten.copy(), self.entry
            return propagate_corrected(self.atten, scale, own=self.own, entry=self.entry), self.entry
        atten, own, entry = self._warp_slabs(rotate)
        return propagate_corrected(atten, scale, own=own, entry=entry), entry

    def _predict(self, scale, rotate):
        """``(rgb, atten, entry)`` after the opacity change ``scale`` (and rotation):
        the corrected slab model and the colour model in one pass per pixel
        (``_synth_kernels.predict_colors``; the same as :meth:`attenuation` and
        ``ColorModel.predict``, to rounding)."""
        from ._synth_kernels import predict_colors

        if self.model is None:
            raise ValueError("these proxies have no colour model (made with training=0): they can show the "
                             "reference render and its layers, not an opacity change or a rotated volume")
        if self._rotation(rotate) is None:
            atten, own, entry = self.atten, self.own, self.entry
        else:
            atten, own, entry = self._warp_slabs(rotate)
        shape = atten.shape
        flat = [np.ascontiguousarray(x.reshape(self.intervals, -1), dtype=np.float64) for x in (atten, own, entry)]
        m = self.model
        rgb = np.empty((flat[0].shape[1], 3))
        out = np.empty_like(flat[0])
        predict_colors(flat[0], flat[1], flat[2], np.ascontiguousarray(scale, dtype=np.float64),
                       np.ascontiguousarray(m.centroids), np.ascontiguousarray(m.colors),
                       np.ascontiguousarray(m.jacobians), rgb, out)
        return rgb.reshape(shape[1:] + (3,)), out.reshape(shape), entry

    def _rotation(self, rotate):
        """``None`` for no rotation, else the checked ``(azimuth, elevation)``."""
        if rotate is None:
            return None
        cam = S.rotated_camera(self.camera, rotate)  # validates
        az, el = (float(x) for x in rotate)
        if az == 0.0 and el == 0.0:
            return None
        kind = "multi" if self.multi_perspective else "single"
        limit = MAX_ROTATION[kind]
        if max(abs(az), abs(el)) > limit:
            raise ValueError(f"rotate={tuple(rotate)!r} turns further than these {kind}-perspective proxies hold "
                             f"({limit:g} degrees); " + ("make them with multi_perspective=True to turn up to "
                                                         f"{MAX_ROTATION['multi']:g}" if kind == "single" else
                                                         "render the volume for this view"))
        return cam

    def _warp_slabs(self, rotate):
        """Each interval's slab (entry depth, own opacity, attenuation) seen from the
        view turned by ``rotate``: ``(atten, own, entry)``, each (intervals, rows, cols)."""
        from ._synth_kernels import splat_slabs

        cam = self._rotation(rotate)
        mp = self.multi_perspective
        src = "mp_" if mp else ""
        source_cam = self.mp_camera if mp else self.camera
        plane, _ = S.pixel_points(source_cam, self.size)
        plane = np.ascontiguousarray(plane.reshape(-1, 3))
        lateral = plane - np.asarray(source_cam.position)
        d = np.linalg.norm(lateral, axis=1)
        lateral = np.ascontiguousarray(np.where(d[:, None] > 0, lateral / np.where(d > 0, d, 1.0)[:, None], 0.0))
        w, h = self.size
        flat = [np.ascontiguousarray(self.arrays[src + g].reshape(self.intervals, -1), dtype=np.float64)
                for g in ("entry", "own", "atten")]
        right, up, fwd = cam.basis()
        cam_array = np.concatenate([np.asarray(cam.position), right, up, fwd, [self.pitch]])
        z = np.empty((self.intervals, w * h))
        own = np.empty_like(z)
        atten = np.empty_like(z)
        splat_slabs(plane, lateral, np.asarray(source_cam.basis()[2]), 1.0 / self.pole_scale if mp else 0.0,
                    flat[0], flat[1], flat[2], cam_array, w, h, S.FILL_NEIGHBOURS, S.FILL_PASSES, 4.0 * self.pitch,
                    z, own, atten)
        # warped attenuation from different pixels need not sum to at most 1
        total = atten.sum(axis=0)
        atten *= np.where(total > 1.0, 1.0 / np.where(total > 1.0, total, 1.0), 1.0)
        shape = (self.intervals, h, w)
        return atten.reshape(shape), own.reshape(shape), z.reshape(shape)

    def layer_depth(self, layer=0, rotate=None):
        """Depth image (rows, cols) of depth layer ``layer`` for the view turned by
        ``rotate`` (``inf`` where no surface): the multi-perspective layer undistorted and
        reprojected when the proxies have one, else the plain layer."""
        k = self._layer(layer)
        cam = self._rotation(rotate)
        if cam is None:
            return self.depth[k].copy()
        if self.multi_perspective:
            return S.warp_depth(self.mp_camera, self.size, self.mp_depth[k], self.mp_dist[k], cam,
                                jump=4 * self.pitch)
        return S.warp_depth(self.camera, self.size, self.depth[k], None, cam, jump=4 * self.pitch)

    def _layer(self, layer):
        if isinstance(layer, bool) or not isinstance(layer, (int, np.integer)):
            raise TypeError(f"layer must be an int; got {layer!r}")
        if not 0 <= layer < self.n_layers:
            raise ValueError(f"layer {layer} is out of range; these proxies have "
                             + (f"layers 0..{self.n_layers - 1}" if self.n_layers else "no depth layers "
                                "(make them with layers=[isovalues])"))
        return int(layer)

    def synthesize(self, opacity_scale=None, *, rotate=None, light=None, enhance=None, contrast=0.5,
                   layers=None, ambient_occlusion=None, ambient=0.1, diffuse=0.7, specular=0.2, specular_power=10.0):
        """An image synthesised from the proxies alone.

        Parameters
        ----------
        opacity_scale : dict {interval: k} or sequence of ``intervals`` floats
            Multiply each interval's extinction by ``k >= 0`` (0 removes it): colour from
            the colour model of the propagated attenuation.
        rotate : (azimuth, elevation) degrees
            Turn the view about the focal point (see ``MAX_ROTATION``).
        light : Light or list of Light, optional
            Relight: the volume image from the depth of its attenuation-weighted entry
            depths, or the layers from their depth.
        enhance : float, optional
            Depth-aware enhancement strength ``lambda`` (paper Eq. 11), with ``contrast``.
        layers : dict {layer: (rgb, opacity)}, optional
            Draw the depth layers instead of the volume: each in its colour and opacity,
            lit, composited front to back.
        ambient_occlusion : float, optional
            Layers: proxy ambient-occlusion strength (paper Eq. 5; radius 8 pixels).

        Returns
        -------
        HDRImage
            Linear premultiplied RGBA. ``depth``: for layers the nearest layer's
            distance from the image plane; for the relit volume the depth it was lit
            by (attenuation-weighted entry depths); else none.
        """
        from . import lighting as LT

        lights = None if light is None else (list(light) if isinstance(light, (list, tuple)) else [light])
        for lt in lights or ():
            if not isinstance(lt, Light):
                raise TypeError(f"light must be a pv_hdrvol.Light or a list of them; got {type(lt).__name__}")
        cam = self._rotation(rotate) or self.camera
        basis = cam.basis()
        shading = dict(ambient=ambient, diffuse=diffuse, specular=specular, specular_power=specular_power)
        meta = {"renderer": "pv_hdrvol proxy synthesis", "precision": "float64", "rotate": None if rotate is None else list(rotate),
                "opacity_scale": as_scale(opacity_scale, self.intervals).tolist()}
        if layers is not None:
            if not isinstance(layers, dict) or not layers:
                raise TypeError(f"layers must be a non-empty dict {{layer: (rgb, opacity)}}; got {layers!r}")
            depths, colors, opac = [], [], []
            for key, style in layers.items():
                try:
                    rgb, op = style
                except (TypeError, ValueError):
                    raise TypeError(f"layers[{key!r}] must be (rgb, opacity); got {style!r}") from None
                z = self.layer_depth(key, rotate)
                n = LT.normals_from_depth(z, self.pitch)
                lit = LT.shade(n, np.asarray(rgb, dtype=np.float64), lights, basis=basis, **shading)
                if ambient_occlusion:
                    lit = lit * LT.ambient_occlusion(z, self.pitch, strength=ambient_occlusion)[..., None]
                depths.append(z)
                colors.append(lit)
                opac.append(np.where(np.isfinite(z), float(op), 0.0))
            rgba = LT.composite_layers(np.stack(colors), np.stack(opac), np.stack(depths))
            front = np.min(np.stack(depths), axis=0)
            meta["layers"] = {str(k): [list(map(float, v[0])), float(v[1])] for k, v in layers.items()}
            return HDRImage(rgba, front, metadata=meta)

        scale = as_scale(opacity_scale, self.intervals)
        identity = np.all(scale == 1.0) and self._rotation(rotate) is None
        if identity:  # the reference render itself
            rgb, alpha = self.rgba[..., :3].copy(), self.rgba[..., 3].copy()
            atten, entry = self.atten, self.entry
        else:
            rgb, atten, entry = self._predict(scale, rotate)
            alpha = atten.sum(axis=0)
        zrep = None  # the attenuation-weighted entry depth: formed only to light by it
        if lights is not None:
            zrep = self._mean_depth(atten, entry)
            n = LT.normals_from_depth(zrep, self.pitch)
            safe = np.where(alpha > 0, alpha, 1.0)[..., None]
            lit = LT.shade(n, rgb / safe, lights, basis=basis, **shading) * alpha[..., None]
            rgb = np.where(np.isfinite(zrep)[..., None], lit, rgb)
            meta["lights"] = [{"direction": lt.direction, "intensity": list(lt.intensity)} for lt in lights]
        rgba = np.concatenate([rgb, alpha[..., None]], axis=2)
        if enhance is not None:
            rgba = LT.enhance(rgba, atten, strength=enhance, contrast=contrast)
            meta["enhance"] = [float(enhance), float(contrast)]
        return HDRImage(rgba, zrep, metadata=meta)

    @staticmethod
    def _mean_depth(atten, entry):
        """Per pixel, the entry depths of the intervals weighted by their attenuation
        (``inf`` where nothing shows): the surface the volume image is lit by."""
        seen = np.isfinite(entry) & (atten > 0)
        weight = np.where(seen, atten, 0.0)
        total = weight.sum(axis=0)
        depth = (weight * np.where(seen, entry, 0.0)).sum(axis=0)
        return np.where(total > 0, depth / np.where(total > 0, total, 1.0), np.inf)

    def radiality(self, layer=0, multi_perspective=None):
        """``(counts, bin_edges)``: the radiality histogram of a layer (methods.md B.1.9),
        from the volume's gradient when the proxies were made."""
        k = self._layer(layer)
        mp = self.multi_perspective if multi_perspective is None else bool(multi_perspective)
        key = "mp_radiality" if mp else "radiality"
        if key not in self.info:
            raise ValueError("these proxies have no multi-perspective layers" if mp else "no radiality recorded")
        return np.asarray(self.info[key][k]), RADIALITY_BINS.copy()

    # -- files ----------------------------------------------------------------------
    def save(self, path):
        """Write the proxy folder ``path`` (created; existing proxy files in it are
        replaced, other files are left alone). Returns the path."""
        from ..image.io import openexr_module, check_writable

        folder = pathlib.Path(path)
        if folder.exists() and not folder.is_dir():
            raise ValueError(f"{os.fspath(path)!r} exists and is not a folder: a proxy set is saved as a folder")
        folder.mkdir(parents=True, exist_ok=True)
        OpenEXR = openexr_module()
        channels = {"R": self.rgba[..., 0], "G": self.rgba[..., 1], "B": self.rgba[..., 2], "A": self.rgba[..., 3]}
        groups = {}
        for group, stack in self.arrays.items():
            if group == "rgba":
                continue
            groups[group] = int(stack.shape[0])
            for k in range(stack.shape[0]):
                channels[_channel(group, k)] = stack[k]
        channels = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in channels.items()}
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        exr = folder / "proxies.exr"
        check_writable(exr)
        with OpenEXR.File(header, channels) as f:
            f.write(os.fspath(exr))
        meta = {
            "format": FORMAT, "version": VERSION, "size": list(self.size), "camera": self.camera.to_dict(),
            "transfer_function": self.tf.to_dict(), "edges": self.edges.tolist(),
            "isovalues": self.isovalues.tolist(), "pole_scale": self.pole_scale, "groups": groups,
            "training": self.training, "info": self.info,
            "model": None if self.model is None else {"lut": self.model.lut().tolist(),
                                                       "intervals": self.model.intervals},
        }
        (folder / "proxies.json").write_text(json.dumps(meta, indent=1))
        HDRImage(self.rgba).save_png(folder / "preview.png")
        right, up, fwd = self.camera.basis()
        phi = math.degrees(math.atan2(-fwd[1], -fwd[0]))
        theta = math.degrees(math.asin(max(-1.0, min(1.0, -fwd[2]))))
        with open(folder / "data.csv", "w", newline="") as f:
            wr = csv.writer(f)
            wr.writerow(["phi", "theta", "intervals", "layers", "FILE", "FILE_proxies", "FILE_parameters"])
            wr.writerow([f"{phi:.6g}", f"{theta:.6g}", self.intervals, self.n_layers, "preview.png", "proxies.exr",
                         "proxies.json"])
        return folder


def load_proxies(path):
    """Read a proxy folder written by :meth:`ProxySet.save` (no volume needed).

    Raises
    ------
    FileNotFoundError
        ``path`` or one of its files does not exist.
    ProxyFormatError (a ValueError)
        A channel is missing, has another size, or the parameters disagree with it.
    """
    from ..image.io import openexr_module
    from .model import ColorModel

    folder = pathlib.Path(path)
    if not folder.is_dir():
        raise FileNotFoundError(f"no proxy folder at {os.fspath(path)!r}")
    meta_path, exr = folder / "proxies.json", folder / "proxies.exr"
    for p in (meta_path, exr):
        if not p.is_file():
            raise FileNotFoundError(f"{os.fspath(path)!r} is not a complete proxy folder: {p.name} is missing")
    try:
        meta = json.loads(meta_path.read_text())
    except ValueError as exc:
        raise ProxyFormatError(f"{os.fspath(meta_path)!r} is not valid JSON: {exc}") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ProxyFormatError(f"{os.fspath(meta_path)!r} is not a pv_hdrvol proxy description")
    if meta.get("version") != VERSION:
        raise ProxyFormatError(f"{os.fspath(meta_path)!r} has version {meta.get('version')!r}; this pv_hdrvol "
                               f"reads version {VERSION}")
    OpenEXR = openexr_module()
    try:
        with OpenEXR.File(os.fspath(exr)) as f:
            ch = {name: np.asarray(c.pixels, dtype=np.float64) for name, c in f.channels().items()}
    except (RuntimeError, ValueError) as exc:
        raise ProxyFormatError(f"{os.fspath(exr)!r} is not a readable OpenEXR file: {exc}") from None
    w, h = (int(x) for x in meta["size"])
    # a multi-channel file may come back as one RGBA array
    if "RGBA" in ch:
        rgba = ch.pop("RGBA")
    else:
        missing = [c for c in "RGBA" if c not in ch]
        if missing:
            raise ProxyFormatError(f"{os.fspath(exr)!r} lacks the reference render's channel(s) {missing}")
        rgba = np.stack([ch.pop(c) for c in "RGBA"], axis=-1)
    if rgba.shape != (h, w, 4):
        raise ProxyFormatError(f"{os.fspath(exr)!r}: the images are {rgba.shape[1]}x{rgba.shape[0]}; "
                               f"proxies.json says {w}x{h}")
    edges = np.asarray(meta["edges"], dtype=np.float64)
    isovalues = np.asarray(meta["isovalues"], dtype=np.float64)
    n_int, n_lay = len(edges) - 1, len(isovalues)
    groups = meta.get("groups", {})
    expected = {g: n_int for g in INTERVAL_GROUPS}
    expected.update({g: n_lay for g in LAYER_GROUPS})
    if meta.get("pole_scale") is not None:
        expected.update({g: n_int for g in MP_INTERVAL_GROUPS})
        expected.update({g: n_lay for g in MP_LAYER_GROUPS})
    arrays = {"rgba": rgba}
    for group, count in expected.items():
        if groups.get(group, count) != count:
            raise ProxyFormatError(f"proxies.json lists {groups.get(group)} '{group}' channels; its "
                                   f"{'intervals' if count == n_int else 'layers'} say {count}")
        planes = []
        for k in range(count):
            name = _channel(group, k)
            if name not in ch:
                raise ProxyFormatError(f"{os.fspath(exr)!r} lacks channel {name!r} ({group} of "
                                       f"{'interval' if count == n_int else 'layer'} {k})")
            if ch[name].shape != (h, w):
                raise ProxyFormatError(f"channel {name!r} is {ch[name].shape[1]}x{ch[name].shape[0]}; the proxies "
                                       f"are {w}x{h}")
            planes.append(ch[name])
        arrays[group] = np.stack(planes) if planes else np.empty((0, h, w))
    model = None
    if meta.get("model") is not None:
        lut = np.asarray(meta["model"]["lut"], dtype=np.float64)
        if lut.shape[0] != 4 * n_int + 3:
            raise ProxyFormatError(f"the colour model's table has {lut.shape[0]} rows; {n_int} intervals need "
                                   f"{4 * n_int + 3}")
        model = ColorModel.from_lut(lut)
    return ProxySet(camera=Camera.from_dict(meta["camera"]), size=(w, h),
                    tf=TransferFunction.from_dict(meta["transfer_function"]), edges=edges, isovalues=isovalues,
                    arrays=arrays, model=model, pole_scale=meta.get("pole_scale"), training=meta.get("training", []),
                    info=meta.get("info", {}))


def storage_ratio(volume_side, image_side, images):
    """Proxy elements over volume elements for ``images`` proxy images of
    ``image_side``\\ :sup:`2` pixels against a ``volume_side``\\ :sup:`3` volume (paper Fig. 15).

    Examples
    --------
    The paper's pessimistic case, ``images = N / 10`` at 512\\ :sup:`2`:

    >>> [round(storage_ratio(n, 512, n / 10), 5) for n in (128, 256, 512, 1024)]
    [1.6, 0.4, 0.1, 0.025]
    """
    n = float(volume_side)
    m = float(image_side)
    k = float(images)
    if not (n > 0 and m > 0 and k > 0):
        raise ValueError(f"sides and image count must be > 0; got {volume_side!r}, {image_side!r}, {images!r}")
    return k * m * m / n ** 3
