"""Sort-last compositing of premultiplied float partial images: pure functions of the
partial images and their visibility order, so any rank count gives the same bits."""
from __future__ import annotations

import math

from ..raycast.compositing import composite_over


def tile_grid(n, width, height):
    """``n`` tiles of a ``width x height`` image on a near-square ``a x b`` grid
    (``a * b = n``, ``a >= b``, the longer image side split ``a`` ways): a list of
    ``(col, row, w, h)``, rank order, row-major. A prime ``n`` gives strips."""
    b = max(d for d in range(1, int(math.isqrt(n)) + 1) if n % d == 0)
    a = n // b
    cols, rows = (a, b) if width >= height else (b, a)
    xs = [width * i // cols for i in range(cols + 1)]
    ys = [height * j // rows for j in range(rows + 1)]
    return [(xs[i], ys[j], xs[i + 1] - xs[i], ys[j + 1] - ys[j]) for j in range(rows) for i in range(cols)]


def clip(rect, tile):
    """The intersection of two ``(col, row, w, h)`` rectangles, or ``None``."""
    c0, r0 = max(rect[0], tile[0]), max(rect[1], tile[1])
    c1, r1 = min(rect[0] + rect[2], tile[0] + tile[2]), min(rect[1] + rect[3], tile[1] + tile[3])
    return (c0, r0, c1 - c0, r1 - r0) if c1 > c0 and r1 > r0 else None


def composite(tile, pieces, dtype):
    """Front-to-back "over" of ``pieces`` into the ``tile = (col, row, w, h)``.

    ``pieces``: ``(order, (col, row, w, h), rgba)`` with rgba (h, w, 4) premultiplied;
    composited by increasing ``order`` (ties keep their position in ``pieces``):
    ``C += (1 - A) c``, ``A += (1 - A) a`` per pixel, with
    :func:`~pv_hdrvol.raycast.compositing.composite_over` in ``dtype`` (the render's
    precision, as this tile compositor always has). Returns (h, w, 4) ``dtype``.
    """
    col, row, w, h = tile

    def layers():
        for _, rect, rgba in sorted(pieces, key=lambda p: p[0]):
            part = clip(rect, tile)
            if part is None:
                continue
            src = rgba[part[1] - rect[1]:part[1] - rect[1] + part[3], part[0] - rect[0]:part[0] - rect[0] + part[2]]
            yield (slice(part[1] - row, part[1] - row + part[3]), slice(part[0] - col, part[0] - col + part[2])), src

    return composite_over(layers(), (h, w), dtype, accumulate=dtype)
