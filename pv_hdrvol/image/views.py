"""Ways to look at all of an HDR image at once: an exposure bracket and pseudocolour.

HDR VolVis Fig. 4: a contact sheet of exposures (each a window onto a few stops of
the range) and log luminance in pseudocolour with a colour bar. Arrays come from
:func:`contact_sheet` and :func:`pseudocolor`; ``plot_*`` draw them with matplotlib.
"""
from __future__ import annotations

import numpy as np

from .display import auto_exposure, luminance


def _rgb(image):
    arr = getattr(image, "rgba", image)
    arr = np.asarray(arr)
    if arr.ndim != 3 or arr.shape[2] not in (3, 4):
        raise ValueError(f"image must be an HDRImage or an array of shape (rows, cols, 3 or 4); got {arr.shape}")
    return arr[..., :3].astype(np.float64)


def contact_sheet(image, stops=(-8, -6, -4, -2, 0, 2), *, columns=None, gap=4):
    """The image at several exposures, tiled left to right, top to bottom.

    Parameters
    ----------
    image : HDRImage or ndarray (rows, cols, 3 or 4)
    stops : sequence of float
        Exposures relative to the auto exposure (which maps the 99th percentile of
        luminance to 1).
    columns : int, optional
        Tiles per row (default: all in one row).
    gap : int
        Pixels of black between tiles.

    Returns
    -------
    sheet : ndarray (H, W, 3) uint8
    exposures : list of float
        The absolute exposure (stops) of each tile.

    Examples
    --------
    >>> import numpy as np
    >>> sheet, ev = contact_sheet(np.ones((4, 5, 3)), stops=[0, 1, 2], gap=1)
    >>> sheet.shape, ev
    ((4, 17, 3), [0.0, 1.0, 2.0])
    """
    from .tonemap import tonemap

    rgb = _rgb(image)
    stops = [float(s) for s in np.atleast_1d(stops)]
    if not stops:
        raise ValueError("stops must name at least one exposure")
    columns = len(stops) if columns is None else int(columns)
    if columns < 1:
        raise ValueError(f"columns must be >= 1; got {columns}")
    if gap < 0:
        raise ValueError(f"gap must be >= 0 pixels; got {gap}")
    base = auto_exposure(rgb)
    tiles = [tonemap(rgb, "linear", exposure_stops=base + s).rgb8 for s in stops]
    rows = -(-len(tiles) // columns)
    h, w = rgb.shape[:2]
    sheet = np.zeros((rows * h + (rows - 1) * gap, columns * w + (columns - 1) * gap, 3), np.uint8)
    for i, tile in enumerate(tiles):
        r, c = divmod(i, columns)
        sheet[r * (h + gap):r * (h + gap) + h, c * (w + gap):c * (w + gap) + w] = tile
    return sheet, [base + s for s in stops]


def pseudocolor(image, cmap="viridis", *, vmin=None, vmax=None):
    """Log10 luminance in a colour map.

    Parameters
    ----------
    image : HDRImage or ndarray (rows, cols, 3 or 4)
    cmap : str
        A matplotlib colour map name (needs matplotlib).
    vmin, vmax : float, optional
        Range of log10 luminance shown (default: the 1st percentile of non-zero
        luminance to the peak; a few faint edge pixels would otherwise squeeze the
        body of the image into one colour).

    Returns
    -------
    rgb : ndarray (rows, cols, 3) uint8
        Black where luminance is 0 or not finite.
    limits : (float, float)
        ``(vmin, vmax)`` in log10 luminance, for a colour bar.
    """
    from ..data.transfer import colormap_rgb

    y = luminance(_rgb(image))
    ok = np.isfinite(y) & (y > 0)
    logs = np.where(ok, np.log10(np.where(ok, y, 1.0)), np.nan)
    lo = float(np.percentile(logs[ok], 1.0)) if vmin is None and ok.any() else (0.0 if vmin is None else float(vmin))
    hi = float(np.nanmax(logs)) if vmax is None and ok.any() else (lo + 1.0 if vmax is None else float(vmax))
    if not hi > lo:
        hi = lo + 1.0
    lut = colormap_rgb(cmap, np.linspace(0.0, 1.0, 256))
    idx = np.clip(np.round((np.nan_to_num(logs, nan=lo) - lo) / (hi - lo) * 255), 0, 255).astype(int)
    out = np.round(lut[idx] * 255).astype(np.uint8)
    out[~ok] = 0
    return out, (lo, hi)


def plot_exposures(image, stops=(-8, -6, -4, -2, 0, 2), *, columns=None, ax=None):
    """Draw :func:`contact_sheet` with each tile's exposure; returns the matplotlib Figure."""
    import matplotlib.pyplot as plt

    rgb = _rgb(image)
    columns = len(np.atleast_1d(stops)) if columns is None else columns
    sheet, ev = contact_sheet(rgb, stops, columns=columns, gap=4)
    fig = ax.figure if ax is not None else plt.figure(figsize=(2.2 * columns, 2.4 * (-(-len(ev) // columns))))
    ax = ax if ax is not None else fig.add_subplot(1, 1, 1)
    ax.imshow(sheet)
    h, w = rgb.shape[:2]
    for i, e in enumerate(ev):
        r, c = divmod(i, columns)
        ax.text(c * (w + 4) + 4, r * (h + 4) + 4, f"{e:+.1f} EV", color="white", va="top", fontsize=8)
    ax.set_axis_off()
    return fig


def plot_pseudocolor(image, cmap="viridis", *, vmin=None, vmax=None, ax=None):
    """Draw :func:`pseudocolor` with a colour bar of log10 luminance; returns the Figure."""
    import matplotlib.pyplot as plt
    from matplotlib import cm, colors

    rgb, (lo, hi) = pseudocolor(image, cmap, vmin=vmin, vmax=vmax)
    fig = ax.figure if ax is not None else plt.figure(figsize=(5, 4))
    ax = ax if ax is not None else fig.add_subplot(1, 1, 1)
    ax.imshow(rgb)
    ax.set_axis_off()
    sm = cm.ScalarMappable(norm=colors.Normalize(lo, hi), cmap=cmap)
    fig.colorbar(sm, ax=ax, label="log10 luminance")
    return fig
