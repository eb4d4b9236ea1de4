"""How far SIMD could take the grid ray caster in numba: an experiment, not a kernel.

The float32 target of issue 2 (half the time of ``vtkFixedPointVolumeRayCastMapper``)
asks for about twice the speed of the scalar loop in ``raycast/_kernels.py``, which
is as fast as the fixed-point mapper. This script measures the two routes to it:

1. **Ray packets.** ``W`` rays of one image row march in lock step, one event (a sample
   or an empty-space leap) per ray and iteration, in five loops over the lanes:
   positions and cells, the loads (leap radius, brick offsets, the eight corners),
   trilinear interpolation and table position, the table loads, then compositing
   (float32 with compensated sums, as the kernel) and the next lattice index. ``W``
   is a run-time argument, so LLVM's loop vectoriser takes the loops (a constant
   width is unrolled first, and numba leaves the SLP vectoriser off). The samples
   are the kernel's (linear axis, the shortened last segment left out); it reports
   the frame time against the kernel's in the same process, and how many lanes were
   busy per iteration.
2. **Gathers.** LLVM emits no gather instruction from numba loops on this CPU, so the
   packet loops load lane by lane. ``llvm.masked.gather`` called through a numba
   intrinsic does emit ``vgatherqpd``: the script times it against scalar loads of the
   same random indices (8 lanes, float64, a table in L1 and one in L2), which bounds
   what any hand-vectorised kernel can gain, since a sample makes about 20 loads.

    python3 benchmarks/simd_ceiling.py                       # engine, 256^2, one thread
    python3 benchmarks/simd_ceiling.py --data bonsai --size 512 --width 8 16 --tf opaque

Needs ../shared/data (or $PV_HDRVOL_DATA). The gather part needs an llvmlite with
opaque pointers (LLVM 15 or later, numba 0.57 or later); it is skipped elsewhere.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_grid import DATASETS, STEP, data_dir, load, read_vti, transfer_functions  # noqa: E402

# float fields of the lane scratch F[field * W + lane]; int fields of I[...]
T0, NF, BX, BY, BZ, SX, SY, SZ, OX, OY, OZ, RX, RY, RZ, KK, FX, FY, FZ, VV, DEP = range(20)
XI, YI, ZI, IB, JB, KB, BI, RAD, TI, NS, LIVE, STOP = range(12)


def packet_kernel():
    """The packet kernel, compiled on first use (not cached: an experiment)."""
    from pv_hdrvol._jit import FUSED_JIT_OPTIONS
    from pv_hdrvol.raycast import _kernels as K

    @numba.njit(**dict(FUSED_JIT_OPTIONS, cache=False))
    def render_packets(bricks, offs, table, leap, grids, dims, cam, width, height, lo, hi, p, W,
                       out_rgba, out_depth, out_samples, counts):
        step = p.step
        nx, ny, nz = dims[0], dims[1], dims[2]
        x_max, y_max, z_max = nx - 1.0, ny - 1.0, nz - 1.0
        shift = p.block_shift
        by, bx = grids[1], grids[2]
        size = 1 << shift
        n_table = table.shape[0] // 4
        oy_off, oz_off = np.uint64(nx), np.uint64(nx + ny)
        one, p1, p2 = np.uint64(1), np.uint64(9), np.uint64(81)
        F = np.empty(20 * W)
        I = np.empty(12 * W, np.int64)
        V = np.empty(8 * W, bricks.dtype)
        TR = np.empty(8 * W, table.dtype)
        S = np.empty(8 * W, np.float32)  # r, g, b, a and their compensations
        pix = np.empty(W, np.int64)
        for row in range(height):
            for col0 in range(0, width, W):
                for l in range(W):  # set-up, as _march
                    col = min(col0 + l, width - 1)
                    pix[l] = row * width + col
                    ox, oy, oz, dx, dy, dz = K.voxel_ray(cam, col, row, width, height)
                    t0, t1 = K._ray_box(ox, oy, oz, dx, dy, dz, lo, hi)
                    F[T0 * W + l] = t0
                    F[OX * W + l], F[OY * W + l], F[OZ * W + l] = ox, oy, oz
                    F[RX * W + l] = 1.0 / dx if dx != 0.0 else 0.0
                    F[RY * W + l] = 1.0 / dy if dy != 0.0 else 0.0
                    F[RZ * W + l] = 1.0 / dz if dz != 0.0 else 0.0
                    F[NF * W + l] = max(math.ceil((t1 - t0) / step), 1.0) - 1.0 if t1 > t0 else 0.0
                    a, b, c, d, e, f = K.midpoint_lattice(ox, oy, oz, dx, dy, dz, t0, step)
                    F[BX * W + l], F[BY * W + l], F[BZ * W + l] = a, b, c
                    F[SX * W + l], F[SY * W + l], F[SZ * W + l] = d, e, f
                    F[KK * W + l] = 0.0
                    F[DEP * W + l] = math.inf
                    for s in range(8):
                        S[s * W + l] = np.float32(0.0)
                    I[NS * W + l] = 0
                    I[STOP * W + l] = 0
                while True:
                    busy = 0
                    for l in range(W):
                        b_ = (F[KK * W + l] < F[NF * W + l]) & (I[STOP * W + l] == 0)
                        I[LIVE * W + l] = b_
                        busy += b_
                    if busy == 0:
                        break
                    counts[0] += 1
                    counts[1] += busy
                    for l in range(W):  # 1: positions, cells, blocks
                        kf = F[KK * W + l]
                        x = min(max(F[BX * W + l] + kf * F[SX * W + l], 0.0), x_max)
                        y = min(max(F[BY * W + l] + kf * F[SY * W + l], 0.0), y_max)
                        z = min(max(F[BZ * W + l] + kf * F[SZ * W + l], 0.0), z_max)
                        xi, yi, zi = int(x), int(y), int(z)
                        I[XI * W + l], I[YI * W + l], I[ZI * W + l] = xi, yi, zi
                        F[FX * W + l], F[FY * W + l], F[FZ * W + l] = x - xi, y - yi, z - zi
                        ib = min(xi, nx - 2) >> shift
                        jb = min(yi, ny - 2) >> shift
                        kb = min(zi, nz - 2) >> shift
                        I[IB * W + l], I[JB * W + l], I[KB * W + l] = ib, jb, kb
                        I[BI * W + l] = (kb * by + jb) * bx + ib
                    for l in range(W):  # 2: the loads, lane by lane
                        I[RAD * W + l] = leap[np.uint64(I[BI * W + l])]
                        q = np.uint64(offs[np.uint64(I[XI * W + l])] + offs[oy_off + np.uint64(I[YI * W + l])]
                                      + offs[oz_off + np.uint64(I[ZI * W + l])])
                        V[l], V[W + l] = bricks[q], bricks[q + one]
                        V[2 * W + l], V[3 * W + l] = bricks[q + p1], bricks[q + p1 + one]
                        V[4 * W + l], V[5 * W + l] = bricks[q + p2], bricks[q + p2 + one]
                        V[6 * W + l], V[7 * W + l] = bricks[q + p2 + p1], bricks[q + p2 + p1 + one]
                    for l in range(W):  # 3: trilinear, table position (linear axis)
                        fx, fy, fz = F[FX * W + l], F[FY * W + l], F[FZ * W + l]
                        v000, v100 = np.float64(V[l]), np.float64(V[W + l])
                        v010, v110 = np.float64(V[2 * W + l]), np.float64(V[3 * W + l])
                        v001, v101 = np.float64(V[4 * W + l]), np.float64(V[5 * W + l])
                        v011, v111 = np.float64(V[6 * W + l]), np.float64(V[7 * W + l])
                        c00 = v000 + fx * (v100 - v000)
                        c10 = v010 + fx * (v110 - v010)
                        c01 = v001 + fx * (v101 - v001)
                        c11 = v011 + fx * (v111 - v011)
                        c0 = c00 + fy * (c10 - c00)
                        c1 = c01 + fy * (c11 - c01)
                        v = c0 + fz * (c1 - c0)
                        u = min(max((v - p.axis_lo) * p.axis_inv_range, 0.0), 1.0)
                        xx = u * (n_table - 1)
                        i = min(int(xx), n_table - 2)
                        I[TI * W + l] = i
                        F[FX * W + l] = xx - i
                        F[VV * W + l] = v
                    for l in range(W):  # 4: the table rows, lane by lane
                        qq = np.uint64(4 * I[TI * W + l])
                        for c in range(8):
                            TR[c * W + l] = table[qq + np.uint64(c)]
                    for l in range(W):  # 5: composite, depth, termination, next index
                        ft = np.float32(F[FX * W + l])
                        r = TR[l] + ft * (TR[4 * W + l] - TR[l])
                        g = TR[W + l] + ft * (TR[5 * W + l] - TR[W + l])
                        b = TR[2 * W + l] + ft * (TR[6 * W + l] - TR[2 * W + l])
                        a_i = TR[3 * W + l] + ft * (TR[7 * W + l] - TR[3 * W + l])
                        v = F[VV * W + l]
                        kf = F[KK * W + l]
                        live = I[LIVE * W + l] != 0
                        radius = I[RAD * W + l]
                        sampled = live & (radius == 0) & (v == v)
                        comp = sampled & (a_i > 0.0)
                        sr, sg, sb, sa = S[l], S[W + l], S[2 * W + l], S[3 * W + l]
                        er, eg, eb, ea = S[4 * W + l], S[5 * W + l], S[6 * W + l], S[7 * W + l]
                        w = (np.float32(1.0) - sa) * a_i
                        xr = w * r - er
                        tr = sr + xr
                        xg = w * g - eg
                        tg = sg + xg
                        xb = w * b - eb
                        tb = sb + xb
                        xa = w - ea
                        ta = sa + xa
                        S[l], S[4 * W + l] = (tr, (tr - sr) - xr) if comp else (sr, er)
                        S[W + l], S[5 * W + l] = (tg, (tg - sg) - xg) if comp else (sg, eg)
                        S[2 * W + l], S[6 * W + l] = (tb, (tb - sb) - xb) if comp else (sb, eb)
                        S[3 * W + l], S[7 * W + l] = (ta, (ta - sa) - xa) if comp else (sa, ea)
                        alpha = np.float64(ta)
                        dp = F[DEP * W + l]
                        hit = comp & (dp == math.inf) & (alpha >= p.depth_alpha)
                        F[DEP * W + l] = F[T0 * W + l] + (kf + 0.5) * step if hit else dp
                        I[STOP * W + l] = 1 if comp & (alpha >= p.alpha_stop) else I[STOP * W + l]
                        I[NS * W + l] += 1 if sampled else 0
                        rx, ry, rz = F[RX * W + l], F[RY * W + l], F[RZ * W + l]
                        ex = (I[IB * W + l] + radius) * size if rx > 0.0 else (I[IB * W + l] - radius + 1) * size
                        ey = (I[JB * W + l] + radius) * size if ry > 0.0 else (I[JB * W + l] - radius + 1) * size
                        ez = (I[KB * W + l] + radius) * size if rz > 0.0 else (I[KB * W + l] - radius + 1) * size
                        tex = (ex - F[OX * W + l]) * rx if rx != 0.0 else math.inf
                        tey = (ey - F[OY * W + l]) * ry if ry != 0.0 else math.inf
                        tez = (ez - F[OZ * W + l]) * rz if rz != 0.0 else math.inf
                        kn = math.ceil((min(min(tex, tey), tez) - F[T0 * W + l]) / step - 0.5)
                        leapt = kn if kn > kf else kf + 1.0
                        F[KK * W + l] = (leapt if radius != 0 else kf + 1.0) if live else kf
                for l in range(W):
                    q = pix[l]
                    for c in range(4):
                        out_rgba[q, c] = S[c * W + l]
                    out_depth[q] = F[DEP * W + l]
                    out_samples[q] = I[NS * W + l]

    return render_packets


def kernel_arguments(hv, volume, tf, camera, size):
    """The production kernel's arguments for one render (recorded by a wrapper), and its image."""
    from pv_hdrvol.raycast import _kernels as K

    seen = {}
    real = K.render_tiles

    def spy(*args):
        seen["args"] = args
        return real(*args)

    K.render_tiles = spy
    try:
        image = hv.render(volume, tf, camera, size, precision="float32", step=STEP, progress_bar=False)
    finally:
        K.render_tiles = real
    return seen["args"], image


def packets(args):
    import pv_hdrvol as hv

    numba.set_num_threads(1)
    volume = hv.volume_from_dataset(read_vti(data_dir() / DATASETS[args.data]))
    camera = hv.Camera.fit(volume.bounds, "iso")
    size = (args.size, args.size)
    kernel = packet_kernel()
    print(f"{args.data} {args.size}^2, one thread, float32, step {STEP} voxel; load {load()}")
    print("| TF | W | kernel ms | packets ms | packets / kernel | busy lanes | samples kernel | samples packets |")
    print("|---|--:|--:|--:|--:|--:|--:|--:|")
    for tf_name in args.tf:
        tf = transfer_functions(hv)[tf_name]
        kargs, image = kernel_arguments(hv, volume, tf, camera, size)
        bricks, offs, table, _sigma, leap, grids, dims, cam = kargs[1:9]  # kargs[0]: the precision marker
        width, height, lo, hi, p = kargs[11], kargs[12], kargs[16], kargs[17], kargs[18]
        assert p.scale == 0 and p.precision == 1, "the packet kernel knows the linear axis and float32 only"
        for w in args.width:
            n = width * height
            rgba, depth, samples = np.zeros((n, 4), np.float32), np.full(n, np.inf), np.zeros(n, np.int64)
            counts = np.zeros(2, np.int64)

            def run():
                counts[:] = 0
                kernel(bricks, offs, table, leap, grids, dims, cam, width, height, lo, hi, p, w, rgba, depth,
                       samples, counts)

            run()  # compiles
            ours, theirs = [], []
            for _ in range(args.frames):
                t = time.perf_counter()
                run()
                ours.append(time.perf_counter() - t)
                t = time.perf_counter()
                hv.render(volume, tf, camera, size, precision="float32", step=STEP, progress_bar=False)
                theirs.append(time.perf_counter() - t)
            a, b = min(theirs) * 1e3, min(ours) * 1e3
            print(f"| {tf_name} | {w} | {a:.1f} | {b:.1f} | {b / a:.2f} | {counts[1] / (counts[0] * w):.2f} | "
                  f"{image.metadata['samples']:,} | {int(samples.sum()):,} |", flush=True)


def gather_intrinsic():
    """``gather8(values, index, at)``: the sum of ``values[index[at:at + 8]]``, loaded by
    one ``llvm.masked.gather`` (``None`` where llvmlite has typed pointers)."""
    from llvmlite import ir
    from numba import types
    from numba.extending import intrinsic

    if numba.version_info[:2] < (0, 57):
        return None

    @intrinsic
    def gather8(typingctx, values, index, at):
        def codegen(context, builder, signature, args):
            data = context.make_array(signature.args[0])(context, builder, args[0]).data
            idx = context.make_array(signature.args[1])(context, builder, args[1]).data
            i64, f64, i32 = ir.IntType(64), ir.DoubleType(), ir.IntType(32)
            vi, vd = ir.VectorType(i64, 8), ir.VectorType(f64, 8)
            lanes = builder.load(builder.bitcast(builder.gep(idx, [args[2]]), vi.as_pointer()), align=8)
            base = builder.insert_element(ir.Constant(vi, ir.Undefined), builder.ptrtoint(data, i64),
                                          ir.Constant(i32, 0))
            base = builder.shuffle_vector(base, ir.Constant(vi, ir.Undefined),
                                          ir.Constant(ir.VectorType(i32, 8), [0] * 8))
            ptrs = builder.inttoptr(builder.add(base, builder.mul(lanes, ir.Constant(vi, [8] * 8))),
                                    ir.VectorType(data.type, 8))
            mask = ir.Constant(ir.VectorType(ir.IntType(1), 8), [1] * 8)
            fnty = ir.FunctionType(vd, [ptrs.type, i32, mask.type, vd])
            name = "llvm.masked.gather.v8f64.v8p0"
            fn = builder.module.globals.get(name) or ir.Function(builder.module, fnty, name=name)
            got = builder.call(fn, [ptrs, ir.Constant(i32, 8), mask, ir.Constant(vd, [0.0] * 8)])
            total = builder.extract_element(got, ir.Constant(i32, 0))
            for k in range(1, 8):
                total = builder.fadd(total, builder.extract_element(got, ir.Constant(i32, k)))
            return total

        return types.float64(values, index, at), codegen

    return gather8


def gathers(args):
    gather8 = gather_intrinsic()
    if gather8 is None:
        print("gathers: skipped (llvmlite with typed pointers)")
        return

    @numba.njit
    def by_gather(values, index, rounds):
        s = 0.0
        for _ in range(rounds):
            for at in range(0, index.shape[0], 8):
                s += gather8(values, index, at)
        return s

    @numba.njit
    def by_scalar(values, index, rounds):
        s = 0.0
        for _ in range(rounds):
            for at in range(0, index.shape[0], 8):
                t = 0.0
                for k in range(8):
                    t += values[index[at + k]]
                s += t
        return s

    rng = np.random.default_rng(0)
    print(f"\nLoads of random float64 entries, 8 per step (one thread; load {load()}):")
    print("| table | gather ns/entry | scalar ns/entry | vgather in code |")
    print("|---|--:|--:|--:|")
    for label, n in (("32 KiB (L1)", 1 << 12), ("1 MiB (L2)", 1 << 17)):
        values = rng.random(n)
        index = rng.integers(0, n, 1 << 14).astype(np.int64)
        assert by_gather(values, index, 1) == by_scalar(values, index, 1)
        asm = by_gather.inspect_asm(by_gather.signatures[0])
        rounds = 2000
        best = {}
        for fn in (by_gather, by_scalar) * 3:
            t = time.perf_counter()
            fn(values, index, rounds)
            dt = (time.perf_counter() - t) / (rounds * index.shape[0]) * 1e9
            best[fn] = min(best.get(fn, math.inf), dt)
        print(f"| {label} | {best[by_gather]:.2f} | {best[by_scalar]:.2f} | {asm.count('vgather')} |")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", choices=sorted(DATASETS), default="engine")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--tf", nargs="+", default=["transparent", "opaque"], choices=["transparent", "opaque"])
    ap.add_argument("--width", type=int, nargs="+", default=[8, 16], help="rays per packet")
    ap.add_argument("--frames", type=int, default=5)
    args = ap.parse_args(argv)
    print(f"numba {numba.__version__}, {os.cpu_count()} CPUs")
    packets(args)
    gathers(args)


if __name__ == "__main__":
    main()
