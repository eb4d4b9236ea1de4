"""numba kernels of the out-of-core renderer: arrays in, arrays out (``render.py``
validates and allocates)."""
from __future__ import annotations

import math

from .._jit import kernel


@kernel
def _footprint(ax, ay, az, bx, by, bz, t0, t1):
    """The smallest ``|a + t b|`` for ``t`` in ``[t0, t1]`` (the distance at ``t`` between
    two rays ``o + t d`` whose origins differ by ``a`` and directions by ``b``)."""
    bb = bx * bx + by * by + bz * bz
    t = t0
    if bb > 0.0:
        t = min(max(-(ax * bx + ay * by + az * bz) / bb, t0), t1)
    x = ax + t * bx
    y = ay + t * by
    z = az + t * bz
    return math.sqrt(x * x + y * y + z * z)


@kernel
def ray_block_levels(origins, directions, width, height, origin, inv_spacing, dims, block, shape, voxel, screen_error,
                     n_levels, out):
    """Per block of ``block`` cells (``out``: int64, (bz, by, bx), filled with
    ``n_levels`` before), the finest level any ray that crosses it asks for: at each
    block a ray crosses (an exact walk of the block grid), the smallest distance to the
    rays of the neighbouring pixels (left, right, up, down) over the ray's stretch in
    the block is its footprint ``p`` (world units), and the level is the coarsest whose
    voxels (``voxel * 2**L``) are at most ``screen_error * p``. A block no ray crosses
    keeps ``n_levels``.

    ``origins``, ``directions``: world rays, one row per pixel (row-major, ``width`` by
    ``height``); ``origin``, ``inv_spacing``, ``dims``: the volume's level-0 grid (x, y, z).
    """
    bz_n, by_n, bx_n = shape[0], shape[1], shape[2]
    for row in range(height):
        for col in range(width):
            r = row * width + col
            # the ray in voxel coordinates (t in world units)
            ox = (origins[r, 0] - origin[0]) * inv_spacing[0]
            oy = (origins[r, 1] - origin[1]) * inv_spacing[1]
            oz = (origins[r, 2] - origin[2]) * inv_spacing[2]
            dx = directions[r, 0] * inv_spacing[0]
            dy = directions[r, 1] * inv_spacing[1]
            dz = directions[r, 2] * inv_spacing[2]
            t0 = 0.0
            t1 = math.inf
            for o, d, n in ((ox, dx, dims[0]), (oy, dy, dims[1]), (oz, dz, dims[2])):
                if d == 0.0:
                    if o < 0.0 or o > n - 1.0:
                        t1 = -1.0
                else:
                    a = (0.0 - o) / d
                    b = (n - 1.0 - o) / d
                    t0 = max(t0, min(a, b))
                    t1 = min(t1, max(a, b))
            if not t1 > t0:
                continue
            ts = t0 + 1e-9 * (t1 - t0)  # just inside: the block the ray enters, not the one it grazes
            ib = min(max(int((ox + ts * dx) // block), 0), bx_n - 1)
            jb = min(max(int((oy + ts * dy) // block), 0), by_n - 1)
            kb = min(max(int((oz + ts * dz) // block), 0), bz_n - 1)
            si = 1 if dx > 0.0 else -1
            sj = 1 if dy > 0.0 else -1
            sk = 1 if dz > 0.0 else -1
            tx = ((ib + (1 if dx > 0.0 else 0)) * block - ox) / dx if dx != 0.0 else math.inf
            ty = ((jb + (1 if dy > 0.0 else 0)) * block - oy) / dy if dy != 0.0 else math.inf
            tz = ((kb + (1 if dz > 0.0 else 0)) * block - oz) / dz if dz != 0.0 else math.inf
            ex = block / abs(dx) if dx != 0.0 else math.inf
            ey = block / abs(dy) if dy != 0.0 else math.inf
            ez = block / abs(dz) if dz != 0.0 else math.inf
            t = t0
            while t < t1:
                tn = min(min(tx, ty), min(tz, t1))
                p = math.inf
                for nc, nr in ((col - 1, row), (col + 1, row), (col, row - 1), (col, row + 1)):
                    if 0 <= nc < width and 0 <= nr < height:
                        q = nr * width + nc
                        p = min(p, _footprint(origins[q, 0] - origins[r, 0], origins[q, 1] - origins[r, 1],
                                              origins[q, 2] - origins[r, 2], directions[q, 0] - directions[r, 0],
                                              directions[q, 1] - directions[r, 1],
                                              directions[q, 2] - directions[r, 2], t, tn))
                level = 0
                if p < math.inf and screen_error * p > voxel:
                    level = min(int(math.floor(math.log2(screen_error * p / voxel))), n_levels - 1)
                if level < out[kb, jb, ib]:
                    out[kb, jb, ib] = level
                if tn >= t1:
                    break
                if tx <= ty and tx <= tz:
                    ib += si
                    tx += ex
                    if ib < 0 or ib >= bx_n:
                        break
                elif ty <= tz:
                    jb += sj
                    ty += ey
                    if jb < 0 or jb >= by_n:
                        break
                else:
                    kb += sk
                    tz += ez
                    if kb < 0 or kb >= bz_n:
                        break
                t = tn
