"""Classification and compositing of a ray's samples, chosen by the type of a marker.

Every grid ray runs one loop (``_kernels._march_plain``); what it does with its
samples is the compositor the type of its ``marker`` names, at compile time, so each
render compiles only its own:

- a float64 zero: emission-absorption in float64;
- a float32 zero: the same in float32 arithmetic with compensated (Kahan) sums;
- an int64 zero: the conventional ``over`` operator in an emulated float16 or uint8
  buffer (``p.precision`` says which);
- an :class:`Extreme`: a maximum or minimum projection, the extreme of the samples at
  the lattice points ``t0 + k step`` and the exit;
- an :class:`Integral`: an average or additive (X-ray) projection, the midpoint rule
  over the segments.

A compositor is ``_start`` (its empty state), ``_take`` or ``_accumulate`` (one
sample), ``_opacity`` and ``_result`` (the pixel). ``ways_of`` (the marker as a
projection or as a compositing, the other ``None``) tells the loop which of the two ways
a sample goes, and
``lattice_at``/``sample_t``/``exit_t``/``lattice_end`` where a projection's samples lie;
numba prunes the other way before typing it. Classification (``table_position``,
``table_row``, ``sigma_at``) lives here too: both kinds of compositor read the transfer
function.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from .._jit import (
    FUSED_JIT_OPTIONS as _FUSED_JIT, JIT_OPTIONS as _JIT, compiled_only, fused_kernel, inline_kernel, kernel,
    stub_overload, uindex as _u,
)

# precision codes (params.PRECISION_CODES)
F64, F32, F16, U8 = 0, 1, 2, 3
# transfer-function axis codes (data/transfer.SCALE_CODES)
LINEAR, LOG, SYMLOG = 0, 1, 2
# blending codes (params.BLENDING_CODES)
COMPOSITE, MAXIMUM, MINIMUM, AVERAGE, ADDITIVE = 0, 1, 2, 3, 4


# -- rounding that emulates a buffer's precision ---------------------------------------
@kernel
def round_half(x):
    """Round a float64 to the nearest IEEE half value (ties to even), as float64."""
    if x == 0.0 or x != x:
        return x
    ax = abs(x)
    if ax >= 65520.0:  # rounds to infinity in half
        return math.copysign(math.inf, x)
    m, e = math.frexp(ax)  # ax = m * 2**e, 0.5 <= m < 1
    ex = e - 1
    if ex < -14:
        ex = -14  # subnormal range: fixed quantum 2**-24
    q = math.ldexp(1.0, ex - 10)
    r = ax / q
    f = math.floor(r)
    d = r - f
    if d > 0.5 or (d == 0.5 and (f - 2.0 * math.floor(0.5 * f)) == 1.0):
        f += 1.0
    return math.copysign(f * q, x)


@kernel
def round_u8(x):
    """Round to the nearest multiple of 1/255 in [0, 1], as an 8-bit buffer stores it."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    return math.floor(x * 255.0 + 0.5) / 255.0


@inline_kernel
def _round(x, precision):
    """Round to what an emulated ``float16`` or ``uint8`` buffer stores (else unchanged)."""
    if precision == F16:
        return round_half(x)
    if precision == U8:
        return round_u8(x)
    return x


@inline_kernel
def _kahan_add32(total, comp, x):
    """Compensated float32 ``total + x``: returns the new total and compensation."""
    y = x - comp
    t = total + y
    return t, (t - total) - y


# -- classification ---------------------------------------------------------------------
@inline_kernel
def table_position(v, p):
    """Position in [0, 1] of data value ``v`` on the table's axis (float64)."""
    if p.scale == LOG:
        if v > 0.0:
            a = math.log10(v)
        else:
            return 0.0
    elif p.scale == SYMLOG:
        a = math.copysign(math.log10(1.0 + abs(v) / p.linthresh), v)
    else:
        a = v
    u = (a - p.axis_lo) * p.axis_inv_range
    if u < 0.0:
        return 0.0
    if u > 1.0:
        return 1.0
    return u


@inline_kernel
def table_row(table, base, n, u, u8):
    """Interpolated row ``(r, g, b, a)`` at axis position ``u`` (``table_position``) of
    the ``n``-row table starting at ``table[base]`` (flat, 4 values per row), and its
    entry ``i`` and fraction ``f``. ``u8``: the nearest of the rows, no interpolation
    (the 8-bit pipeline). The lerp is in the table's precision (float32 tables: no
    conversions). Inlined, so it takes the caller's flags: every compositing loop that
    must give the same bits is a ``fused_kernel``."""
    if u8:
        # the row itself: at u = 1 it is the last, and a lerp would read the row past it
        i = int(u * (n - 1) + 0.5)
        q = _u(base + 4 * i)
        return table[q], table[q + _u(1)], table[q + _u(2)], table[q + _u(3)], i, 0.0
    x = u * (n - 1)
    i = int(x)
    if i > n - 2:
        i = n - 2
    f = x - i
    q = _u(base + 4 * i)
    ft = table.dtype.type(f)
    r = table[q] + ft * (table[q + _u(4)] - table[q])
    g = table[q + _u(1)] + ft * (table[q + _u(5)] - table[q + _u(1)])
    b = table[q + _u(2)] + ft * (table[q + _u(6)] - table[q + _u(2)])
    a = table[q + _u(3)] + ft * (table[q + _u(7)] - table[q + _u(3)])
    return r, g, b, a, i, f


@fused_kernel
def _lookup(table, v, n, p):
    """Interpolated table row ``(r, g, b, a)`` of data value ``v``, and its entry and fraction."""
    return table_row(table, 0, n, table_position(v, p), p.precision == U8)


@fused_kernel
def sigma_at(sigma, i, f):
    """Extinction between entries ``i`` and ``i + 1`` of ``sigma`` at fraction ``f`` (float64).
    ``f = 0`` reads entry ``i`` alone: the 8-bit lookup gives the last entry that way."""
    s0 = np.float64(sigma[_u(i)])
    if f == 0.0:
        return s0
    return s0 + f * (np.float64(sigma[_u(i + 1)]) - s0)


# -- compositing: start / accumulate / finish, one implementation per precision -----------
# Chosen at compile time by the type of a marker argument (float64, float32, or an int for
# the emulations), so each precision's loop carries only its own accumulators: a single
# loop with a runtime branch kept all twelve live and spilled them to the stack on every
# sample. (numba's IR inlining would also specialise, but numba 0.56 takes minutes to
# deep-copy the IR of a loop this size.)
@compiled_only
def _start(marker):
    """Empty compositing state for the precision ``marker`` stands for (compiled only)."""
    raise NotImplementedError("compiled only")


@compiled_only
def _accumulate(marker, prec, state, a_i, r, g, b):
    """Add one sample (opacity ``a_i``, colour ``r, g, b``) behind ``state`` (compiled only)."""
    raise NotImplementedError("compiled only")


@compiled_only
def _opacity(marker, state):
    """Accumulated opacity of ``state``, float64 (compiled only)."""
    raise NotImplementedError("compiled only")


@compiled_only
def _finish(marker, state):
    """``(r, g, b, alpha)`` of ``state`` as float64 (compiled only)."""
    raise NotImplementedError("compiled only")


def _is_f32(marker):
    return isinstance(marker, numba.types.Float) and marker.bitwidth == 32


@stub_overload(_start, jit_options=_FUSED_JIT)
def _start_impl(marker):
    if _kind(marker) == "extreme":
        return lambda marker: (-math.inf, math.inf)  # the extreme (times its sign) and where
    if _kind(marker) == "integral":
        # int v dt, the valid length, optical depth, emission (r, g, b), first sample's t
        return lambda marker: (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, math.inf)
    if _is_f32(marker):
        def start32(marker):
            z = np.float32(0.0)
            return z, z, z, z, z, z, z, z  # r, g, b, alpha, then their Kahan compensations
        return start32

    def start64(marker):
        return 0.0, 0.0, 0.0, 0.0
    return start64


@stub_overload(_accumulate, jit_options=_FUSED_JIT)
def _accumulate_impl(marker, prec, state, a_i, r, g, b):
    if _is_f32(marker):
        def accumulate32(marker, prec, state, a_i, r, g, b):
            # float32 arithmetic throughout, with compensated sums
            r32, g32, b32, a32, er, eg, eb, ea = state
            w = (np.float32(1.0) - a32) * np.float32(a_i)
            r32, er = _kahan_add32(r32, er, w * np.float32(r))
            g32, eg = _kahan_add32(g32, eg, w * np.float32(g))
            b32, eb = _kahan_add32(b32, eb, w * np.float32(b))
            a32, ea = _kahan_add32(a32, ea, w)
            return r32, g32, b32, a32, er, eg, eb, ea
        return accumulate32
    if isinstance(marker, numba.types.Float):
        def accumulate64(marker, prec, state, a_i, r, g, b):
            # plain float64 sums are accurate to ~n eps
            cr, cg, cb, alpha = state
            w = (1.0 - alpha) * a_i
            return cr + w * r, cg + w * g, cb + w * b, alpha + w
        return accumulate64

    def accumulate_emulated(marker, prec, state, a_i, r, g, b):
        # the conventional `over` operator in a half-float or 8-bit buffer
        cr, cg, cb, alpha = state
        a = _round(np.float64(a_i), prec)
        rest = _round(1.0 - alpha, prec)
        cr = _round(cr + _round(rest * _round(a * r, prec), prec), prec)
        cg = _round(cg + _round(rest * _round(a * g, prec), prec), prec)
        cb = _round(cb + _round(rest * _round(a * b, prec), prec), prec)
        return cr, cg, cb, _round(alpha + _round(rest * a, prec), prec)
    return accumulate_emulated


@stub_overload(_opacity, jit_options=_FUSED_JIT)
def _opacity_impl(marker, state):
    def opacity(marker, state):
        return np.float64(state[3])
    return opacity


@stub_overload(_finish, jit_options=_FUSED_JIT)
def _finish_impl(marker, state):
    def finish(marker, state):
        return np.float64(state[0]), np.float64(state[1]), np.float64(state[2]), np.float64(state[3])
    return finish


@compiled_only
def _marker_precision(marker, p):
    """The precision code of a compositing marker (compiled only): float64 and float32
    markers name their precision at compile time; an integer marker leaves it to
    ``p.precision`` (float16 or uint8, which share one emulated loop)."""
    raise NotImplementedError("compiled only")


@stub_overload(_marker_precision, jit_options=_JIT, inline="always")
def _marker_precision_impl(marker, p):
    if marker == numba.types.float64:
        return lambda marker, p: F64
    if marker == numba.types.float32:
        return lambda marker, p: F32
    return lambda marker, p: p.precision


# -- projections: compositors of one value per ray --------------------------------------------
class Extreme(NamedTuple):
    """The compositor of a maximum (``sign`` 1) or minimum (``sign`` -1) projection.

    It takes the extreme of the samples at the lattice points ``t0 + k step`` and at the
    exit ``t1`` (so on a view along an axis through grid points it sees every grid value
    exactly); its colour and opacity are the transfer function's at that value over
    ``unit``, the opacity unit distance; depth is where it was first met. The ray stops
    once it reaches ``stop`` (the data's extreme; ``inf``: never).
    """

    sign: float
    stop: float
    unit: float


class Integral(NamedTuple):
    """The compositor of an average (``additive`` 0) or additive (1) projection: the
    midpoint rule over the segments. Additive gives ``int v dt`` (world units) and the
    emission ``int c(v) sigma(v) dt`` with opacity ``1 - exp(-int sigma dt)``, no
    absorption of the colour (an X-ray); average gives ``int v dt / L`` over the length
    ``L`` of the valid (non-NaN) samples, coloured as :class:`Extreme` over ``unit``.
    Depth is the first valid sample's."""

    additive: int
    unit: float


def projection_marker(mode, unit, stop):
    """The marker of the projection ``mode`` (a blending code), opacity unit distance
    ``unit`` and stopping value ``stop`` (``Extreme.stop``; sign included)."""
    if mode == MAXIMUM or mode == MINIMUM:
        return Extreme(1.0 if mode == MAXIMUM else -1.0, float(stop), float(unit))
    if mode == AVERAGE or mode == ADDITIVE:
        return Integral(int(mode == ADDITIVE), float(unit))
    raise ValueError(f"blending code {mode!r} is not a projection's: expected one of "
                     f"{[MAXIMUM, MINIMUM, AVERAGE, ADDITIVE]} (params.BLENDING_CODES)")


def _kind(marker):
    """``"extreme"``, ``"integral"`` or ``None`` (a compositing precision) for a numba type."""
    cls = getattr(marker, "instance_class", None)
    return "extreme" if cls is Extreme else "integral" if cls is Integral else None


@compiled_only
def ways_of(marker):
    """``(proj, comp)``: ``(marker, None)`` if ``marker`` names a projection, ``(None,
    marker)`` if a compositing precision (compiled only).

    The loop takes both as arguments and branches on ``is not None``: numba prunes a
    branch on an argument that is ``None`` before typing it (and only then: a
    constant-valued call, or an argument of another type, is typed and lowered both
    ways). So a composite compiles no projection code and a projection no compositing."""
    raise NotImplementedError("compiled only")


@stub_overload(ways_of, jit_options=_FUSED_JIT)
def _ways_of_impl(marker):
    if _kind(marker) is None:
        return lambda marker: (None, marker)
    return lambda marker: (marker, None)


@compiled_only
def lattice_at(marker, b, s, o, d, t0, kf, step):
    """Coordinate of sample ``kf`` on one axis (compiled only): the midpoint ``b + kf s``
    (``_kernels.midpoint_lattice``) for compositing and integrals; the lattice point
    ``o + (t0 + kf step) d`` for an extreme."""
    raise NotImplementedError("compiled only")


@stub_overload(lattice_at, jit_options=_FUSED_JIT, inline="always")
def _lattice_at_impl(marker, b, s, o, d, t0, kf, step):
    if _kind(marker) == "extreme":
        return lambda marker, b, s, o, d, t0, kf, step: o + (t0 + kf * step) * d
    return lambda marker, b, s, o, d, t0, kf, step: b + kf * s


@compiled_only
def sample_t(marker, t0, kk, step):
    """The ``t`` of full segment ``kk``'s sample (compiled only): its midpoint
    ``t0 + (kk + 1/2) step``, or its lattice point ``t0 + kk step`` for an extreme."""
    raise NotImplementedError("compiled only")


@stub_overload(sample_t, jit_options=_FUSED_JIT, inline="always")
def _sample_t_impl(marker, t0, kk, step):
    if _kind(marker) == "extreme":
        return lambda marker, t0, kk, step: t0 + kk * step
    return lambda marker, t0, kk, step: t0 + (kk + 0.5) * step


@compiled_only
def exit_t(marker, ta, t1):
    """Where the last, shortened segment ``[ta, t1]`` is sampled (compiled only): its
    midpoint, or the exit ``t1`` for an extreme."""
    raise NotImplementedError("compiled only")


@stub_overload(exit_t, jit_options=_FUSED_JIT, inline="always")
def _exit_t_impl(marker, ta, t1):
    if _kind(marker) == "extreme":
        return lambda marker, ta, t1: t1
    return lambda marker, ta, t1: 0.5 * (ta + t1)


@compiled_only
def lattice_end(marker, k1, last):
    """The end of the full segments' indices (compiled only): ``k1``; an extreme also
    samples the lattice point that starts the last segment (``k1 + 1`` if ``last``)."""
    raise NotImplementedError("compiled only")


@stub_overload(lattice_end, jit_options=_FUSED_JIT, inline="always")
def _lattice_end_impl(marker, k1, last):
    if _kind(marker) == "extreme":
        return lambda marker, k1, last: k1 + 1 if last else k1
    return lambda marker, k1, last: k1


@compiled_only
def _take(marker, state, v, t, dt, table, sigma, n_table, p):
    """A projection's ``(state, done)`` after the valid sample ``v`` at ``t`` standing
    for the length ``dt`` (compiled only; a compositing marker returns ``state``)."""
    raise NotImplementedError("compiled only")


@stub_overload(_take, jit_options=_FUSED_JIT)
def _take_impl(marker, state, v, t, dt, table, sigma, n_table, p):
    kind = _kind(marker)
    if kind == "extreme":
        def extreme(marker, state, v, t, dt, table, sigma, n_table, p):
            best, t_best = state
            sv = marker.sign * v
            if sv > best:
                return (sv, t), sv >= marker.stop
            return (best, t_best), False
        return extreme
    if kind == "integral":
        def integral(marker, state, v, t, dt, table, sigma, n_table, p):
            total, length, tau, er, eg, eb, t_first = state
            if t_first == math.inf:
                t_first = t
            total += v * dt
            length += dt
            if marker.additive:
                r, g, b, a, i, f = table_row(table, 0, n_table, table_position(v, p), p.precision == U8)
                sd = sigma_at(sigma, i, f) * dt
                tau += sd
                er += r * sd
                eg += g * sd
                eb += b * sd
            return (total, length, tau, er, eg, eb, t_first), False
        return integral

    def compositing(marker, state, v, t, dt, table, sigma, n_table, p):  # never compiled: pruned
        return state, False
    return compositing


@compiled_only
def _result(marker, state, depth, samples, table, sigma, n_table, p):
    """The ray's ``(r, g, b, alpha, depth, samples, value)`` (compiled only): a
    compositing precision's colour (``value`` NaN), or a projection's value, colour
    and depth (all NaN-valued, transparent and at infinity without a valid sample)."""
    raise NotImplementedError("compiled only")


@stub_overload(_result, jit_options=_FUSED_JIT)
def _result_impl(marker, state, depth, samples, table, sigma, n_table, p):
    kind = _kind(marker)
    if kind is None:
        def composited(marker, state, depth, samples, table, sigma, n_table, p):
            cr, cg, cb, alpha = _finish(marker, state)
            return cr, cg, cb, alpha, depth, samples, math.nan
        return composited
    if kind == "extreme":
        def extreme(marker, state, depth, samples, table, sigma, n_table, p):
            if samples == 0:
                return 0.0, 0.0, 0.0, 0.0, math.inf, 0, math.nan
            best, t = state
            return _coloured(marker.sign * best, t, samples, marker.unit, table, sigma, n_table, p)
        return extreme

    def integral(marker, state, depth, samples, table, sigma, n_table, p):
        if samples == 0:
            return 0.0, 0.0, 0.0, 0.0, math.inf, 0, math.nan
        total, length, tau, er, eg, eb, t = state
        if marker.additive:  # the integrated emission, its opacity from the optical depth
            return er, eg, eb, -math.expm1(-tau), t, samples, total
        return _coloured(total / length, t, samples, marker.unit, table, sigma, n_table, p)
    return integral


@inline_kernel
def _coloured(value, t, samples, unit, table, sigma, n_table, p):
    """A projection's pixel: the transfer function's colour at ``value``, its opacity
    over the distance ``unit``, premultiplied."""
    r, g, b, a, i, f = table_row(table, 0, n_table, table_position(value, p), p.precision == U8)
    alpha = -math.expm1(-sigma_at(sigma, i, f) * unit)
    return alpha * r, alpha * g, alpha * b, alpha, t, samples, value
