"""numba kernels of the depth layers of a mesh boundary (``raycast/layers.py``).

A boundary face is rasterised like a triangle on a GPU: the ray of pixel ``(col, row)``
is ``camera_ray``'s, whose view-plane coordinates ``x`` (from the column) and ``y``
(from the row) enter its direction (perspective) or origin (parallel) linearly. The
Plücker product of that ray with an edge is therefore, up to a positive factor, the
edge function ``A x + B y + C``, with ``A, B, C`` fixed per edge and view. Each edge's
three numbers are formed once, from its lower-numbered corner (negated for the other
direction), so two faces sharing an edge evaluate exactly opposite numbers at every
pixel and agree on which of them the ray crosses: no pixel is lost or counted twice
along a shared edge. Where an edge function is within rounding of zero (a ray through
an edge or a vertex), the ray caster's own Plücker test decides, with its tie rule for
exact zeros, so the rasteriser makes exactly the walk's decisions (``_rasterize_band``).

The same rasteriser serves the ray caster (``rasterize_hits``: each pixel's crossings,
its entry and re-entry faces) and the reference layers of upsampling
(``rasterize_layers``: the nearest ``k`` crossings and the thickness), so the two cover
the same pixels. Per pixel and face it costs two multiply-adds per edge, where a
Plücker test from the points costs three products of cross products.

What does not depend on the image's size is formed once per view, in the view plane
(``face_view``, ``face_setup``: edge functions, plane, tolerances, where each edge
crosses a row), so a low-resolution render and its full-resolution layers share it;
per size come only the faces' pixel boxes (``face_boxes``) and the faces of each band
of rows (``band_faces``), so a band visits only its own faces.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import helper_kernel, kernel, parallel_kernel
from ._tet_kernels import _face_point, _face_products, _same_sign, pixel_ray

#: per face (``face_setup``): 3 edges x (A, B, C), the plane (P, Q, R), n . R, n . U,
#: n . F, the 3 edges' tolerances, the sign the edge functions share inside, and per
#: edge the view-plane x of its zero on row y as ``k y + m`` (k, then m, edge by edge)
FACE_FIELDS = 25
#: an edge bounds a row's span of pixels only where its function changes by at least
#: this many of its rounding tolerances per pixel (then its zero is known to 1e-3 pixel)
SPAN_SAFE = 1e3
#: relative size of an edge function below which its sign is left to the Plücker test
#: (the rounding of either is about 1e-15 of the same scale)
UNSURE = 1e-9
#: what ``_rasterize_band`` fills: depth layers and thickness, crossing counts, crossing lists
LAYERS, COUNT, HITS = 0, 1, 2


@helper_kernel
def _dot(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@helper_kernel
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


@helper_kernel
def _eye(cam):
    """The camera position in the mesh's normalised frame, and the mesh's scale (``cam``:
    ``tets.camera_array``)."""
    scale = cam[18]
    return (cam[0] - cam[15]) / scale, (cam[1] - cam[16]) / scale, (cam[2] - cam[17]) / scale, scale


@helper_kernel
def _view_coordinate(q, n, half):
    """``camera_ray``'s view-plane coordinate of pixel column (or row) ``q`` of ``n``."""
    return ((q + 0.5) * (2.0 / n) - 1.0) * half


@parallel_kernel
def face_view(points, tri, cam, view):
    """Per boundary face, its corners' view-plane coordinates ``view[f]`` ((3, 2):
    ``camera_ray``'s ``x`` and ``y`` of the ray through the corner; all NaN for a face
    with a corner behind a perspective camera). They do not depend on the image's
    size, so one table serves a render and its full-resolution layers.

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
            view[f, m, 0] = x
            view[f, m, 1] = y
        if behind:
            for m in range(3):
                view[f, m, 0] = math.nan
                view[f, m, 1] = math.nan


@parallel_kernel
def face_boxes(view, cam, width, height, boxes):
    """Per boundary face, ``boxes[f]``: the pixels ``col0, col1, row0, row1`` of a
    ``width`` x ``height`` image whose centres lie in the bounding box of the corners'
    projections (``face_view``; column ``(x / half_w + 1) width / 2``, row
    ``(1 - y / half_h) height / 2``, as ``Camera.project``), widened by 1e-3 pixel
    against rounding and clipped to the image (empty when ``col1 < col0``); the whole
    image for a face reaching behind the camera. The box only limits the search; the
    exact tests decide.
    """
    for f in numba.prange(view.shape[0]):
        if view[f, 0, 0] != view[f, 0, 0]:
            boxes[f, 0] = 0
            boxes[f, 1] = width - 1
            boxes[f, 2] = 0
            boxes[f, 3] = height - 1
            continue
        lo_c = math.inf
        hi_c = -math.inf
        lo_r = math.inf
        hi_r = -math.inf
        for m in range(3):
            col = (view[f, m, 0] / cam[12] + 1.0) * (0.5 * width)
            row = (1.0 - view[f, m, 1] / cam[13]) * (0.5 * height)
            lo_c = min(lo_c, col)
            hi_c = max(hi_c, col)
            lo_r = min(lo_r, row)
            hi_r = max(hi_r, row)
        # centres at index + 1/2; clipped before converting (a corner may project far away)
        boxes[f, 0] = int(math.ceil(min(max(lo_c - 0.5 - 1e-3, 0.0), width + 1.0)))
        boxes[f, 1] = int(math.floor(min(max(hi_c - 0.5 + 1e-3, -1.0), width - 1.0)))
        boxes[f, 2] = int(math.ceil(min(max(lo_r - 0.5 - 1e-3, 0.0), height + 1.0)))
        boxes[f, 3] = int(math.floor(min(max(hi_r - 0.5 + 1e-3, -1.0), height - 1.0)))


@kernel
def band_faces(boxes, height, bands):
    """``(offsets, members)``: the faces whose boxes reach into each band of rows
    (``rasterize_layers``' bands), band ``i``'s being ``members[offsets[i]:offsets[i + 1]]``
    in ascending order, so each band visits only its faces, in the order of all."""
    band_rows = (height + bands - 1) // bands
    offsets = np.zeros(bands + 1, dtype=np.int64)
    for f in range(boxes.shape[0]):
        if boxes[f, 1] >= boxes[f, 0] and boxes[f, 3] >= boxes[f, 2]:
            for band in range(boxes[f, 2] // band_rows, boxes[f, 3] // band_rows + 1):
                offsets[band + 1] += 1
    for band in range(bands):
        offsets[band + 1] += offsets[band]
    members = np.empty(offsets[bands], dtype=np.int64)
    fill = offsets[:bands].copy()
    for f in range(boxes.shape[0]):
        if boxes[f, 1] >= boxes[f, 0] and boxes[f, 3] >= boxes[f, 2]:
            for band in range(boxes[f, 2] // band_rows, boxes[f, 3] // band_rows + 1):
                members[fill[band]] = f
                fill[band] += 1
    return offsets, members


@parallel_kernel
def face_setup(points, tri, normals, view, cam, faces):
    """Per boundary face, ``faces[f]`` (``FACE_FIELDS``): the three edges' ``(A, B, C)``,
    the plane, the edges' tolerances, the sign the edge functions share inside and
    where each edge's zero lies along a row; from the corners' view-plane coordinates
    ``view`` (``face_view``), so the table holds for any image size.

    ``cam`` is ``tets.camera_array``; points and the eye are in the mesh's normalised
    frame. The plane (``faces[f, 9:12] = (P, Q, R)``, ``faces[f, 12:15] = (n . R, n . U,
    n . F)``, ``n`` the face's normal): a perspective ray meets it at
    ``t = P |D| / (n . D)`` with ``D = x R + y U + F``, ``n . D = x n.R + y n.U + n.F`` and
    ``|D| = sqrt(1 + x^2 + y^2)``; a parallel one at ``t = (P + Q x + R y) / (n . F)``.

    Tolerance of edge ``e`` (``faces[f, 15 + e]``): ``UNSURE`` times its rounding scale
    (``_edge_scale``) at the largest ``|x|``, ``|y|`` of the face's pixels: those of its
    corners plus 2e-3 of the half view (the pixel boxes reach 1e-3 pixel past them),
    at most the half view (every pixel centre lies inside it; all of it for a face
    reaching behind the eye). The inside's sign
    (``faces[f, 18]``): the edge functions' shared sign at the corners' centroid, when
    all three are sure there (a face in front of the eye whose projection is no
    sliver), else 0 (no spans: every row scans the face's whole box). Edge ``e``'s zero
    on row ``y`` is at ``x = k y + m`` (``faces[f, 19 + 2 e]``, ``faces[f, 20 + 2 e]``;
    0 and 0 for an edge along the rows).
    """
    ox, oy, oz, scale = _eye(cam)
    perspective = cam[14] == 0.0
    eye = math.sqrt(_dot(ox, oy, oz, ox, oy, oz)) + (0.0 if perspective else 1.0 / scale)
    for f in numba.prange(tri.shape[0]):
        norms = (_norm(points, tri[f, 0]), _norm(points, tri[f, 1]), _norm(points, tri[f, 2]))
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
        # every pixel centre lies inside the view (|x| < half_w, |y| < half_h)
        X = cam[12]
        Y = cam[13]
        in_front = view[f, 0, 0] == view[f, 0, 0]
        if in_front:
            X = min(X, max(abs(view[f, 0, 0]), abs(view[f, 1, 0]), abs(view[f, 2, 0])) + 2e-3 * cam[12])
            Y = min(Y, max(abs(view[f, 0, 1]), abs(view[f, 1, 1]), abs(view[f, 2, 1])) + 2e-3 * cam[13])
        spread = 1.0 + X + Y
        for e in range(3):
            A, B, C = faces[f, 3 * e], faces[f, 3 * e + 1], faces[f, 3 * e + 2]
            sc = _edge_scale(points, tri[f, e], tri[f, (e + 1) % 3], norms[e], norms[(e + 1) % 3], eye)
            faces[f, 15 + e] = UNSURE * (sc * spread + abs(A) * X + abs(B) * Y + abs(C))
        # the inside's sign, at the centroid of the corners' view-plane points
        sigma = 0.0
        if in_front:
            xc = (view[f, 0, 0] + view[f, 1, 0] + view[f, 2, 0]) / 3.0
            yc = (view[f, 0, 1] + view[f, 1, 1] + view[f, 2, 1]) / 3.0
            above = 0
            below = 0
            for e in range(3):
                w = faces[f, 3 * e] * xc + faces[f, 3 * e + 1] * yc + faces[f, 3 * e + 2]
                above += w > faces[f, 15 + e]
                below += w < -faces[f, 15 + e]
            sigma = 1.0 if above == 3 else (-1.0 if below == 3 else 0.0)
        faces[f, 18] = sigma
        for e in range(3):
            A = faces[f, 3 * e]
            inv = -1.0 / A if A != 0.0 else 0.0
            faces[f, 19 + 2 * e] = faces[f, 3 * e + 1] * inv
            faces[f, 20 + 2 * e] = faces[f, 3 * e + 2] * inv


@helper_kernel
def _norm(points, u):
    """``|points[u]|``."""
    return math.sqrt(_dot(points[u, 0], points[u, 1], points[u, 2], points[u, 0], points[u, 1], points[u, 2]))


@helper_kernel
def _edge_scale(points, u, v, nu, nv, eye):
    """The scale of the terms of the edge ``u -> v``'s function and Plücker product,
    ``|a| |b| + |b - a| (|o| + spread)`` (the same for both directions), from the
    corners' norms ``nu``, ``nv`` and ``eye = |o| + spread``: the rounding of either is
    a few 1e-16 of it times ``1 + |x| + |y|``. ``spread``: how far a parallel camera's
    ray origins move per unit of ``x`` or ``y`` (0 for perspective)."""
    ex = points[v, 0] - points[u, 0]
    ey = points[v, 1] - points[u, 1]
    ez = points[v, 2] - points[u, 2]
    return nu * nv + math.sqrt(_dot(ex, ey, ez, ex, ey, ez)) * eye


@kernel
def _view_plane(cam, width, height):
    """``(perspective, xs, ys)``: the camera's kind and the view-plane coordinates of
    the pixel columns and rows (``camera_ray``'s ``x`` and ``y``)."""
    xs = np.empty(width)
    for col in range(width):
        xs[col] = _view_coordinate(col, width, cam[12])
    ys = np.empty(height)
    for row in range(height):
        ys[row] = -_view_coordinate(row, height, cam[13])  # (1 - (row + 1/2) 2 / h) half_h
    return cam[14] == 0.0, xs, ys


@parallel_kernel
def rasterize_layers(faces, boxes, band_offsets, band_members, points, tri, normals, cam, width, height, bands,
                     lanes, length_scale, counts, layers, thickness):
    """Per pixel: the number of boundary faces its ray crosses at ``t >= 0`` (``counts``),
    the ``k`` nearest ``t`` in order (``layers`` (k, pixels), ``inf`` past the count)
    and the sum of exits' minus entries' ``t``, at least 0 (``thickness``), all three
    filled here (no need to initialise them); distances times ``length_scale`` (world
    units for the mesh's normalised ones).

    Rows are split into ``bands``, one band per thread at a time, so no two threads
    write one pixel; lane ``l`` takes bands ``l, l + lanes, ...`` and the lanes are
    split among the threads, so each thread's rows are spread over the image (a mesh
    seldom fills it evenly); each band visits only its faces (``band_faces``: ``band_offsets``,
    ``band_members``). ``faces`` and ``boxes`` from ``face_setup`` and ``face_boxes``;
    ``points``, ``tri`` and ``normals`` (the boundary faces and their outward normals)
    for the Plücker test of rays within rounding of an edge.
    """
    perspective, xs, ys = _view_plane(cam, width, height)
    no_offsets = np.empty(0, dtype=np.int64)  # the crossing lists: not made here
    no_t = np.empty(0)
    no_enter = np.empty(0, dtype=np.bool_)
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
            _rasterize_band(faces, boxes, band_members, band_offsets[band], band_offsets[band + 1], points, tri,
                            normals, cam, width, height, perspective, xs, ys, r0, r1, LAYERS, counts, layers,
                            thickness, no_offsets, no_t, no_offsets, no_enter)
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


@parallel_kernel
def rasterize_hits(faces, boxes, band_offsets, band_members, points, tri, normals, cam, width, height, bands,
                   lanes, count_only, offsets, counts, out_t, out_face, out_enter):
    """Per pixel, the boundary faces its ray crosses at ``t >= 0``: the ray caster's
    entry and re-entry faces, decided by the same edge functions as the layers.

    With ``count_only``, only ``counts`` (filled here). Otherwise the crossings of
    pixel ``i`` are written from ``offsets[i]`` on (``offsets`` from the counts of a
    ``count_only`` call, so they fit exactly), ``counts`` recounted: ``out_t`` the
    distance in the mesh's normalised units (``pixel_ray``'s ``t``), ``out_face`` the
    face, ``out_enter`` whether the ray goes into the mesh there (``n . d < 0``);
    sorted by ``t``, then face. Bands and lanes as ``rasterize_layers``.
    """
    perspective, xs, ys = _view_plane(cam, width, height)
    no_layers = np.empty((0, 0))
    no_thickness = np.empty(0)
    mode = COUNT if count_only else HITS
    band_rows = (height + bands - 1) // bands
    for lane in numba.prange(lanes):
        for band in range(lane, bands, lanes):
            r0 = band * band_rows
            r1 = min(height, (band + 1) * band_rows) - 1
            for pix in range(r0 * width, (r1 + 1) * width):
                counts[pix] = 0
            _rasterize_band(faces, boxes, band_members, band_offsets[band], band_offsets[band + 1], points, tri,
                            normals, cam, width, height, perspective, xs, ys, r0, r1, mode, counts, no_layers,
                            no_thickness, offsets, out_t, out_face, out_enter)
            if count_only:
                continue
            for row in range(r0, r1 + 1):
                y = ys[row]
                for col in range(width):
                    pix = row * width + col
                    lo = offsets[pix]
                    hi = lo + counts[pix]
                    if hi == lo:
                        continue
                    if perspective:  # the band kernel's distances are along D, |D| > 1
                        x = xs[col]
                        f = math.sqrt(1.0 + x * x + y * y)
                        for q in range(lo, hi):
                            out_t[q] *= f
                    _sort_hits(out_t, out_face, out_enter, lo, hi)


@kernel
def _sort_hits(ts, faces, enter, lo, hi):
    """Insertion sort of ``ts[lo:hi]`` (with ``faces`` and ``enter``) by ``t``, then face."""
    for i in range(lo + 1, hi):
        t = ts[i]
        f = faces[i]
        e = enter[i]
        j = i - 1
        while j >= lo and (ts[j] > t or (ts[j] == t and faces[j] > f)):
            ts[j + 1] = ts[j]
            faces[j + 1] = faces[j]
            enter[j + 1] = enter[j]
            j -= 1
        ts[j + 1] = t
        faces[j + 1] = f
        enter[j + 1] = e


@helper_kernel
def _edge_bound(sigma, a, b, k, m, tol, pixel, to_col, col_shift):
    """How the edge function ``a x + b y + c`` (zero at view-plane ``x = k y + m``)
    bounds a row's pixels that may have the inside's sign ``sigma``: ``(kind, kc, mc)``,
    the column of its zero on row ``y`` being ``kc y + mc``, a lower bound for
    ``kind = 1``, an upper one for ``kind = -1``. ``kind = 0`` (no bound) for no known
    sign, or an edge that changes by less than ``SPAN_SAFE`` tolerances ``tol`` per
    ``pixel`` or is nearly along the rows (``|b| > 1e6 |a|``): the rounding of
    ``kc y + mc`` then stays below 1e-6 column."""
    if sigma == 0.0 or abs(a) * pixel < SPAN_SAFE * tol or abs(b) > 1e6 * abs(a):
        return 0, 0.0, 0.0
    return (1 if sigma * a > 0.0 else -1), k * to_col, m * to_col + col_shift


@helper_kernel
def _bound(kind, k, m, y, lo, hi):
    """``[lo, hi]`` narrowed by an ``_edge_bound`` on row ``y``."""
    if kind > 0:
        return max(lo, k * y + m), hi
    if kind < 0:
        return lo, min(hi, k * y + m)
    return lo, hi


@kernel
def _plucker_hit(points, tri, normals, f, cam, col, row, width, height):
    """``(t, entering)`` of pixel ``(col, row)``'s ray through boundary face ``f`` by the
    ray caster's own Plücker test (``_tet_kernels._pi``, with its tie rule for exact
    zeros); ``t`` along the unit direction, ``nan`` on a miss."""
    ox, oy, oz, dx, dy, dz = pixel_ray(cam, col, row, width, height)
    a = tri[f, 0]
    b = tri[f, 1]
    c = tri[f, 2]
    wab, wbc, wca = _face_products(points, a, b, c, ox, oy, oz, dx, dy, dz)
    if not _same_sign(wab, wbc, wca):
        return math.nan, False
    t, ua, ub, uc = _face_point(points, a, b, c, wab, wbc, wca, ox, oy, oz, dx, dy, dz)
    return t, dx * normals[f, 0] + dy * normals[f, 1] + dz * normals[f, 2] < 0.0


@kernel
def _rasterize_band(faces, boxes, members, first, last, points, tri, normals, cam, width, height, perspective, xs, ys,
                    r0, r1, mode, counts, layers, thickness, offsets, out_t, out_face, out_enter):
    """The pixels in rows ``r0 .. r1`` of faces ``members[first:last]``, for ``mode``: ``LAYERS`` (``counts``,
    the ``k`` nearest distances ``layers`` and ``thickness``, as ``rasterize_layers``),
    ``COUNT`` (``counts``) or ``HITS`` (each crossing at ``offsets[pix] + counts[pix]``
    of ``out_t``, ``out_face``, ``out_enter``, as ``rasterize_hits``). Distances along
    ``D`` (perspective: not yet times ``|D|``), in the mesh's normalised units; the
    arrays a mode does not use are not touched.

    A pixel is decided by the signs of the three edge functions where each is larger
    than ``UNSURE`` times its rounding scale, or where two of them have surely
    opposite signs; otherwise (a ray within rounding of an edge or a vertex) by the
    ray caster's Plücker test, with its tie rule for exact zeros. Both faces of an
    edge see the same edge function, negated, and the same scale, so they agree on
    when to ask the Plücker test too, which also gives them exactly opposite numbers.
    """
    k = layers.shape[0]
    # view-plane x of a column's centre is (col + 1/2) pixel - half_w: its inverse
    pixel = xs[1] - xs[0] if width > 1 else 1.0
    to_col = 1.0 / pixel
    col_shift = -xs[0] * to_col
    for i in range(first, last):
        f = members[i]
        row0 = max(boxes[f, 2], r0)
        row1 = min(boxes[f, 3], r1)
        col0 = boxes[f, 0]
        col1 = boxes[f, 1]  # >= col0: band_faces lists no empty box
        a0, b0, c0 = faces[f, 0], faces[f, 1], faces[f, 2]
        a1, b1, c1 = faces[f, 3], faces[f, 4], faces[f, 5]
        a2, b2, c2 = faces[f, 6], faces[f, 7], faces[f, 8]
        p, q, r = faces[f, 9], faces[f, 10], faces[f, 11]
        nr, nu, nf = faces[f, 12], faces[f, 13], faces[f, 14]
        e0, e1, e2 = faces[f, 15], faces[f, 16], faces[f, 17]
        # each edge's zero, in columns, along the rows (a span; none without the inside's sign)
        sigma = faces[f, 18]
        k0, g0, m0 = _edge_bound(sigma, a0, b0, faces[f, 19], faces[f, 20], e0, pixel, to_col, col_shift)
        k1, g1, m1 = _edge_bound(sigma, a1, b1, faces[f, 21], faces[f, 22], e1, pixel, to_col, col_shift)
        k2, g2, m2 = _edge_bound(sigma, a2, b2, faces[f, 23], faces[f, 24], e2, pixel, to_col, col_shift)
        for row in range(row0, row1 + 1):
            y = ys[row]
            # columns whose centres lie in the span, widened by a pixel: a sure inside
            # pixel lies there, and an unsure one within 1e-3 pixel of an edge's zero
            lo, hi = _bound(k0, g0, m0, y, col0 - 1.0, col1 + 1.0)
            lo, hi = _bound(k1, g1, m1, y, lo, hi)
            lo, hi = _bound(k2, g2, m2, y, lo, hi)
            c_lo = max(col0, int(math.ceil(min(lo, col1 + 1.0))) - 1)
            c_hi = min(col1, int(math.floor(max(hi, col0 - 1.0))) + 1)
            for col in range(c_lo, c_hi + 1):
                x = xs[col]
                v0 = a0 * x + b0 * y + c0
                v1 = a1 * x + b1 * y + c1
                v2 = a2 * x + b2 * y + c2
                above = (v0 > e0) + (v1 > e1) + (v2 > e2)
                below = (v0 < -e0) + (v1 < -e1) + (v2 < -e2)
                if above == 3 or below == 3:
                    if perspective:
                        # in units of |D| (multiplied by it once per pixel afterwards)
                        nd = nr * x + nu * y + nf
                        t = p / nd
                    else:
                        nd = nf
                        t = (p + q * x + r * y) / nd
                    enter = nd < 0.0
                elif above > 0 and below > 0:
                    continue
                else:
                    t, enter = _plucker_hit(points, tri, normals, f, cam, col, row, width, height)
                    if perspective:
                        t /= math.sqrt(1.0 + x * x + y * y)
                if not (t >= 0.0 and t < math.inf):
                    continue
                pix = row * width + col
                if mode == HITS:
                    h = offsets[pix] + counts[pix]
                    out_t[h] = t
                    out_face[h] = f
                    out_enter[h] = enter
                counts[pix] += 1
                if mode != LAYERS:
                    continue
                thickness[pix] += -t if enter else t
                if k > 0 and t < layers[k - 1, pix]:
                    m = k - 1
                    while m > 0 and layers[m - 1, pix] > t:
                        layers[m, pix] = layers[m - 1, pix]
                        m -= 1
                    layers[m, pix] = t
