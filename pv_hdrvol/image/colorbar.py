"""A picture with the colour bar of its transfer function beside it, for figures.

Needs matplotlib, imported only when a figure is made (``matplotlib.figure.Figure``,
not pyplot: no global state, no display needed).
"""
from __future__ import annotations

import numpy as np

from ..data.transfer import scale_inverse, scale_forward

#: Entries of the colour bar's colormap, sampled evenly along the transfer function's axis.
COLORBAR_ENTRIES = 256


def colorbar_figure(picture, tf, *, label=None, dpi=100):
    """A matplotlib figure: ``picture`` at its own pixel size, a colour bar of ``tf`` to its right.

    Parameters
    ----------
    picture : ndarray, shape (rows, cols, 3), uint8
        The displayed image, row 0 at the top (``HDRImage.to_display()``,
        ``ToneMapped.rgb8``). It is placed pixel for pixel, not resampled.
    tf : TransferFunction
        The bar shows its colours from ``tf.vmin`` to ``tf.vmax``, with tick labels in
        data units on the transfer function's axis: powers of ten for ``scale="log"``,
        symmetric-log ticks for ``"symlog"``. Colours above 1 (HDR emission) are
        scaled down by the largest component so the bar keeps their hue.
    label : str, optional
        Title of the bar (e.g. the scalar's name and unit).
    dpi : float
        Dots per inch of the figure; the picture keeps its pixels at any value.

    Returns
    -------
    matplotlib.figure.Figure
        On an Agg canvas; the bar is ``figure.axes[0]`` (data coordinates: values);
        save with ``figure.savefig(path, dpi=dpi)``.

    Examples
    --------
    >>> import numpy as np, pv_hdrvol as hv
    >>> tf = hv.TransferFunction.ramp(1e-6, 1.0, scale="log", cmap="gray")
    >>> fig = colorbar_figure(np.zeros((64, 48, 3), np.uint8), tf)
    >>> fig.axes[0].get_yscale()
    'log'
    """
    from matplotlib import colors as mcolors
    from matplotlib import ticker
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.cm import ScalarMappable
    from matplotlib.figure import Figure

    picture = np.asarray(picture)
    if picture.ndim != 3 or picture.shape[2] not in (3, 4) or picture.dtype != np.uint8:
        raise ValueError(f"picture must be a uint8 array of shape (rows, cols, 3); got {picture.dtype} "
                         f"{picture.shape}")
    rows, cols = picture.shape[:2]
    k = max(1.0, rows / 400.0)  # text and bar grow with large pictures
    bar_px = int(round(110 * k)) + (int(round(16 * k)) if label else 0)
    fig_rows = max(rows, int(round(220 * k)))
    fig = Figure(figsize=((cols + bar_px) / dpi, fig_rows / dpi), dpi=dpi, facecolor="white")
    FigureCanvasAgg(fig)  # drawn off screen (canvas.buffer_rgba()), whatever pyplot's backend
    bottom = (fig_rows - rows) // 2
    fig.figimage(picture, xo=0, yo=bottom, origin="upper")
    margin = int(round(12 * k))
    cax = fig.add_axes([(cols + margin) / (cols + bar_px), margin / fig_rows,
                        14 * k / (cols + bar_px), 1.0 - 2.0 * margin / fig_rows])

    a0, a1 = tf.axis_range
    values = scale_inverse(np.linspace(a0, a1, COLORBAR_ENTRIES), tf.scale, tf.linthresh)
    values[0], values[-1] = tf.vmin, tf.vmax
    rgb = np.clip(tf.color_at(values), 0.0, None)
    top = rgb.max()
    if top > 1.0:
        rgb = rgb / top
    cmap = mcolors.ListedColormap(rgb)
    if tf.scale == "log":
        norm = mcolors.LogNorm(tf.vmin, tf.vmax)
    elif tf.scale == "symlog":
        # the transfer function's own axis (sign(v) log10(1 + |v| / linthresh)), so each
        # colour sits at its value; matplotlib's SymLogNorm is a different curve
        def forward(v):
            return scale_forward(v, "symlog", tf.linthresh)

        def inverse(a):
            return scale_inverse(a, "symlog", tf.linthresh)

        norm = mcolors.FuncNorm((forward, inverse), tf.vmin, tf.vmax)
    else:
        norm = mcolors.Normalize(tf.vmin, tf.vmax)
    bar = fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), cax=cax)
    if tf.scale == "symlog":
        bar.ax.yaxis.set_major_locator(ticker.SymmetricalLogLocator(base=10, linthresh=tf.linthresh))
        bar.ax.yaxis.set_major_formatter(ticker.LogFormatterSciNotation(base=10, linthresh=tf.linthresh))
        bar.ax.yaxis.set_minor_locator(ticker.NullLocator())
    fontsize = 9 * k
    bar.ax.tick_params(labelsize=fontsize)
    if label:
        bar.set_label(label, fontsize=fontsize)
    return fig


def save_png_with_colorbar(path, picture, tf, *, label=None, dpi=100):
    """Write :func:`colorbar_figure` of ``picture`` and ``tf`` as a PNG at ``path``."""
    fig = colorbar_figure(picture, tf, label=label, dpi=dpi)
    fig.savefig(path, dpi=dpi, format="png", facecolor=fig.get_facecolor())
    return fig
