"""numba kernels for tetrahedral meshes: arrays in, arrays out (``raycast/tets.py`` validates).

Traversal (Platis & Theoharis 2003; Marmitt & Slusallek 2006): a ray ``o + t d`` meets
the edge ``a -> b`` of a cell with the Plücker product

    pi(a, b) = d . (a x b) + (b - a) . (o x d),

whose sign says on which side of the edge the ray passes. The ray crosses the
triangle ``(a, b, c)`` iff ``pi(a, b)``, ``pi(b, c)``, ``pi(c, a)`` share a sign, and
then meets it at the barycentric point ``(pi(b, c), pi(c, a), pi(a, b)) / sum``. Each
edge's product is formed from its two corners in ascending point order and negated
for the other direction, so a cell and its neighbour compute the very same numbers for
their shared edges and always agree on where a ray leaves one and enters the other: no
ray leaks through a crack between cells, whatever the rounding, and zero-volume cells
need no special case (they are crossed in zero length).

Rays enter through the mesh boundary: ``_layer_kernels.rasterize_hits`` lists, per
pixel, every boundary face the ray crosses, sorted by ``t``, so rays that leave a
non-convex mesh re-enter at their next entering face. It decides with edge functions,
which are the Plücker products of the face's edges up to a positive factor (formed
once per view: two multiply-adds per edge and pixel), and hands rays within rounding
of an edge to ``_pi`` below, so its decisions are the walk's; the walk forms the entry
face's products itself. The same rasteriser gives the depth layers of the boundary.

Integration of a cell's segment: the scalar is linear along it, from ``s0`` to ``s1``.
Within one table cell the extinction and the colour are linear too and the segment
is one piece: optical depth ``h (sigma_0 + sigma_1) / 2`` (exact) and ``int c sigma``
by the product rule. Across up to ``WALK_CELLS`` table cells it is one piece per
cell; across more, the integrals come from cumulative tables over the scalar
(``cumulative_tables``), again exact for the table's piecewise-linear functions, and
the segment is cut into pieces of optical depth at most ``tau_max``. A piece's
emission ``int c sigma e^-tau`` takes its colour as linear in optical depth between
the piece's ends (``_piece``): exact when extinction or colour is constant along the
piece, off by O(tau^3) times the colour change where both vary.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba

from .._jit import helper_kernel, kernel, parallel_kernel
from ..rays._kernels import CAMERA_FIELDS, camera_ray
from ._composite_kernels import _accumulate, _finish, _marker_precision, _opacity, _start, table_position
from ._kernels import lane_pixel, lane_pixels, store_pixel
from ._shading_kernels import SH_FADE, fade_weight, light_factors


#: directions of the symbolic perturbation of rays (generic: no simple ratios)
PERTURB_O = (0.5772156649015329, 0.2614972128476428, 0.7390851332151607)
PERTURB_D = (0.3183098861837907, 0.8346268416740731, 0.4472135954999579)
#: magnitude of a product decided by the perturbation (a weight of nothing)
TIE = 1e-250

#: columns of the tet renderer's table: r, g, b, sigma (per world unit) at the knot,
#: then the cumulative integrals from knot 0 of sigma, c_r sigma, c_g sigma, c_b sigma
#: over the data value, then the knot's data value (one row: one or two cache lines)
TABLE_COLUMNS = 9

#: how far (relative, in the mesh's normalised units) before the exit of a ray from
#: the mesh its next entering boundary face may lie and still be entered: the two
#: distances come from different faces and formulas, so they round differently
REENTRY_SLACK = 1e-9

#: table cells a segment may cross and still be integrated cell by cell (beyond: cumulative tables)
WALK_CELLS = 2

#: a cell's record (``tets._cell_records``): its integer view holds the four corners
#: (columns 0-3), then the four neighbour codes ``4 neighbour + face there`` (-1 on the
#: boundary; columns 4-7); its float64 view ends with the four corner values
#: (``_value_col``: column 4 of int32 records, 64 bytes a cell; 8 of int64 ones)
CORNER_COL = 0
NEIGHBOR_COL = 4


class TetParams(NamedTuple):
    """Scalars of a tet render (15 fields at most, see ``_kernels.GridParams``)."""

    precision: int
    scale: int  # transfer-function axis (data/transfer.SCALE_CODES)
    axis_lo: float
    axis_inv_range: float
    linthresh: float
    alpha_stop: float
    depth_alpha: float
    length_scale: float  # world units per normalised unit (TetMesh.scale)
    tau_max: float  # largest optical depth of one piece
    max_pieces: int
    max_steps: int  # cells a ray may visit before it is stopped (a guard, never reached on valid meshes)
    shade: int  # 1: light each cell by its gradient (``_shading_kernels``)


# -- Plücker products -----------------------------------------------------------------------
@helper_kernel
def _pi(points, a, b, dx, dy, dz, mx, my, mz, ox, oy, oz):
    """Product of the ray (origin o, direction d, moment m = o x d) with the edge a -> b.

    It is formed from the lower-numbered corner and negated for the other direction, so
    both directions give exactly opposite numbers. A product of exactly 0 (the ray
    meets the edge's line: through an edge or a vertex, or parallel to the edge) takes
    the sign it has for the ray moved by an infinitesimal ``eps PERTURB_O`` and turned
    by ``eps**2 PERTURB_D`` (simulation of simplicity): the first non-zero term of the
    expansion. Every cell sees the same perturbed ray, so the decisions stay
    consistent; the value returned is then ``+-TIE``, a weight of nothing.
    """
    sign = 1.0
    if a > b:
        a, b = b, a
        sign = -1.0
    ax = points[a, 0]
    ay = points[a, 1]
    az = points[a, 2]
    bx = points[b, 0]
    by = points[b, 1]
    bz = points[b, 2]
    ex = bx - ax
    ey = by - ay
    ez = bz - az
    pi = (dx * (ay * bz - az * by) + dy * (az * bx - ax * bz) + dz * (ax * by - ay * bx)
          + ex * mx + ey * my + ez * mz)
    if pi != 0.0:
        return sign * pi
    wx, wy, wz = PERTURB_O
    vx, vy, vz = PERTURB_D
    # eps: (b - a) . (w x d)
    q = ex * (wy * dz - wz * dy) + ey * (wz * dx - wx * dz) + ez * (wx * dy - wy * dx)
    if q == 0.0:
        # eps^2: the product of the line (o, v) with the edge
        q = (vx * (ay * bz - az * by) + vy * (az * bx - ax * bz) + vz * (ax * by - ay * bx)
             + ex * (oy * vz - oz * vy) + ey * (oz * vx - ox * vz) + ez * (ox * vy - oy * vx))
        if q == 0.0:
            # eps^3: (b - a) . (w x v)
            q = ex * (wy * vz - wz * vy) + ey * (wz * vx - wx * vz) + ez * (wx * vy - wy * vx)
    return sign * TIE if q >= 0.0 else -sign * TIE


@helper_kernel
def _face_products(points, a, b, c, ox, oy, oz, dx, dy, dz):
    """The ray's products with the edges ``a -> b``, ``b -> c`` and ``c -> a`` of a face."""
    mx = oy * dz - oz * dy
    my = oz * dx - ox * dz
    mz = ox * dy - oy * dx
    return (_pi(points, a, b, dx, dy, dz, mx, my, mz, ox, oy, oz),
            _pi(points, b, c, dx, dy, dz, mx, my, mz, ox, oy, oz),
            _pi(points, c, a, dx, dy, dz, mx, my, mz, ox, oy, oz))


@helper_kernel
def _same_sign(x, y, z):
    return (x >= 0.0 and y >= 0.0 and z >= 0.0) or (x <= 0.0 and y <= 0.0 and z <= 0.0)


@helper_kernel
def _face_point(points, a, b, c, wab, wbc, wca, ox, oy, oz, dx, dy, dz):
    """``(t, ua, ub, uc)``: where the ray meets triangle ``(a, b, c)`` and the point's
    barycentric weights; ``t = nan`` when the ray lies in the triangle's plane."""
    s = wab + wbc + wca
    if abs(s) < 1e3 * TIE:  # the ray lies in the triangle's plane
        return math.nan, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0
    ua = wbc / s
    ub = wca / s
    uc = wab / s
    x = ua * points[a, 0] + ub * points[b, 0] + uc * points[c, 0]
    y = ua * points[a, 1] + ub * points[b, 1] + uc * points[c, 1]
    z = ua * points[a, 2] + ub * points[b, 2] + uc * points[c, 2]
    return (x - ox) * dx + (y - oy) * dy + (z - oz) * dz, ua, ub, uc


# -- rays ----------------------------------------------------------------------------------
@kernel
def pixel_ray(cam, col, row, width, height):
    """The ray of pixel ``(col, row)`` in the mesh's normalised frame, bit for bit as
    ``Camera.rays`` then ``(origin - center) / scale`` compute it.

    ``cam`` (float64, ``camera_array``): ``Camera.kernel_array`` (``camera_ray``), then
    the mesh's centre and scale."""
    ox, oy, oz, dx, dy, dz = camera_ray(cam, col, row, width, height)
    scale = cam[CAMERA_FIELDS + 3]
    return ((ox - cam[CAMERA_FIELDS]) / scale, (oy - cam[CAMERA_FIELDS + 1]) / scale,
            (oz - cam[CAMERA_FIELDS + 2]) / scale, dx, dy, dz)


# -- integration of one segment -----------------------------------------------------------
@helper_kernel
def _tpos(v, n, p):
    """Fractional table index of data value ``v`` (clamped to ``[0, n - 1]``)."""
    return table_position(v, p) * (n - 1)


@helper_kernel
def _row(table, x):
    """Table row ``(r, g, b, sigma)`` interpolated at fractional index ``x``."""
    n = table.shape[0]
    i = min(int(x), n - 2)
    f = x - i
    return (table[i, 0] + f * (table[i + 1, 0] - table[i, 0]), table[i, 1] + f * (table[i + 1, 1] - table[i, 1]),
            table[i, 2] + f * (table[i + 1, 2] - table[i, 2]), table[i, 3] + f * (table[i + 1, 3] - table[i, 3]))


@helper_kernel
def _cumulative(table, s, x):
    """``int sigma ds`` and ``int c sigma ds`` (r, g, b) from the first knot to data value
    ``s`` (at fractional table index ``x``), then the colour (r, g, b) at ``s``."""
    n = table.shape[0]
    if s <= table[0, 8]:
        h = s - table[0, 8]
        sg = table[0, 3]
        return (h * sg, h * sg * table[0, 0], h * sg * table[0, 1], h * sg * table[0, 2],
                table[0, 0], table[0, 1], table[0, 2])
    if s >= table[n - 1, 8]:
        h = s - table[n - 1, 8]
        sg = table[n - 1, 3]
        return (table[n - 1, 4] + h * sg, table[n - 1, 5] + h * sg * table[n - 1, 0],
                table[n - 1, 6] + h * sg * table[n - 1, 1], table[n - 1, 7] + h * sg * table[n - 1, 2],
                table[n - 1, 0], table[n - 1, 1], table[n - 1, 2])
    i = min(int(x), n - 2)
    # the part of cell i from its knot to s: linear in s between the knot's row and s's row
    h = s - table[i, 8]
    r1, g1, b1, s1 = _row(table, x)
    s0 = table[i, 3]
    e0 = h * (s0 + 0.5 * s1) / 3.0  # weights of the product rule, see _piece
    e1 = h * (0.5 * s0 + s1) / 3.0
    return (table[i, 4] + 0.5 * h * (s0 + s1), table[i, 5] + e0 * table[i, 0] + e1 * r1,
            table[i, 6] + e0 * table[i, 1] + e1 * g1, table[i, 7] + e0 * table[i, 2] + e1 * b1, r1, g1, b1)


@kernel
def cumulative_tables(table):
    """Fill columns 4-7 of ``table`` (see ``TABLE_COLUMNS``): ``int sigma ds`` and
    ``int c sigma ds`` from knot 0 to knot i, exact for the rows' linear interpolation
    in the data value between knots."""
    table[0, 4] = 0.0
    table[0, 5] = 0.0
    table[0, 6] = 0.0
    table[0, 7] = 0.0
    for i in range(1, table.shape[0]):
        h = table[i, 8] - table[i - 1, 8]
        s0 = table[i - 1, 3]
        s1 = table[i, 3]
        e0 = h * (s0 + 0.5 * s1) / 3.0
        e1 = h * (0.5 * s0 + s1) / 3.0
        table[i, 4] = table[i - 1, 4] + 0.5 * h * (s0 + s1)
        table[i, 5] = table[i - 1, 5] + e0 * table[i - 1, 0] + e1 * table[i, 0]
        table[i, 6] = table[i - 1, 6] + e0 * table[i - 1, 1] + e1 * table[i, 1]
        table[i, 7] = table[i - 1, 7] + e0 * table[i - 1, 2] + e1 * table[i, 2]


@helper_kernel
def _piece(marker, prec, state, tau, er, eg, eb, dr, dg, db, lit):
    """Composite a piece of optical depth ``tau``, emission ``(er, eg, eb) = int c sigma dt``
    (the colour's mean ``E / tau``) and colour change front to back ``(dr, dg, db)``.

    The colour is taken as linear in optical depth across the piece: the emission is
    then ``a mean(c) + k (c_b - c_f)`` with ``a = 1 - e^-tau`` and
    ``k = (1 - e^-tau (1 + tau)) / tau - a / 2`` (the front is seen through less of the
    piece; exact for a constant extinction or a constant colour). ``k`` cancels for
    small ``tau``: its series is used below 0.01.

    ``lit = (mr, mg, mb, kr, kg, kb)`` lights the colour as ``m c + k`` per channel
    (``_shading_kernels.light_factors``: constant across a cell, so the lit emission
    is exactly ``m`` times the unlit one plus ``k`` times the opacity); ``(1, 1, 1, 0,
    0, 0)`` leaves it unchanged, bit for bit."""
    if not tau > 0.0:
        return state
    a = -math.expm1(-tau)
    inv = 1.0 / tau
    if tau < 0.01:
        k = tau * tau * (-1.0 / 12.0 + tau * (1.0 / 24.0 - tau / 80.0))
    else:
        k = (a - (1.0 - a) * tau) * inv - 0.5 * a
    k /= a
    return _accumulate(marker, prec, state, a, max(er * inv + k * dr, 0.0) * lit[0] + lit[3],
                       max(eg * inv + k * dg, 0.0) * lit[1] + lit[4], max(eb * inv + k * db, 0.0) * lit[2] + lit[5])


@helper_kernel
def _piece_linear(marker, prec, state, h, r0, g0, b0, a0, r1, g1, b1, a1, lit):
    """Composite a piece of length ``h`` along which colour and extinction go linearly
    from ``(r0, g0, b0, a0)`` to ``(r1, g1, b1, a1)``: exact optical depth, emission
    exact when the extinction or the colour is constant."""
    w0 = h * (a0 + 0.5 * a1) / 3.0
    w1 = h * (0.5 * a0 + a1) / 3.0
    return _piece(marker, prec, state, 0.5 * h * (a0 + a1), w0 * r0 + w1 * r1, w0 * g0 + w1 * g1, w0 * b0 + w1 * b1,
                  r1 - r0, g1 - g0, b1 - b0, lit)


@kernel
def _segment(marker, prec, state, table, s0, x0, s1, x1, c0_ok, c0, length, p, lit):
    """Composite the segment of world ``length`` along which the scalar goes linearly from
    ``s0`` to ``s1`` (fractional table indices ``x0``, ``x1``). ``c0`` is
    ``_cumulative`` at ``s0`` when ``c0_ok`` (the previous cell's exit). Returns the
    state, the number of pieces, and ``(ok, _cumulative)`` at ``s1`` for the next cell."""
    n = table.shape[0]
    i0 = min(int(x0), n - 2)
    i1 = min(int(x1), n - 2)
    inside0 = s0 >= table[0, 8] and s0 <= table[n - 1, 8]
    inside1 = s1 >= table[0, 8] and s1 <= table[n - 1, 8]
    if i0 == i1 and inside0 == inside1 and (inside0 or (s0 < table[0, 8]) == (s1 < table[0, 8])):
        # one table cell (or one constant end region): sigma and c are linear in t
        r0, g0, b0, a0 = _row(table, x0)
        r1, g1, b1, a1 = _row(table, x1)
        return _piece_linear(marker, prec, state, length, r0, g0, b0, a0, r1, g1, b1, a1, lit), 1, False, c0
    # a few table cells: walk them, one exact piece per cell (no cancellation)
    up = s1 > s0
    j_first = (0 if s0 < table[0, 8] else i0 + 1) if up else (n - 1 if s0 > table[n - 1, 8] else i0)
    j_last = (n - 1 if s1 > table[n - 1, 8] else i1) if up else (0 if s1 < table[0, 8] else i1 + 1)
    if abs(j_last - j_first) <= WALK_CELLS:
        scale = length / (s1 - s0)
        sa = s0
        ra, ga, ba, aa = _row(table, x0)
        pieces = 0
        j = max(j_first - 1, 0) if up else min(j_first + 1, n - 1)
        while True:
            if (up and j > j_last + 1) or (not up and j < j_last - 1) or j < 0 or j >= n:
                break
            sk = table[j, 8]
            if (up and sk > sa and sk < s1) or (not up and sk < sa and sk > s1):
                state = _piece_linear(marker, prec, state, (sk - sa) * scale, ra, ga, ba, aa,
                                      table[j, 0], table[j, 1], table[j, 2], table[j, 3], lit)
                pieces += 1
                sa = sk
                ra, ga, ba, aa = table[j, 0], table[j, 1], table[j, 2], table[j, 3]
            j = j + 1 if up else j - 1
        rb, gb, bb, ab = _row(table, x1)
        state = _piece_linear(marker, prec, state, (s1 - sa) * scale, ra, ga, ba, aa, rb, gb, bb, ab, lit)
        return state, pieces + 1, False, c0
    # many table cells: integrals from the cumulative tables, per unit of s
    scale = length / (s1 - s0)
    if not c0_ok:
        c0 = _cumulative(table, s0, x0)
    c1 = _cumulative(table, s1, x1)
    tau = (c1[0] - c0[0]) * scale
    pieces = 1
    if tau > p.tau_max:
        pieces = min(int(math.ceil(tau / p.tau_max)), p.max_pieces)
    if pieces == 1:
        return _piece(marker, prec, state, tau, (c1[1] - c0[1]) * scale, (c1[2] - c0[2]) * scale,
                      (c1[3] - c0[3]) * scale, c1[4] - c0[4], c1[5] - c0[5], c1[6] - c0[6], lit), 1, True, c1
    ca = c0
    for k in range(1, pieces + 1):
        sb = s0 + (s1 - s0) * (k / pieces) if k < pieces else s1
        cb = _cumulative(table, sb, _tpos(sb, n, p))
        state = _piece(marker, prec, state, (cb[0] - ca[0]) * scale, (cb[1] - ca[1]) * scale,
                       (cb[2] - ca[2]) * scale, (cb[3] - ca[3]) * scale, cb[4] - ca[4], cb[5] - ca[5],
                       cb[6] - ca[6], lit)
        ca = cb
        if _opacity(marker, state) >= p.alpha_stop:
            break
    return state, pieces, True, c1


# -- one ray -------------------------------------------------------------------------------
@helper_kernel
def _value_col(cells_f):
    """The float64 column of a record's first corner value: the last four are the values."""
    return cells_f.shape[1] - 4


@helper_kernel
def _corners(cells_i, cell, face, a, b, c):
    """Local indices in ``cell`` of the points ``a, b, c`` of its face ``face``. A point
    repeated in a degenerate cell is matched once; a corner left unmatched (only in a
    cell whose face lists repeated points) takes a free index."""
    ia = -1
    ib = -1
    ic = -1
    for k in range(4):
        if k == face:
            continue
        vk = cells_i[cell, CORNER_COL + k]
        if vk == a and ia < 0:
            ia = k
        elif vk == b and ib < 0:
            ib = k
        elif vk == c and ic < 0:
            ic = k
    if ia < 0 or ib < 0 or ic < 0:
        for k in range(4):
            if k == face or k == ia or k == ib or k == ic:
                continue
            if ia < 0:
                ia = k
            elif ib < 0:
                ib = k
            elif ic < 0:
                ic = k
    return ia, ib, ic


@helper_kernel
def _consistency(x, y, z):
    """How far the three products are from sharing a sign (larger: closer)."""
    return max(min(x, y, z), -max(x, y, z))


@kernel
def _march_in(marker, prec, points, cells_i, cells_f, active, btri, bcell, bface, table, grads, shading, lights,
              hit_t, hit_face, hit_enter, lo, hi, ox, oy, oz, dx, dy, dz, p, own0, own1, t_near, t_far):
    """Composite the ray through the mesh; ``(r, g, b, alpha, depth, cells, pieces, stopped)``.

    The ray composites ``[t_near, t_far]`` (the mesh's normalised frame; ``0, inf``:
    all of it): clipping planes and a crop box (``rays/clip.py``) and opaque geometry.
    It stops at ``t_far`` inside a cell, and starts at ``t_near`` inside one, with the
    scalar interpolated there (it is linear along the ray in a cell); cells before
    ``t_near`` are walked through, not composited.
    Only the cell segments whose midpoints lie in ``[own0, own1)`` are composited
    (``-inf, inf``: all): a piece of a distributed mesh renders the segments whose
    midpoints lie in the box it owns, each whole, with the arithmetic of the whole
    mesh's render; the walk ends once a segment starts at or past ``own1``.

    With ``p.shade``, each cell is lit by its gradient ``grads[cell]`` (world units)
    from the eye along the ray (``_shading_kernels``); else ``grads``, ``shading``,
    ``lights`` are placeholders and nothing is lit."""
    unlit = (1.0, 1.0, 1.0, 0.0, 0.0, 0.0)
    dl = math.sqrt(dx * dx + dy * dy + dz * dz)
    ex = -dx / dl
    ey = -dy / dl
    ez = -dz / dl
    mx = oy * dz - oz * dy
    my = oz * dx - ox * dz
    mz = ox * dy - oy * dx
    state = _start(marker)
    depth = math.inf
    t_cur = -math.inf
    cells = 0
    pieces = 0
    guard = False
    done = False
    no_cum = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    n_table = table.shape[0]
    value_col = _value_col(cells_f)
    for h in range(lo, hi):
        if done:
            break
        # entering faces already passed are skipped; one within rounding of the exit is
        # the next part of the mesh (a face on the far side of a non-conforming
        # interface, or of a crack, meets the ray where it left)
        if not hit_enter[h] or hit_t[h] < t_cur - REENTRY_SLACK * (1.0 + abs(t_cur)):
            continue
        if hit_t[h] >= t_far:
            break
        f = hit_face[h]
        cell = bcell[f]
        face = bface[f]
        a = btri[f, 0]
        b = btri[f, 1]
        c = btri[f, 2]
        # the products written out, not through _face_products: numba 0.56 takes
        # minutes longer to compile this loop with a nested inlined helper
        wab = _pi(points, a, b, dx, dy, dz, mx, my, mz, ox, oy, oz)
        wbc = _pi(points, b, c, dx, dy, dz, mx, my, mz, ox, oy, oz)
        wca = _pi(points, c, a, dx, dy, dz, mx, my, mz, ox, oy, oz)
        t_in, ua, ub, uc = _face_point(points, a, b, c, wab, wbc, wca, ox, oy, oz, dx, dy, dz)
        if t_in != t_in:
            continue
        # the scalar where the ray left the previous cell, its table index and cumulative
        # integrals: the next cell starts there (unless the field jumps across the face)
        s_prev = math.nan
        x_prev = 0.0
        c_ok = False
        c_prev = no_cum
        while True:
            cells += 1
            if cells > p.max_steps:
                guard = True
                done = True
                break
            # the entry face (a, b, c) and its edge products come from the previous cell
            # (or the boundary test): only the three edges to the fourth corner d are new
            ia, ib, ic = _corners(cells_i, cell, face, a, b, c)
            d = cells_i[cell, CORNER_COL + face]
            s_in = (ua * cells_f[cell, value_col + ia] + ub * cells_f[cell, value_col + ib]
                    + uc * cells_f[cell, value_col + ic])
            wad = _pi(points, a, d, dx, dy, dz, mx, my, mz, ox, oy, oz)
            wbd = _pi(points, b, d, dx, dy, dz, mx, my, mz, ox, oy, oz)
            wcd = _pi(points, c, d, dx, dy, dz, mx, my, mz, ox, oy, oz)
            # the exit is one of the faces (a, b, d), (b, c, d), (c, a, d), opposite c, a, b
            if _same_sign(wab, wbd, -wad):
                out = ic
            elif _same_sign(wbc, wcd, -wbd):
                out = ia
            elif _same_sign(wca, wad, -wcd):
                out = ib
            else:
                # rounding gave no consistent face (only next to a degenerate
                # configuration): take the least inconsistent one
                m0 = _consistency(wab, wbd, -wad)
                m1 = _consistency(wbc, wcd, -wbd)
                m2 = _consistency(wca, wad, -wcd)
                out = ic if m0 >= m1 and m0 >= m2 else (ia if m1 >= m2 else ib)
            # the exit face becomes (a, b, c) with its cyclic edge products
            if out == ic:
                a, b, c, ia, ib, ic, wab, wbc, wca = a, b, d, ia, ib, face, wab, wbd, -wad
            elif out == ia:
                a, b, c, ia, ib, ic, wab, wbc, wca = b, c, d, ib, ic, face, wbc, wcd, -wbd
            else:
                a, b, c, ia, ib, ic, wab, wbc, wca = c, a, d, ic, ia, face, wca, wad, -wcd
            t_out, ua, ub, uc = _face_point(points, a, b, c, wab, wbc, wca, ox, oy, oz, dx, dy, dz)
            if not t_out > t_in:  # NaN (ray in the face's plane) or rounding: no length
                t_out = t_in
            clipped = t_out > t_far
            if t_in >= own1:  # every segment from here on is another piece's
                done = True
                break
            t_start = max(t_in, t_near)
            t_mid = 0.5 * (t_start + min(t_out, t_far))
            if active[cell] and min(t_out, t_far) > t_start and t_mid >= own0 and t_mid < own1:
                s_out = (ua * cells_f[cell, value_col + ia] + ub * cells_f[cell, value_col + ib]
                         + uc * cells_f[cell, value_col + ic])
                if t_start > t_in:  # the clip's near end cuts this cell: start there
                    s_cut = s_in + (s_out - s_in) * ((t_start - t_in) / (t_out - t_in))
                    if clipped:
                        s_out = s_in + (s_out - s_in) * ((t_far - t_in) / (t_out - t_in))
                        t_out = t_far
                    s_in = s_cut
                    t_in = t_start
                elif clipped:
                    s_out = s_in + (s_out - s_in) * ((t_far - t_in) / (t_out - t_in))
                    t_out = t_far
                same = s_in == s_prev
                x_in = x_prev if same else _tpos(s_in, n_table, p)
                x_out = _tpos(s_out, n_table, p)
                lit = unlit
                if p.shade:
                    gx = grads[cell, 0]
                    gy = grads[cell, 1]
                    gz = grads[cell, 2]
                    w = fade_weight(math.sqrt(gx * gx + gy * gy + gz * gz), 0.5 * (s_in + s_out), p.scale,
                                    p.axis_inv_range, p.linthresh, shading[SH_FADE])
                    lit = light_factors(gx, gy, gz, ex, ey, ez, w, shading, lights)
                state, np_, c_ok, c_prev = _segment(marker, prec, state, table, s_in, x_in, s_out, x_out,
                                                    c_ok and same, c_prev, (t_out - t_in) * p.length_scale, p, lit)
                s_prev = s_out
                x_prev = x_out
                pieces += np_
                alpha = _opacity(marker, state)
                if depth == math.inf and alpha >= p.depth_alpha:
                    depth = 0.5 * (t_in + t_out) * p.length_scale
                if alpha >= p.alpha_stop:
                    done = True
                    break
            if clipped:
                done = True
                break
            t_in = t_out
            code = cells_i[cell, NEIGHBOR_COL + out]
            if code < 0:
                t_cur = t_out
                break
            face = code & 3
            cell = code >> 2
    r, g_, b_, alpha = _finish(marker, state)
    return r, g_, b_, alpha, depth, cells, pieces, guard


@kernel
def _march(marker, points, cells_i, cells_f, active, btri, bcell, bface, table, grads, shading, lights, hit_t,
           hit_face, hit_enter, lo, hi, ox, oy, oz, dx, dy, dz, p, own0, own1, t_near, t_far):
    """One ray in the precision of ``marker`` (a float64, float32 or int64 zero: see
    ``_kernels._marker_precision``): only that compositing loop is compiled."""
    return _march_in(marker, _marker_precision(marker, p), points, cells_i, cells_f, active, btri, bcell, bface,
                     table, grads, shading, lights, hit_t, hit_face, hit_enter, lo, hi, ox, oy, oz, dx, dy, dz, p,
                     own0, own1, t_near, t_far)


@parallel_kernel
def render_tiles(marker, points, cells_i, cells_f, active, btri, bcell, bface, table, grads, shading, lights,
                 hit_offsets, hit_t, hit_face, hit_enter, cam, own, span, width, height, tile, tile_rows, lanes,
                 p, out_rgba, out_depth, out_cells, out_pieces, out_guard):
    """Fill the pixels of the tiles in the rows of tiles ``tile_rows`` (as the grid's
    ``_kernels.render_tiles``: one lane of interleaved tiles per thread). ``span``: as
    there (``[near, far]`` per pixel, world distances; empty: ``[0, inf]``); ``own`` (pixels x 2, world distances;
    empty: everything) the span of each ray whose segments this render composites
    (``_march_in``); a pixel whose span is empty is skipped."""
    has_span = span.shape[0] > 0
    has_own = own.shape[0] > 0
    for lane in numba.prange(lanes):
        for i in range(lane_pixels(lane, lanes, tile_rows, tile, width)):
            pix = lane_pixel(i, lane, lanes, tile_rows, tile, width, height)
            if pix < 0:
                continue
            lo = hit_offsets[pix]
            hi = hit_offsets[pix + 1]
            if hi == lo or (has_own and not own[pix, 1] > own[pix, 0]) \
                    or (has_span and not span[pix, 1] > span[pix, 0]):
                continue
            ox, oy, oz, dx, dy, dz = pixel_ray(cam, pix % width, pix // width, width, height)
            r, g, b, a, dep, nc, npc, guard = _march(
                marker, points, cells_i, cells_f, active, btri, bcell, bface, table, grads, shading, lights,
                hit_t, hit_face, hit_enter, lo, hi, ox, oy, oz, dx, dy, dz, p,
                own[pix, 0] / p.length_scale if has_own else -math.inf,
                own[pix, 1] / p.length_scale if has_own else math.inf,
                span[pix, 0] / p.length_scale if has_span else 0.0,
                span[pix, 1] / p.length_scale if has_span else math.inf)
            store_pixel(out_rgba, out_depth, out_cells, pix, r, g, b, a, dep, nc)
            out_pieces[pix] = npc
            out_guard[pix] = guard
