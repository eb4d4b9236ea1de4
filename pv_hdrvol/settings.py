"""What a render was made from, kept in the image's metadata so it can be made again.

Every renderer stores :func:`settings_metadata` under ``image.metadata["settings"]``:
the transfer function, camera, image size and :class:`~pv_hdrvol.RenderOptions` as
plain JSON values (floats as JSON numbers keep float64 exactly). The EXR and Radiance
headers and ``HDRImage.to_vtk`` carry the metadata, so::

    settings = hv.load("out.exr").settings()   # RenderSettings(tf, camera, size, options, keywords)
    again = settings.render(volume)            # bit-identical to the saved render

The data itself is not stored: render the same volume (the metadata's ``"scalars"``
names the array that was used).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from ._validate import as_size
from .data.transfer import TransferFunction
from .params import Light, RenderOptions
from .rays.camera import Camera

#: Version of the ``"settings"`` layout; :meth:`RenderSettings.from_dict` reads this one.
SETTINGS_VERSION = 1

# The function RenderSettings.render replays with: pv_hdrvol.render, registered by
# pv_hdrvol.dispatch as it loads (register_renderer). This record sits below the
# renderers, which import it to write their settings, so it cannot import them.
_RENDERER = []


def register_renderer(render):
    """Make ``render`` (``render(data, tf, camera, size, options=..., **keywords)``) the
    function :meth:`RenderSettings.render` calls; :mod:`pv_hdrvol.dispatch` registers
    :func:`pv_hdrvol.render`."""
    if not callable(render):
        raise TypeError(f"register_renderer needs a callable; got {type(render).__name__}")
    _RENDERER[:] = [render]


@dataclass(frozen=True)
class RenderSettings:
    """The inputs of a render besides the data: enough to render it again.

    Parameters
    ----------
    tf : TransferFunction
    camera : Camera or None
        ``None`` when the render was given rays instead of a camera (then
        :meth:`HDRImage.settings` needs ``partial=True``).
    size : (int, int)
        ``(width, height)`` in pixels.
    options : RenderOptions
    keywords : dict
        The renderer's own keywords beyond the options (``render_tets``: ``tau_max``,
        ``upsample``); empty for image volumes.

    Examples
    --------
    >>> import json, numpy as np, pv_hdrvol as hv
    >>> tf = hv.TransferFunction.ramp(0.0, 1.0, cmap="gray", opacity=(0.0, 0.3))
    >>> volume = np.linspace(0.0, 1.0, 6 * 5 * 4).reshape(6, 5, 4)
    >>> img = hv.render(volume, tf, hv.Camera.fit((0, 3, 0, 4, 0, 5), "xy"), (9, 7), step=0.3)
    >>> stored = json.loads(json.dumps(img.metadata))  # what an EXR header keeps
    >>> settings = hv.HDRImage(img.rgba, metadata=stored).settings()
    >>> settings.size, settings.options.step
    ((9, 7), 0.3)
    >>> bool(np.array_equal(settings.render(volume).rgba, img.rgba))
    True
    """

    tf: TransferFunction
    camera: Camera
    size: tuple
    options: RenderOptions
    keywords: dict = field(default_factory=dict)

    def render(self, data, **kwargs):
        """``pv_hdrvol.render(data, tf, camera, size, options=options, **keywords)``;
        ``kwargs`` add to (or replace) the keywords (``scalars=``, ``progress_bar=``...)."""
        if not _RENDERER:
            raise RuntimeError("no renderer is registered: import pv_hdrvol (its dispatch registers pv_hdrvol.render)")
        render = _RENDERER[0]
        if self.camera is None:
            raise ValueError("these settings hold no camera (the render was given rays); pass the rays: "
                             "pv_hdrvol.render(data, settings.tf, rays, options=settings.options)")
        return render(data, self.tf, self.camera, self.size, options=self.options, **{**self.keywords, **kwargs})

    def to_dict(self):
        """Plain JSON values: ``{"version", "tf", "camera", "size", "options", "keywords"}``."""
        return {
            "version": SETTINGS_VERSION,
            "tf": self.tf.to_dict(),
            "camera": None if self.camera is None else self.camera.to_dict(),
            "size": list(self.size),
            "options": options_to_dict(self.options),
            "keywords": _plain(dict(self.keywords)),
        }

    @classmethod
    def from_dict(cls, data):
        """Settings from :meth:`to_dict`'s form (as stored in ``metadata["settings"]``).

        Keys other than those of :meth:`to_dict` and ``"not_stored"`` raise
        ``ValueError``, as do a newer ``version`` and render options this version
        does not know.
        """
        if not hasattr(data, "keys"):
            raise TypeError(f"RenderSettings.from_dict needs a dict; got {type(data).__name__}")
        allowed = ("version", "tf", "camera", "size", "options", "keywords", "not_stored")
        unknown = sorted(set(data) - set(allowed))
        missing = [k for k in ("tf", "size", "options") if k not in data]
        if unknown or missing:
            raise ValueError(f"RenderSettings.from_dict: unknown keys {unknown}, missing keys {missing}; "
                             f"allowed: {list(allowed)}")
        version = data.get("version", SETTINGS_VERSION)
        if version != SETTINGS_VERSION:
            raise ValueError(f"settings version {version!r} is not readable by this pv_hdrvol (reads version "
                             f"{SETTINGS_VERSION})")
        camera = data.get("camera")
        return cls(TransferFunction.from_dict(data["tf"]), None if camera is None else Camera.from_dict(camera),
                   as_size(tuple(data["size"])), options_from_dict(data["options"]), dict(data.get("keywords") or {}))


def options_to_dict(options):
    """Every field of a :class:`RenderOptions` as plain JSON values (found by
    ``dataclasses.fields``, so fields added later travel without changes here)."""
    return {f.name: _plain(getattr(options, f.name)) for f in dataclasses.fields(options)}


def options_from_dict(data):
    """:class:`RenderOptions` from :func:`options_to_dict`'s form; absent fields take
    their defaults, unknown ones raise ``ValueError``."""
    if not hasattr(data, "keys"):
        raise TypeError(f"render options must be a dict; got {type(data).__name__}")
    names = [f.name for f in dataclasses.fields(RenderOptions)]
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise ValueError(f"unknown render options {unknown} (saved by a newer pv_hdrvol?); this version knows "
                         f"{names}")
    values = {name: _as_tuple(value) for name, value in data.items()}
    if values.get("lights") is not None:
        values["lights"] = tuple(Light(**light) if hasattr(light, "keys") else light for light in data["lights"])
    return RenderOptions(**values)


def settings_metadata(tf, camera, size, options, keywords=None, **inputs):
    """The ``"settings"`` entry of a render's metadata (``RenderSettings.to_dict()``).

    ``inputs`` are the render's other inputs that settings cannot hold (``lens=``,
    ``labels=``, ``label_styles=``, ``block_mask=``); those that are not ``None`` are
    listed under ``"not_stored"``, as is a camera given as rays.
    """
    is_camera = isinstance(camera, Camera)
    stored = RenderSettings(tf, camera if is_camera else None, as_size(size), options, dict(keywords or {}))
    out = stored.to_dict()
    not_stored = ([] if is_camera else ["rays"]) + sorted(k for k, v in inputs.items() if v is not None)
    if not_stored:
        out["not_stored"] = not_stored
    return out


def _plain(value):
    """``value`` with tuples as lists, numpy scalars and arrays as Python values and
    dataclasses (a :class:`~pv_hdrvol.Light`) as dicts of their fields (JSON)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.ndarray, np.generic)):
        return value.tolist()
    return value


def _as_tuple(value):
    """JSON lists back to tuples (the options' sequences are tuples)."""
    return tuple(_as_tuple(v) for v in value) if isinstance(value, list) else value


__all__ = ["RenderSettings", "SETTINGS_VERSION", "options_from_dict", "options_to_dict", "register_renderer",
           "settings_metadata"]
