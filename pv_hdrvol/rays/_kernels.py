"""numba kernels of the lenses (``rays/lenses.py``) and of clipping (``rays/clip.py``):
arrays in, arrays filled.

Nothing here validates or allocates; ``lenses.py`` does that.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import inline_kernel, kernel, parallel_kernel

#: Length of ``Camera.kernel_array()``: what ``camera_ray`` reads.
CAMERA_FIELDS = 15


@kernel
def camera_ray(cam, col, row, width, height):
    """World ray ``(ox, oy, oz, dx, dy, dz)`` of pixel ``(col, row)``, bit for bit as
    ``Camera.rays`` computes it (the same operations in the same order).

    ``cam`` (float64, ``Camera.kernel_array``): position, right, up, forward, half width,
    half height of the view at unit distance (or of the parallel view), parallel (1.0) or
    not. Making rays here spares a render two arrays of ``6 * width * height`` floats."""
    x = ((col + 0.5) * (2.0 / width) - 1.0) * cam[12]
    y = (1.0 - (row + 0.5) * (2.0 / height)) * cam[13]
    gx = x * cam[3] + y * cam[6]
    gy = x * cam[4] + y * cam[7]
    gz = x * cam[5] + y * cam[8]
    if cam[14] != 0.0:
        return cam[0] + gx, cam[1] + gy, cam[2] + gz, cam[9], cam[10], cam[11]
    inv_len = 1.0 / math.sqrt(1.0 + x * x + y * y)
    return cam[0], cam[1], cam[2], (gx + cam[9]) * inv_len, (gy + cam[10]) * inv_len, (gz + cam[11]) * inv_len


@inline_kernel
def _sigma_max(a, b, c, d):
    """Largest singular value of [[a, b], [c, d]], without cancellation."""
    p = a * a + b * b
    q = c * c + d * d
    r = a * c + b * d
    return math.sqrt(0.5 * (p + q + math.sqrt((p - q) * (p - q) + 4.0 * r * r)))


@inline_kernel
def _band(dist, inner, width, inv_m):
    """Scale s and ds/d(dist) of the linear transition: 1/M up to ``inner``, 1 from
    ``inner + width`` (an empty band when width is 0)."""
    if dist <= inner:
        return inv_m, 0.0
    if dist < inner + width:
        return inv_m + (1.0 - inv_m) * (dist - inner) / width, (1.0 - inv_m) / width
    return 1.0, 0.0


@kernel
def _magnifier_scale(r0, c0, cx, cy, square, radius, transition, inv_m, s, sigma):
    """s over the window whose top-left pixel is (r0, c0); sigma (if not empty) = sigma_max
    of J = s I + s' v g^T, v = p - c, g = grad r (Euclidean or L-infinity)."""
    nr, nc = s.shape
    jacobian = sigma.shape[0] == nr
    inner = radius - transition
    for j in range(nr):
        dy = (r0 + j + 0.5) - cy
        for i in range(nc):
            dx = (c0 + i + 0.5) - cx
            gx = 0.0
            gy = 0.0
            if square:
                if abs(dx) >= abs(dy):
                    r = abs(dx)
                    gx = 1.0 if dx > 0 else -1.0
                else:
                    r = abs(dy)
                    gy = 1.0 if dy > 0 else -1.0
            else:
                r = math.sqrt(dx * dx + dy * dy)
                if r > 0:
                    gx = dx / r
                    gy = dy / r
            sv, ds = _band(r, inner, transition, inv_m)
            s[j, i] = sv
            if jacobian:
                sigma[j, i] = _sigma_max(sv + ds * dx * gx, ds * dx * gy, ds * dy * gx, sv + ds * dy * gy)


@kernel
def _mask_scale(sq_dist, width, inv_m, s):
    """s from squared distances to the shape: 1/M on it, the band outside."""
    nr, nc = s.shape
    for j in range(nr):
        for i in range(nc):
            s[j, i] = _band(math.sqrt(sq_dist[j, i]), 0.0, width, inv_m)[0]


@inline_kernel
def _source(sv, p, c):
    """One coordinate of q = c + s (p - c); exactly p where s = 1."""
    return p if sv == 1.0 else c + sv * (p - c)


@kernel
def _numeric_sigma(s, r0, c0, cx, cy, sigma):
    """sigma_max of dq/dp by central differences (one-sided at the window's edge, which
    is the image border or a margin where s = 1), as numpy.gradient."""
    nr, nc = s.shape
    for j in range(nr):
        y = r0 + j + 0.5
        ju = j - 1 if j > 0 else 0
        jd = j + 1 if j < nr - 1 else nr - 1
        for i in range(nc):
            x = c0 + i + 0.5
            il = i - 1 if i > 0 else 0
            ir = i + 1 if i < nc - 1 else nc - 1
            if ir > il:
                a = (_source(s[j, ir], x + (ir - i), cx) - _source(s[j, il], x + (il - i), cx)) / (ir - il)
                c = (_source(s[j, ir], y, cy) - _source(s[j, il], y, cy)) / (ir - il)
            else:  # a one-pixel-wide image: the homothety's own derivative
                a = s[j, i]
                c = 0.0
            if jd > ju:
                b = (_source(s[jd, i], x, cx) - _source(s[ju, i], x, cx)) / (jd - ju)
                d = (_source(s[jd, i], y + (jd - j), cy) - _source(s[ju, i], y + (ju - j), cy)) / (jd - ju)
            else:
                b = 0.0
                d = s[j, i]
            sigma[j, i] = _sigma_max(a, b, c, d)


@inline_kernel
def _invert_rate(u, f, cum, start):
    """Normalised source radius x with F(x) = u F(1), f piecewise linear on the table, and
    f there. In interval k, F = cum[k] + f[k] t + a t^2: solve for t exactly."""
    n = f.shape[0] - 1
    target = u * cum[n]
    m = int(u * n)
    if m > n - 1:
        m = n - 1
    # start[m] <= k <= start[m + 1] (one more either side for rounding): a short search
    lo = start[m] - 1 if start[m] > 0 else 0
    hi = start[m + 1] + 1 if start[m + 1] < n - 1 else n - 1
    while lo < hi:  # the last k with cum[k] <= target
        mid = (lo + hi + 1) // 2
        if cum[mid] <= target:
            lo = mid
        else:
            hi = mid - 1
    delta = target - cum[lo]
    if delta < 0.0:
        delta = 0.0
    a = (f[lo + 1] - f[lo]) * (0.5 * n)
    b = f[lo]
    disc = b * b + 4.0 * a * delta
    # the root of a t^2 + b t = delta written without cancellation
    t = 2.0 * delta / (b + math.sqrt(disc if disc > 0.0 else 0.0))
    if t > 1.0 / n:
        t = 1.0 / n
    return lo / n + t, b + 2.0 * a * t


@kernel
def _invert_rates(u, f, cum, start, x):
    for k in range(u.shape[0]):
        x[k] = _invert_rate(u[k], f, cum, start)[0]


@kernel
def _sampling_scale(r0, c0, cx, cy, radius, f, cum, start, s, sigma):
    """s = rho(r) / r inside the lens (F(1) / f(0) at r = 0), 1 outside; sigma (if not
    empty) = max(s, drho/dr), drho/dr = F(1) / f."""
    nr, nc = s.shape
    jacobian = sigma.shape[0] == nr
    f1 = cum[cum.shape[0] - 1]
    for j in range(nr):
        dy = (r0 + j + 0.5) - cy
        for i in range(nc):
            dx = (c0 + i + 0.5) - cx
            r = math.sqrt(dx * dx + dy * dy)
            sv = 1.0
            sg = 1.0
            if r < radius:
                x, fx = _invert_rate(r / radius, f, cum, start)
                sv = f1 / f[0] if r == 0.0 else x * radius / r
                sg = max(sv, f1 / fx)
            s[j, i] = sv
            if jacobian:
                sigma[j, i] = sg


@kernel
def _apply_homothety(origins, directions, width, r0, c0, s, anchor, fwd, parallel):
    """Re-aim the rays of the window's pixels with s != 1 (see ``lenses``' module
    docstring); return how many changed.

    Parallel: origin ``O_c + s (O_p - O_c)`` (``anchor = O_c``). Perspective: the
    direction through ``u_c + s (u_p - u_c)``, where ``u = d / (d . fwd)`` is a ray's
    point at unit depth (``anchor = u_c``); the origin stays the camera position.
    """
    nr, nc = s.shape
    moved = 0
    for j in range(nr):
        for i in range(nc):
            sv = s[j, i]
            if sv == 1.0:
                continue
            moved += 1
            k = (r0 + j) * width + c0 + i
            if parallel:
                for a in range(3):
                    origins[k, a] = anchor[a] + sv * (origins[k, a] - anchor[a])
            else:
                depth = directions[k, 0] * fwd[0] + directions[k, 1] * fwd[1] + directions[k, 2] * fwd[2]
                ux = anchor[0] + sv * (directions[k, 0] / depth - anchor[0])
                uy = anchor[1] + sv * (directions[k, 1] / depth - anchor[1])
                uz = anchor[2] + sv * (directions[k, 2] / depth - anchor[2])
                inv = 1.0 / math.sqrt(ux * ux + uy * uy + uz * uz)
                directions[k, 0] = ux * inv
                directions[k, 1] = uy * inv
                directions[k, 2] = uz * inv
    return moved


@kernel
def _fill_lod(sigma, r0, c0, width, lod):
    """lod = max(0, log2 sigma) over the window; return whether any is > 0."""
    nr, nc = sigma.shape
    found = False
    for j in range(nr):
        for i in range(nc):
            if sigma[j, i] > 1.0:
                lod[(r0 + j) * width + c0 + i] = np.log2(sigma[j, i])  # math.log2: not in numba 0.56
                found = True
    return found


@kernel
def _lower_envelope(f, n, d, v, z):
    """1-D squared distance transform (Felzenszwalb & Huttenlocher 2012) of f[:n] into d[:n].

    f is 0 at sites, inf elsewhere (first pass) or the previous pass's squared distances;
    infinite entries are not parabolas. All values are integers, so the result is exact.
    """
    k = -1
    for q in range(n):
        fq = f[q]
        if fq == np.inf:
            continue
        if k < 0:
            k = 0
            v[0] = q
            z[0] = -np.inf
            z[1] = np.inf
            continue
        while True:
            p = v[k]
            sep = ((fq + q * q) - (f[p] + p * p)) / (2.0 * q - 2.0 * p)
            if sep <= z[k]:
                k -= 1  # z[0] = -inf stops this at k = 0
            else:
                break
        k += 1
        v[k] = q
        z[k] = sep
        z[k + 1] = np.inf
    if k < 0:
        for q in range(n):
            d[q] = np.inf
        return
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        p = v[k]
        d[q] = (q - p) * (q - p) + f[p]


@kernel
def _squared_edt(mask):
    """Squared Euclidean distance from every pixel to the nearest True pixel (inf: none)."""
    h, w = mask.shape
    out = np.empty((h, w))
    n = max(h, w)
    f = np.empty(n)
    d = np.empty(n)
    v = np.empty(n, dtype=np.int64)
    z = np.empty(n + 1)
    for i in range(w):
        for j in range(h):
            f[j] = 0.0 if mask[j, i] else np.inf
        _lower_envelope(f, h, d, v, z)
        for j in range(h):
            out[j, i] = d[j]
    for j in range(h):
        for i in range(w):
            f[i] = out[j, i]
        _lower_envelope(f, w, d, v, z)
        for i in range(w):
            out[j, i] = d[i]
    return out


@kernel
def _project_cubes(cells, origin, spacing, pos, right, up, fwd, parallel, half_h, w, h, pts, flags):
    """Pixel positions (col, row) of the 8 corners of each voxel cube ``cells[v] + [-0.5, 0.5]^3``
    (index order x, y, z), as ``Camera.project``; ``flags``: 1 when every corner is behind
    the eye, 2 when a perspective cube straddles the eye plane, else 0."""
    aspect = w / h
    for v in range(cells.shape[0]):
        behind = 0
        for a in range(8):
            px = origin[0] + (cells[v, 0] + (a & 1) - 0.5) * spacing[0] - pos[0]
            py = origin[1] + (cells[v, 1] + ((a >> 1) & 1) - 0.5) * spacing[1] - pos[1]
            pz = origin[2] + (cells[v, 2] + ((a >> 2) & 1) - 0.5) * spacing[2] - pos[2]
            x = px * right[0] + py * right[1] + pz * right[2]
            y = px * up[0] + py * up[1] + pz * up[2]
            z = px * fwd[0] + py * fwd[1] + pz * fwd[2]
            if z <= 0.0:
                behind += 1
            if parallel:
                u = x / half_h
                t = y / half_h
            else:
                u = x / (z * half_h)
                t = y / (z * half_h)
            pts[v, a, 0] = (u / aspect + 1.0) * w / 2.0
            pts[v, a, 1] = (1.0 - t) * h / 2.0
        flags[v] = 1 if behind == 8 else (2 if behind > 0 and not parallel else 0)


@kernel
def _fill_projected_cubes(pts, flags, mask):
    """Mark pixels whose centre lies in the convex hull of each voxel's 8 projected corners.

    pts: (n, 8, 2) (col, row); flags: 0 project, 1 skip (behind the eye), 2 fill all.
    The hull's extent on a scanline is reached on a segment between two corners, so the
    28 corner pairs give it exactly, without building the hull.
    """
    h, w = mask.shape
    for v in range(pts.shape[0]):
        if flags[v] == 1:
            continue
        if flags[v] == 2:
            for j in range(h):
                for i in range(w):
                    mask[j, i] = True
            return
        ymin = np.inf
        ymax = -np.inf
        for a in range(8):
            y = pts[v, a, 1]
            if y < ymin:
                ymin = y
            if y > ymax:
                ymax = y
        lo = ymin - 0.5
        hi = ymax - 0.5
        if not (hi >= 0.0 and lo <= h - 1.0):  # also drops NaN
            continue
        j0 = 0 if lo <= 0.0 else int(math.ceil(lo))
        j1 = h - 1 if hi >= h - 1.0 else int(math.floor(hi))
        for j in range(j0, j1 + 1):
            yc = j + 0.5
            xl = np.inf
            xr = -np.inf
            for a in range(8):
                ax = pts[v, a, 0]
                ay = pts[v, a, 1]
                if ay == yc:
                    if ax < xl:
                        xl = ax
                    if ax > xr:
                        xr = ax
                for b in range(a + 1, 8):
                    by = pts[v, b, 1]
                    if (ay < yc < by) or (by < yc < ay):
                        x = ax + (yc - ay) * (pts[v, b, 0] - ax) / (by - ay)
                        if x < xl:
                            xl = x
                        if x > xr:
                            xr = x
            lo = xl - 0.5
            hi = xr - 0.5
            if not (hi >= 0.0 and lo <= w - 1.0):
                continue
            i0 = 0 if lo <= 0.0 else int(math.ceil(lo))
            i1 = w - 1 if hi >= w - 1.0 else int(math.floor(hi))
            for i in range(i0, i1 + 1):
                mask[j, i] = True


@inline_kernel
def _fisheye_ray(col, row, w, h, k, frame, out, n):
    """out[n] = the equidistant fisheye direction at (col, row); frame rows: right, up, fwd."""
    dx = col - 0.5 * w
    dy = 0.5 * h - row
    r = math.sqrt(dx * dx + dy * dy)
    theta = k * r
    lateral = k if r == 0.0 else math.sin(theta) / r  # sin(theta) / r -> k at the centre
    cos = math.cos(theta)
    for a in range(3):
        out[n, a] = cos * frame[2, a] + lateral * (dx * frame[0, a] + dy * frame[1, a])


@kernel
def _fisheye_grid(w, h, k, frame, out):
    for j in range(h):
        for i in range(w):
            _fisheye_ray(i + 0.5, j + 0.5, w, h, k, frame, out, j * w + i)


@kernel
def _fisheye_points(pts, w, h, k, frame, out):
    for n in range(pts.shape[0]):
        _fisheye_ray(pts[n, 0], pts[n, 1], w, h, k, frame, out, n)


# -- clipping (rays/clip.py) -----------------------------------------------------------------
@inline_kernel
def _clip_one(ox, oy, oz, dx, dy, dz, planes, box, stop):
    """``(near, far)`` of ``t >= 0`` where ``o + t d`` is on the kept side of every plane
    (rows ``origin, normal`` of ``planes``: ``(x - origin) . normal >= 0``) and in
    ``box`` (6 bounds, or empty), ``far`` at most ``stop``."""
    near = 0.0
    for k in range(planes.shape[0]):
        s = (ox - planes[k, 0]) * planes[k, 3] + (oy - planes[k, 1]) * planes[k, 4] + (oz - planes[k, 2]) * planes[k, 5]
        r = dx * planes[k, 3] + dy * planes[k, 4] + dz * planes[k, 5]
        if r > 0.0:
            near = max(near, -s / r)
        elif r < 0.0:
            stop = min(stop, -s / r)
        elif not s >= 0.0:
            stop = -math.inf
    if box.shape[0] == 6:
        for axis in range(3):
            o = ox if axis == 0 else (oy if axis == 1 else oz)
            d = dx if axis == 0 else (dy if axis == 1 else dz)
            lo = box[2 * axis]
            hi = box[2 * axis + 1]
            if d != 0.0:
                ta = (lo - o) / d
                tb = (hi - o) / d
                near = max(near, min(ta, tb))
                stop = min(stop, max(ta, tb))
            elif not (o >= lo and o <= hi):
                stop = -math.inf
    return near, stop


@parallel_kernel
def clip_spans_of_camera(cam, width, height, planes, box, far, out):
    """``out[pix] = (near, far)`` of each pixel's ray (``camera_ray``); ``far``: a limit
    per pixel, or empty."""
    has_far = far.shape[0] > 0
    for row in numba.prange(height):
        for col in range(width):
            pix = row * width + col
            ox, oy, oz, dx, dy, dz = camera_ray(cam, col, row, width, height)
            near, stop = _clip_one(ox, oy, oz, dx, dy, dz, planes, box, far[pix] if has_far else math.inf)
            out[pix, 0] = near
            out[pix, 1] = stop


@parallel_kernel
def clip_spans_of_rays(origins, directions, planes, box, far, out):
    """``clip_spans_of_camera`` for rays given as arrays (one row per ray)."""
    has_far = far.shape[0] > 0
    for i in numba.prange(origins.shape[0]):
        near, stop = _clip_one(origins[i, 0], origins[i, 1], origins[i, 2], directions[i, 0], directions[i, 1],
                               directions[i, 2], planes, box, far[i] if has_far else math.inf)
        out[i, 0] = near
        out[i, 1] = stop
