"""Kernels of plenoptic opacity functions: per-block minimum optical depth over the
block's screen footprint for many orthographic views, and the front-to-back culling
pass over an opacity buffer. Arrays in, arrays out; validation is in ``pof.py``."""
import math

import numba
import numpy as np

from .._jit import fused_parallel_kernel, inline_kernel, kernel, parallel_kernel
from ..raycast._kernels import _ray_box, pixel_ray_span, segment_count
from ..raycast._kernels_ext import _position  # (v, scale code, axis low, 1 / axis range, linthresh)


@kernel
def _trilinear(values, x, y, z):
    """Trilinear value of ``values`` (z, y, x) at point coordinates ``(x, y, z)``."""
    nz, ny, nx = values.shape
    x = min(max(x, 0.0), nx - 1.0)
    y = min(max(y, 0.0), ny - 1.0)
    z = min(max(z, 0.0), nz - 1.0)
    xi = min(int(x), nx - 2)
    yi = min(int(y), ny - 2)
    zi = min(int(z), nz - 2)
    fx = x - xi
    fy = y - yi
    fz = z - zi
    c00 = values[zi, yi, xi] + fx * (values[zi, yi, xi + 1] - values[zi, yi, xi])
    c10 = values[zi, yi + 1, xi] + fx * (values[zi, yi + 1, xi + 1] - values[zi, yi + 1, xi])
    c01 = values[zi + 1, yi, xi] + fx * (values[zi + 1, yi, xi + 1] - values[zi + 1, yi, xi])
    c11 = values[zi + 1, yi + 1, xi] + fx * (values[zi + 1, yi + 1, xi + 1] - values[zi + 1, yi + 1, xi])
    c0 = c00 + fy * (c10 - c00)
    c1 = c01 + fy * (c11 - c01)
    return c0 + fz * (c1 - c0)


@kernel
def _project_box(lo, hi, px, py, pz, rx, ry, rz, ux, uy, uz):
    """``(u0, u1, w0, w1)``: the extent along ``right`` and ``up`` of the box ``[lo, hi]``
    seen from ``p`` (orthographic)."""
    u0 = math.inf
    u1 = -math.inf
    w0 = math.inf
    w1 = -math.inf
    for c in range(8):
        qx = (hi[0] if c & 1 else lo[0]) - px
        qy = (hi[1] if c & 2 else lo[1]) - py
        qz = (hi[2] if c & 4 else lo[2]) - pz
        pu = qx * rx + qy * ry + qz * rz
        pw = qx * ux + qy * uy + qz * uz
        u0 = min(u0, pu)
        u1 = max(u1, pu)
        w0 = min(w0, pw)
        w1 = max(w1, pw)
    return u0, u1, w0, w1


@kernel
def _chord(ox, oy, oz, dx, dy, dz, lo, hi):
    """``(t0, t1)`` of the line ``o + t d`` through the box ``[lo, hi]`` (``t1 <= t0``: missed)."""
    t0 = -math.inf
    t1 = math.inf
    for axis in range(3):
        o = ox if axis == 0 else (oy if axis == 1 else oz)
        d = dx if axis == 0 else (dy if axis == 1 else dz)
        if d != 0.0:
            ta = (lo[axis] - o) / d
            tb = (hi[axis] - o) / d
            if ta > tb:
                ta, tb = tb, ta
            t0 = max(t0, ta)
            t1 = min(t1, tb)
        elif o < lo[axis] or o > hi[axis]:
            return 1.0, 0.0
    return t0, t1


@kernel
def block_min_depth(values, spacing, sigma, scale, linthresh, axis_lo, axis_inv, lo_index, hi_index, frames, pitch,
                    step, chord_min, skip_empty_pixels, out, sets):
    """Smallest optical depth of one block over its footprint, for every view and basis.

    ``values`` (z, y, x) the whole volume (so samples near the block's faces read their
    neighbours); ``spacing`` (3,); ``sigma`` (p, n) extinction per world unit of each
    basis at ``n`` equidistant entries of the axis; ``lo_index``/``hi_index`` the block's
    point-index box (x, y, z); ``frames`` (V, 9): view direction, right, up per view.
    Pixels are the centres ``((i + 1/2) pitch, (j + 1/2) pitch)`` of a lattice in the
    view plane through the world origin; a pixel belongs to the footprint when its ray's
    chord through the block is at least ``chord_min`` (> 0). Samples at the midpoints
    of segments of length ``step`` from the block's entry, the last one shorter, as the
    ray caster marches. NaN samples are empty. ``skip_empty_pixels``: a basis's minimum
    ignores pixels where it is 0 (the paper's "non-empty pixels" reading: not
    conservative). ``out`` (V, p) receives the minimum optical depth (``inf`` when no
    pixel qualifies); ``sets`` (V, p, p) the paper's POF sets: ``sets[v, i, j]`` is basis
    ``j``'s optical depth at the pixel where basis ``i`` has its minimum (the first such
    pixel; ``inf`` when none). A pixel that stops early cannot lower any minimum, so the
    pixels recorded there were marched to the end for every basis.
    """
    n_views = frames.shape[0]
    p = sigma.shape[0]
    n = sigma.shape[1]
    lo = np.empty(3)
    hi = np.empty(3)
    for a in range(3):
        lo[a] = lo_index[a] * spacing[a]
        hi[a] = hi_index[a] * spacing[a]
    cx = 0.5 * (lo[0] + hi[0])
    cy = 0.5 * (lo[1] + hi[1])
    cz = 0.5 * (lo[2] + hi[2])
    radius = 0.5 * math.sqrt((hi[0] - lo[0]) ** 2 + (hi[1] - lo[1]) ** 2 + (hi[2] - lo[2]) ** 2) + 1.0
    depth = np.empty(p)
    inv_x, inv_y, inv_z = 1.0 / spacing[0], 1.0 / spacing[1], 1.0 / spacing[2]
    for v in range(n_views):
        dx, dy, dz = frames[v, 0], frames[v, 1], frames[v, 2]
        rx, ry, rz = frames[v, 3], frames[v, 4], frames[v, 5]
        ux, uy, uz = frames[v, 6], frames[v, 7], frames[v, 8]
        u0, u1, w0, w1 = _project_box(lo, hi, 0.0, 0.0, 0.0, rx, ry, rz, ux, uy, uz)
        back = cx * dx + cy * dy + cz * dz - radius
        ex, ey, ez = dx * inv_x, dy * inv_y, dz * inv_z
        for q in range(p):
            out[v, q] = math.inf
            for r in range(p):
                sets[v, q, r] = math.inf
        for j in range(int(math.ceil(w0 / pitch - 0.5)), int(math.floor(w1 / pitch - 0.5)) + 1):
            wc = (j + 0.5) * pitch
            for i in range(int(math.ceil(u0 / pitch - 0.5)), int(math.floor(u1 / pitch - 0.5)) + 1):
                uc = (i + 0.5) * pitch
                ox = uc * rx + wc * ux + back * dx
                oy = uc * ry + wc * uy + back * dy
                oz = uc * rz + wc * uz + back * dz
                t0, t1 = _chord(ox, oy, oz, dx, dy, dz, lo, hi)
                if t1 - t0 < chord_min:
                    continue
                for q in range(p):
                    depth[q] = 0.0
                # in point coordinates: o' = o / spacing, d' = d / spacing (t stays in world units)
                vx, vy, vz = ox * inv_x, oy * inv_y, oz * inv_z
                n_seg = max(1, int(math.ceil((t1 - t0) / step)))
                for k in range(n_seg):
                    ta = t0 + k * step
                    length = step if k < n_seg - 1 else t1 - ta
                    tm = ta + 0.5 * length
                    s = _trilinear(values, vx + tm * ex, vy + tm * ey, vz + tm * ez)
                    if s != s:
                        continue
                    x = _position(s, scale, axis_lo, axis_inv, linthresh) * (n - 1)
                    e = min(int(x), n - 2)
                    f = x - e
                    above = True
                    for q in range(p):
                        depth[q] += (sigma[q, e] + f * (sigma[q, e + 1] - sigma[q, e])) * length
                        if depth[q] < out[v, q]:
                            above = False
                    if above:  # depth only grows along the ray: this pixel cannot lower a minimum
                        break
                for q in range(p):
                    if depth[q] < out[v, q] and not (skip_empty_pixels and depth[q] == 0.0):
                        out[v, q] = depth[q]
                        for r in range(p):
                            sets[v, q, r] = depth[r]


@kernel
def cull_blocks(order, lo_world, hi_world, alpha, camera, width, height, window, threshold, chord_min, halo,
                opacity, visible):
    """Front-to-back visibility over an opacity buffer (Gao et al. 2003, section 3.3).

    ``order`` the candidate blocks front to back; ``lo_world``/``hi_world`` (B, 3) their
    boxes; ``alpha`` (B,) their conservative opacity for this view; ``camera`` the
    orthographic frame (position, right, up, forward, half width, half height);
    ``window`` (col0, row0, col1, row1), inclusive: the pixels considered (a tile);
    ``opacity`` (height, width) the buffer, updated in place; ``visible`` (B,) set to 1
    for the blocks kept. A block is culled when every pixel it may touch (centre ray
    through the box grown by ``halo``) has opacity >= ``threshold``; a kept block
    composites ``alpha`` into the pixels whose centre ray crosses it over at least
    ``chord_min``.
    """
    px, py, pz = camera[0], camera[1], camera[2]
    rx, ry, rz = camera[3], camera[4], camera[5]
    ux, uy, uz = camera[6], camera[7], camera[8]
    dx, dy, dz = camera[9], camera[10], camera[11]
    half_w, half_h = camera[12], camera[13]
    pitch_x = 2.0 * half_w / width
    pitch_y = 2.0 * half_h / height
    lo = np.empty(3)
    hi = np.empty(3)
    glo = np.empty(3)
    ghi = np.empty(3)
    for b in order:
        for a in range(3):
            lo[a] = lo_world[b, a]
            hi[a] = hi_world[b, a]
            glo[a] = lo[a] - halo
            ghi[a] = hi[a] + halo
        u0, u1, w0, w1 = _project_box(glo, ghi, px, py, pz, rx, ry, rz, ux, uy, uz)
        # columns: x = (col + 1/2) pitch_x - half_w; rows: y = half_h - (row + 1/2) pitch_y
        c0 = max(window[0], int(math.ceil((u0 + half_w) / pitch_x - 0.5)))
        c1 = min(window[2], int(math.floor((u1 + half_w) / pitch_x - 0.5)))
        r0 = max(window[1], int(math.ceil((half_h - w1) / pitch_y - 0.5)))
        r1 = min(window[3], int(math.floor((half_h - w0) / pitch_y - 0.5)))
        if c0 > c1 or r0 > r1:
            continue
        hidden = True
        for row in range(r0, r1 + 1):
            for col in range(c0, c1 + 1):
                if opacity[row, col] >= threshold:
                    continue
                x = (col + 0.5) * pitch_x - half_w
                y = half_h - (row + 0.5) * pitch_y
                t0, t1 = _chord(px + x * rx + y * ux, py + x * ry + y * uy, pz + x * rz + y * uz, dx, dy, dz,
                                glo, ghi)
                if t1 > t0:
                    hidden = False
                    break
            if not hidden:
                break
        if hidden:
            continue
        visible[b] = 1
        keep = 1.0 - alpha[b]
        for row in range(r0, r1 + 1):
            for col in range(c0, c1 + 1):
                x = (col + 0.5) * pitch_x - half_w
                y = half_h - (row + 0.5) * pitch_y
                t0, t1 = _chord(px + x * rx + y * ux, py + x * ry + y * uy, pz + x * rz + y * uz, dx, dy, dz,
                                lo, hi)
                if t1 - t0 >= chord_min:
                    opacity[row, col] = 1.0 - (1.0 - opacity[row, col]) * keep


# -- the view-independent occlusion bound (bound.py) ----------------------------------------
@parallel_kernel
def span_minimum(sigma, sparse, chunk, i0, i1, out):
    """``out[q] = min(sigma[i0[q]:i1[q] + 1])`` for every query ``q`` (flat arrays).

    ``sparse[l, c]`` is the minimum of the ``2**l`` chunks of ``chunk`` entries from
    chunk ``c`` (a sparse table over the chunk minima): a query costs at most
    ``2 chunk`` reads plus two table reads, whatever its length."""
    for q in numba.prange(i0.shape[0]):
        a = i0[q]
        b = i1[q]
        m = math.inf
        if b - a < 2 * chunk:
            for i in range(a, b + 1):
                m = min(m, sigma[i])
        else:
            ca = (a + chunk - 1) // chunk  # first whole chunk
            cb = (b + 1) // chunk - 1  # last whole chunk
            for i in range(a, ca * chunk):
                m = min(m, sigma[i])
            for i in range((cb + 1) * chunk, b + 1):
                m = min(m, sigma[i])
            n = cb - ca + 1
            level = 0
            while (2 << level) <= n:
                level += 1
            m = min(m, min(sparse[level, ca], sparse[level, cb - (1 << level) + 1]))
        out[q] = m


@inline_kernel
def _cell_span(x, lo, hi, width, n, eps):
    """First and last index of the cells of ``width`` (``n`` of them, from ``lo``) that a
    point within ``eps`` of ``x`` (clamped to ``[lo, hi]``) may fall in, as the ray
    caster's ``int`` of the clamped position does up to rounding."""
    x = min(max(x, lo), hi)
    a = int(math.floor((max(x - eps, lo) - lo) / width))
    b = int(math.floor((min(x + eps, hi) - lo) / width))
    return min(max(a, 0), n - 1), min(max(b, 0), n - 1)


@inline_kernel
def _block_exit(x, o, d, lo, width, n):
    """Ray parameter at which ``o + t d`` leaves the block of ``width`` holding ``x``
    along one axis (``inf`` for a ray parallel to it)."""
    if d == 0.0:
        return math.inf
    b = min(max(int(math.floor((x - lo) / width)), 0), n - 1)
    if d > 0.0:
        return (lo + (b + 1) * width - o) / d
    return (lo + b * width - o) / d


@fused_parallel_kernel
def march_bound(extinction, empty, cam, origins, directions, width, height, lo, hi, group_width, block_width, step,
                target, slack, cap, lanes, needed, met):
    """March every pixel ray through the groups at the ray caster's sample positions.

    ``extinction`` (gz, gy, gx) float32: a lower bound on the extinction (per world unit)
    of every sample whose cell lies in the group. Rays come from ``cam``
    (``Camera.kernel_array``, then the lattice origin and 1 / lattice spacing, as
    ``raycast._kernels.voxel_ray``) or, when ``cam`` is empty, from ``origins`` and
    ``directions`` (one row per pixel, lattice coordinates, ``t`` in world units).

    Each ray samples the box ``[lo, hi]`` (lattice coordinates) as the ray caster does:
    from its entry ``t0``, segments of ``step`` with a sample at each midpoint, the last
    one shorter, ending at the exit. A group spans ``group_width`` lattice units from
    ``lo``, a block ``block_width``. Sample ``k`` adds ``min(extinction * length, cap)``
    to the ray's bound ``D`` after it is taken; while ``D < target + (k + 32) slack``
    the sample's block is marked ``needed[lane]``, and every sample's block ``met[lane]``
    (lane ``l`` takes rows ``l, l + lanes, ...``: no two threads write one array). A
    sample within 1e-7 lattice units of a face counts in both cells: the ray caster
    rounds its positions in its own order.

    ``empty`` (bz, by, bx) uint8: blocks where no value of any group can have
    extinction (the ray caster skips them): neither met nor needed, and leapt over to
    the first sample past them, as a ray is once occluded.
    """
    gz, gy, gx = extinction.shape
    bz, by, bx = needed.shape[1], needed.shape[2], needed.shape[3]
    no_span = np.empty((0, 2))
    eps = 1e-7
    for lane in numba.prange(lanes):
        for row in range(lane, height, lanes):
            for col in range(width):
                pix = row * width + col
                ox, oy, oz, dx, dy, dz, _, _ = pixel_ray_span(cam, origins, directions, no_span, pix, width, height)
                t0, t1 = _ray_box(ox, oy, oz, dx, dy, dz, lo, hi, 0.0, math.inf)
                if not t1 > t0:
                    continue
                n_seg = segment_count(t0, t1, step)
                n_full = n_seg - 1
                depth = 0.0
                occluded = False
                k = 0
                while k < n_seg:
                    if k < n_full:
                        tm = t0 + (k + 0.5) * step
                        length = step
                    else:
                        ta = t0 + n_full * step
                        tm = 0.5 * (ta + t1)
                        length = t1 - ta
                    x = ox + tm * dx
                    y = oy + tm * dy
                    z = oz + tm * dz
                    if not occluded and depth >= target + (k + 32) * slack:
                        occluded = True  # the ray caster has stopped: no later sample is taken either
                    ia, ib = _cell_span(x, lo[0], hi[0], block_width, bx, eps)
                    ja, jb = _cell_span(y, lo[1], hi[1], block_width, by, eps)
                    ka, kb = _cell_span(z, lo[2], hi[2], block_width, bz, eps)
                    all_empty = True
                    for kk in range(ka, kb + 1):
                        for jj in range(ja, jb + 1):
                            for ii in range(ia, ib + 1):
                                if empty[kk, jj, ii] == 0:
                                    all_empty = False
                                    met[lane, kk, jj, ii] = 1
                                    if not occluded:
                                        needed[lane, kk, jj, ii] = 1
                    if occluded or all_empty:
                        # nothing adds to the bound here (occluded: nothing counts any more; an empty block:
                        # no extinction): on to the first sample past this block, or one just before its exit
                        # (which the ray caster may round into the next block)
                        te = min(_block_exit(x, ox, dx, lo[0], block_width, bx),
                                 min(_block_exit(y, oy, dy, lo[1], block_width, by),
                                     _block_exit(z, oz, dz, lo[2], block_width, bz)))
                        if k >= n_full or not te < t1:
                            break
                        kn = int(math.ceil((te - t0) / step - 0.5 - 1e-6))
                        k = min(max(kn, k + 1), n_full)
                        continue
                    k += 1
                    ia, ib = _cell_span(x, lo[0], hi[0], group_width, gx, eps)
                    ja, jb = _cell_span(y, lo[1], hi[1], group_width, gy, eps)
                    ka, kb = _cell_span(z, lo[2], hi[2], group_width, gz, eps)
                    s = math.inf
                    for kk in range(ka, kb + 1):
                        for jj in range(ja, jb + 1):
                            for ii in range(ia, ib + 1):
                                s = min(s, np.float64(extinction[kk, jj, ii]))
                    depth += min(s * length, cap)
