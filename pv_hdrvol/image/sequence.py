"""HDR sequences: an EXR per frame, and a tone-mapped movie made from the same frames.

A movie tone-mapped frame by frame flickers: each frame's log-average, maximum or base
range moves the curve. :func:`tonemap_sequence` fits the operator once on all frames
together (``adapt="sequence"``, the default) and applies that one mapping to every
frame; ``adapt="frame"`` fits each frame on its own when that is wanted.
"""
from __future__ import annotations

import math
import os
import pathlib

import numpy as np

from .display import LUMINANCE_WEIGHTS

_ADAPT = ("sequence", "frame")


def orbit(camera, n_frames, *, degrees=360.0):
    """Cameras turned about the focal point around the camera's view-up axis.

    Parameters
    ----------
    camera : Camera
        The first frame.
    n_frames : int
        Number of cameras (>= 1).
    degrees : float
        Total turn; frame ``i`` is at ``i * degrees / n_frames`` (so a full turn
        does not repeat the first frame).

    Returns
    -------
    list of Camera

    Examples
    --------
    >>> from pv_hdrvol import Camera
    >>> cams = orbit(Camera((0, 0, 5), (0, 0, 0), (0, 1, 0)), 4)
    >>> [tuple(round(v, 12) + 0.0 for v in c.position) for c in cams][:2]
    [(0.0, 0.0, 5.0), (5.0, 0.0, 0.0)]
    """
    import dataclasses

    if not isinstance(n_frames, (int, np.integer)) or n_frames < 1:
        raise ValueError(f"n_frames must be an integer >= 1; got {n_frames!r}")
    _, up, _ = camera.basis()
    fp = np.asarray(camera.focal_point)
    offset = np.asarray(camera.position) - fp
    out = []
    for i in range(int(n_frames)):
        a = math.radians(degrees * i / n_frames)
        # Rodrigues rotation of the offset about the up axis
        rotated = (offset * math.cos(a) + np.cross(up, offset) * math.sin(a)
                   + up * np.dot(up, offset) * (1 - math.cos(a)))
        out.append(dataclasses.replace(camera, position=tuple(fp + rotated), view_up=tuple(up)))
    return out


def write_sequence(frames, directory, *, pattern="frame_{:04d}.exr", metadata=None, pixel_type="float32",
                   progress_bar=False):
    """Write one HDR file per frame (EXR by default), with metadata.

    Parameters
    ----------
    frames : iterable of HDRImage
        Rendered lazily if a generator (e.g. one render per camera of :func:`orbit`).
    directory : str or PathLike
        Created if missing. Existing files are not overwritten: a name that exists
        raises ``FileExistsError`` before anything is written to it.
    pattern : str
        File name with one ``{}`` field for the frame index; its suffix picks the
        format (``.exr``, ``.hdr``, ``.npy``).
    metadata : dict, optional
        Added to every frame's metadata, with ``frame`` (index) and ``sequence_length``
        when ``frames`` has a length.
    progress_bar : bool
        Show a tqdm bar.

    Returns
    -------
    list of pathlib.Path
    """
    directory = pathlib.Path(directory)
    if "{" not in pattern:
        raise ValueError(f"pattern must contain a {{}} field for the frame index; got {pattern!r}")
    directory.mkdir(parents=True, exist_ok=True)
    total = len(frames) if hasattr(frames, "__len__") else None
    bar = None
    if progress_bar:
        from tqdm.auto import tqdm

        bar = tqdm(total=total, desc="Writing frames", unit="frame")
    paths = []
    try:
        for i, frame in enumerate(frames):
            path = directory / pattern.format(i)
            if path.exists():
                raise FileExistsError(f"{path} exists; write the sequence to a new directory or pattern")
            extra = dict(metadata or {})
            extra["frame"] = i
            if total is not None:
                extra["sequence_length"] = total
            # a new HDRImage over the same arrays: the caller's frame keeps its metadata
            out = type(frame)(frame.rgba, frame.depth, {**frame.metadata, **extra})
            out.save(path, pixel_type=pixel_type) if path.suffix == ".exr" else out.save(path)
            paths.append(path)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
    return paths


def _frames(frames):
    from .hdr import HDRImage, load

    out = []
    for f in frames:
        if isinstance(f, (str, os.PathLike)):
            f = load(f)
        if not isinstance(f, HDRImage):
            raise TypeError(f"frames must be HDRImages or paths to HDR files; got {type(f).__name__}")
        out.append(f)
    if not out:
        raise ValueError("frames is empty")
    return out


def tonemap_sequence(frames, operator="reinhard", *, adapt="sequence", roi=None, encoding=None, **params):
    """Tone map frames with one mapping (``adapt="sequence"``) or one per frame.

    With ``"sequence"``, the operator is fitted once on all frames stacked together
    (for local operators their global anchors: base range, output reference), so a
    pixel value maps to the same display value in every frame of a global operator.
    ``encoding``: as :func:`~pv_hdrvol.tonemap` (None: the operator's own).

    Returns
    -------
    list of ToneMapped
    """
    from .tonemap import make_operator, tonemap, _roi_weights

    if adapt not in _ADAPT:
        raise ValueError(f"adapt must be one of {_ADAPT}; got {adapt!r}")
    frames = _frames(frames)
    shapes = {f.shape for f in frames}
    if len(shapes) != 1:
        raise ValueError(f"frames must all have one shape; got {sorted(shapes)}")
    if adapt == "frame":
        return [tonemap(f, operator, roi=roi, encoding=encoding, **params) for f in frames]
    op = make_operator(operator, **params)
    stacked = np.concatenate([f.rgba[..., :3].astype(np.float64) for f in frames], axis=0)
    weights = _roi_weights(roi, frames[0].shape)
    if weights is not None:
        weights = np.concatenate([weights] * len(frames), axis=0)
    fitted = op.fit(stacked @ LUMINANCE_WEIGHTS, weights)
    if not fitted.is_global:
        fitted.weights = None if roi is None else _roi_weights(roi, frames[0].shape)
        fitted._layers = None
    return [tonemap(f, op, encoding=encoding, fitted=fitted) for f in frames]


def write_movie(frames, path, operator="reinhard", *, fps=24, adapt="sequence", roi=None, **params):
    """A tone-mapped movie (``.mp4`` or ``.gif``) from HDR frames or their files.

    Parameters
    ----------
    frames : sequence of HDRImage or of paths (e.g. :func:`write_sequence`'s)
    path : str or PathLike
        ``.gif`` needs Pillow; ``.mp4`` needs ``imageio`` and ``imageio-ffmpeg``
        (``pip install pv_hdrvol[movie]``).
    operator, adapt, roi, **params
        As :func:`tonemap_sequence` (one mapping for all frames by default).
    fps : float
        Frames per second.

    Returns
    -------
    pathlib.Path
    """
    path = pathlib.Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise ValueError(f"movie path must end in .gif or .mp4; got {path.name!r}")
    if not fps > 0:
        raise ValueError(f"fps must be > 0; got {fps!r}")
    mapped = [t.rgb8 for t in tonemap_sequence(frames, operator, adapt=adapt, roi=roi, **params)]
    if suffix == ".gif":
        from PIL import Image

        images = [Image.fromarray(m) for m in mapped]
        images[0].save(path, save_all=True, append_images=images[1:], duration=int(round(1000 / fps)), loop=0)
    else:
        try:
            import imageio.v2 as imageio
        except ImportError:
            raise ImportError("writing .mp4 needs imageio and imageio-ffmpeg: pip install 'pv_hdrvol[movie]'") from None
        h, w = mapped[0].shape[:2]
        # H.264 in yuv420p needs even sizes: pad by one black row / column if odd
        pad = ((0, h % 2), (0, w % 2), (0, 0))
        with imageio.get_writer(path, fps=fps, codec="libx264", quality=8, macro_block_size=1) as writer:
            for m in mapped:
                writer.append_data(np.pad(m, pad))
    return path
