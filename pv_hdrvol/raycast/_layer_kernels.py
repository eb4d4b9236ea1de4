"""numba kernels of the depth layers of a mesh boundary (``raycast/layers.py``).

A boundary face is rasterised like a triangle on a GPU: the ray of pixel ``(col, row)``
is ``camera_ray``'s, whose view-plane coordinates ``x`` (from the column) and ``y``
(from the row) enter its direction (perspective) or origin (parallel) linearly. The
Plücker product of that ray with an edge is therefore, up to a positive factor, the
edge function ``A x + B y + C``, with ``A, B, C`` fixed per edge and view. Each edge's
three numbers are formed once, from its lower-numbered corner (negated for the other
direction), so two faces sharing an edge evaluate exactly opposite numbers at every
pixel and agree on which of them the ray crosses: no pixel is lost or counted twice
along a shared edge. An exact zero takes the sign of ``A`` (then of ``B``), opposite
for the two faces too (a tie rule like a rasteriser's top-left rule).

The ray caster itself finds its entry faces with the full Plücker test
(``_tet_kernels.boundary_hits``); these kernels serve the reference layers of
upsampling, where per pixel per face two multiply-adds per edge replace it.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import inline_kernel, kernel, parallel_kernel

#: per face: 3 edges x (A, B, C), the plane (P, Q, R) and n . R, n . U, n . F (``face_setup``)
FACE_FIELDS = 15


@inline_kernel
def _dot(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@kernel
def _edge(points, u, v, cam, ox, oy, oz, scale):
    """``(A, B, C)`` of the edge ``u -> v`` (formed from the lower-numbered corner)."""
    sign = 1.0
    if u > v:
        u, v = v, u
        sign = -1.0
    ax, ay, az = points[u, 0], points[u, 1], points[u, 2]
    bx, by, bz = points[v, 0], points[v, 1], points[v, 2]
    ex, ey, ez = bx - ax, by - ay, bz - az
    rx, ry, rz = cam[3], cam[4], cam[5]
    ux, uy, uz = cam[6], cam[7], cam[8]
    fx, fy, fz = cam[9], cam[10], cam[11]
    # a x b
    cx = ay * bz - az * by
    cy = az * bx - ax * bz
    cz = ax * by - ay * bx
    if cam[14] == 0.0:
        # perspective, origin o fixed: pi = d . (a x b + (b - a) x o), d = x R + y U + F (up to |d|)
        gx = cx + (ey * oz - ez * oy)
        gy = cy + (ez * ox - ex * oz)
        gz = cz + (ex * oy - ey * ox)
        return sign * _dot(rx, ry, rz, gx, gy, gz), sign * _dot(ux, uy, uz, gx, gy, gz), \
            sign * _dot(fx, fy, fz, gx, gy, gz)
    # parallel, direction F fixed, origin o + (x R + y U) / scale:
    # pi = F . (a x b) + origin . (F x (b - a))
    gx = fy * ez - fz * ey
    gy = fz * ex - fx * ez
    gz = fx * ey - fy * ex
    return sign * _dot(rx, ry, rz, gx, gy, gz) / scale, sign * _dot(ux, uy, uz, gx, gy, gz) / scale, \
        sign * (_dot(fx, fy, fz, cx, cy, cz) + _dot(ox, oy, oz, gx, gy, gz))


@inline_kernel
def _eye(cam):
    """The camera position in the mesh's normalised frame, and the mesh's scale (``cam``:
    ``tets.camera_array``)."""
    scale = cam[18]
    return (cam[0] - cam[15]) / scale, (cam[1] - cam[16]) / scale, (cam[2] - cam[17]) / scale, scale


@inline_kernel
def _view_coordinate(q, n, half):
    """``camera_ray``'s view-plane coordinate of pixel column (or row) ``q`` of ``n``."""
    return ((q + 0.5) * (2.0 / n) - 1.0) * half


@parallel_kernel
def face_boxes(points, tri, cam, width, height, boxes, proj):
    """Per boundary face, its corners' pixel coordinates ``proj[f]`` ((3, 2): column,
    row, continuous, row 0 at the top, as ``Camera.project``; all NaN for a face with a
    corner behind a perspective camera) and ``boxes[f]``: the pixels ``col0, col1, row0, row1`` whose
    centres lie in the projected bounding box widened by 1e-3 pixel against rounding,
    clipped to the image (empty when ``col1 < col0``); the whole image for a face
    reaching behind the camera. The box only limits the search; the exact tests decide.

    ``cam`` is ``tets.camera_array`` (``Camera.kernel_array``, then the mesh's centre
    and scale); the points are in the mesh's normalised frame.
    """
    ox, oy, oz, scale = _eye(cam)
    perspective = cam[14] == 0.0
    for f in numba.prange(tri.shape[0]):
        behind = False
        for m in range(3):
            p = tri[f, m]
            rx = points[p, 0] - ox
            ry = points[p, 1] - oy
            rz = points[p, 2] - oz
            x = _dot(rx, ry, rz, cam[3], cam[4], cam[5])
            y = _dot(rx, ry, rz, cam[6], cam[7], cam[8])
            if perspective:
                z = _dot(rx, ry, rz, cam[9], cam[10], cam[11])
                if not z > 0.0:
                    behind = True
                x /= z
                y /= z
            else:
                x *= scale
                y *= scale
            proj[f, m, 0] = (x / cam[12] + 1.0) * (0.5 * width)
            proj[f, m, 1] = (1.0 - y / cam[13]) * (0.5 * height)
        if behind:
            for m in range(3):
                proj[f, m, 0] = math.nan
                proj[f, m, 1] = math.nan
            boxes[f, 0] = 0
            boxes[f, 1] = width - 1
            boxes[f, 2] = 0
            boxes[f, 3] = height - 1
            continue
        lo_c = min(proj[f, 0, 0], proj[f, 1, 0], proj[f, 2, 0])
        hi_c = max(proj[f, 0, 0], proj[f, 1, 0], proj[f, 2, 0])
        lo_r = min(proj[f, 0, 1], proj[f, 1, 1], proj[f, 2, 1])
        hi_r = max(proj[f, 0, 1], proj[f, 1, 1], proj[f, 2, 1])
        # centres at index + 1/2; clipped before converting (a corner may project far away)
        boxes[f, 0] = int(math.ceil(min(max(lo_c - 0.5 - 1e-3, 0.0), width + 1.0)))
        boxes[f, 1] = int(math.floor(min(max(hi_c - 0.5 + 1e-3, -1.0), width - 1.0)))
        boxes[f, 2] = int(math.ceil(min(max(lo_r - 0.5 - 1e-3, 0.0), height + 1.0)))
        boxes[f, 3] = int(math.floor(min(max(hi_r - 0.5 + 1e-3, -1.0), height - 1.0)))


@parallel_kernel
def face_setup(points, tri, normals, cam, faces):
    """Per boundary face, ``faces[f]``: the three edges' ``(A, B, C)`` and the plane.

    ``cam`` is ``tets.camera_array``; points and the eye are in the mesh's normalised
    frame. The plane (``faces[f, 9:12] = (P, Q, R)``, ``faces[f, 12:15] = (n . R, n . U,
    n . F)``, ``n`` the face's normal): a perspective ray meets it at
    ``t = P |D| / (n . D)`` with ``D = x R + y U + F``, ``n . D = x n.R + y n.U + n.F`` and
    ``|D| = sqrt(1 + x^2 + y^2)``; a parallel one at ``t = (P + Q x + R y) / (n . F)``.
    """
    ox, oy, oz, scale = _eye(cam)
    perspective = cam[14] == 0.0
    for f in numba.prange(tri.shape[0]):
        for e in range(3):
            A, B, C = _edge(points, tri[f, e], tri[f, (e + 1) % 3], cam, ox, oy, oz, scale)
            faces[f, 3 * e] = A
            faces[f, 3 * e + 1] = B
            faces[f, 3 * e + 2] = C
        a = tri[f, 0]
        nx, ny, nz = normals[f, 0], normals[f, 1], normals[f, 2]
        faces[f, 9] = nx * (points[a, 0] - ox) + ny * (points[a, 1] - oy) + nz * (points[a, 2] - oz)
        nr = _dot(nx, ny, nz, cam[3], cam[4], cam[5])
        nu = _dot(nx, ny, nz, cam[6], cam[7], cam[8])
        faces[f, 10] = 0.0 if perspective else -nr / scale
        faces[f, 11] = 0.0 if perspective else -nu / scale
        faces[f, 12] = nr
        faces[f, 13] = nu
        faces[f, 14] = _dot(nx, ny, nz, cam[9], cam[10], cam[11])


@inline_kernel
def _side(value, A, B):
    """The sign of an edge function, an exact 0 taking the sign of ``A`` (then ``B``)."""
    if value != 0.0:
        return value
    if A != 0.0:
        return A
    return B


@parallel_kernel
def rasterize_layers(faces, boxes, cam, width, height, bands, lanes, length_scale, counts, layers, thickness):
    """Per pixel: the number of boundary faces its ray crosses at ``t >= 0`` (``counts``),
    the ``k`` nearest ``t`` in order (``layers`` (k, pixels), ``inf`` past the count)
    and the sum of exits' minus entries' ``t``, at least 0 (``thickness``), all three
    filled here (no need to initialise them); distances times ``length_scale`` (world
    units for the mesh's normalised ones).

    Rows are split into ``bands``, one band per thread at a time, so no two threads
    write one pixel; lane ``l`` takes bands ``l, l + lanes, ...`` and the lanes are
    split among the threads, so each thread's rows are spread over the image (a mesh
    seldom fills it evenly). ``faces`` and ``boxes`` from ``face_setup``.
    """
    perspective = cam[14] == 0.0
    half_w = cam[12]
    half_h = cam[13]
    xs = np.empty(width)
    for col in range(width):
        xs[col] = _view_coordinate(col, width, half_w)
    ys = np.empty(height)
    for row in range(height):
        ys[row] = -_view_coordinate(row, height, half_h)  # (1 - (row + 1/2) 2 / h) half_h
    band_rows = (height + bands - 1) // bands
    for lane in numba.prange(lanes):
        for band in range(lane, bands, lanes):
            r0 = band * band_rows
            r1 = min(height, (band + 1) * band_rows) - 1
            p0 = r0 * width
            p1 = (r1 + 1) * width
            for pix in range(p0, p1):
                counts[pix] = 0
                thickness[pix] = 0.0
                for m in range(layers.shape[0]):
                    layers[m, pix] = math.inf
            _rasterize_band(faces, boxes, width, perspective, xs, ys, r0, r1, counts, layers, thickness)
            for row in range(r0, r1 + 1):
                y = ys[row]
                for col in range(width):
                    pix = row * width + col
                    if counts[pix] == 0:
                        continue
                    # the band kernel's distances are along D; perspective rays have |D| > 1
                    x = xs[col]
                    f = length_scale * math.sqrt(1.0 + x * x + y * y) if perspective else length_scale
                    # differences of distances: rounding may leave -1e-16 where a ray grazes the boundary
                    thickness[pix] = max(thickness[pix], 0.0) * f
                    for m in range(layers.shape[0]):
                        layers[m, pix] *= f


@kernel
def _rasterize_band(faces, boxes, width, perspective, xs, ys, r0, r1, counts, layers, thickness):
    """``rasterize_layers`` for the rows ``r0 .. r1``: distances along ``D`` (perspective:
    not yet times ``|D|``), in the mesh's normalised units."""
    k = layers.shape[0]
    for f in range(faces.shape[0]):
        row0 = max(boxes[f, 2], r0)
        row1 = min(boxes[f, 3], r1)
        if row1 < row0 or boxes[f, 1] < boxes[f, 0]:
            continue
        a0, b0, c0 = faces[f, 0], faces[f, 1], faces[f, 2]
        a1, b1, c1 = faces[f, 3], faces[f, 4], faces[f, 5]
        a2, b2, c2 = faces[f, 6], faces[f, 7], faces[f, 8]
        p, q, r = faces[f, 9], faces[f, 10], faces[f, 11]
        nr, nu, nf = faces[f, 12], faces[f, 13], faces[f, 14]
        for row in range(row0, row1 + 1):
            y = ys[row]
            for col in range(boxes[f, 0], boxes[f, 1] + 1):
                x = xs[col]
                s0 = _side(a0 * x + b0 * y + c0, a0, b0)
                s1 = _side(a1 * x + b1 * y + c1, a1, b1)
                s2 = _side(a2 * x + b2 * y + c2, a2, b2)
                if not ((s0 > 0.0 and s1 > 0.0 and s2 > 0.0) or (s0 < 0.0 and s1 < 0.0 and s2 < 0.0)):
                    continue
                if perspective:
                    # in units of |D| (rasterize_layers multiplies by it once per pixel)
                    nd = nr * x + nu * y + nf
                    t = p / nd
                else:
                    nd = nf
                    t = (p + q * x + r * y) / nd
                if not (t >= 0.0 and t < math.inf):
                    continue
                pix = row * width + col
                counts[pix] += 1
                thickness[pix] += -t if nd < 0.0 else t
                if k > 0 and t < layers[k - 1, pix]:
                    m = k - 1
                    while m > 0 and layers[m - 1, pix] > t:
                        layers[m, pix] = layers[m - 1, pix]
                        m -= 1
                    layers[m, pix] = t
