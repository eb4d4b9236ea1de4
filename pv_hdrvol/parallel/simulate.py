"""Scaling beyond this machine by simulation (../shared/notes/methods.md A.6.3).

:func:`measure` renders each visible block alone on one core (as a rank does) and
records its time and screen rectangle; :func:`simulate` deals the blocks to ``P``
ranks along a curve, splits the image into ``P`` tiles and models

    T(P) = max_r [cull_r + sum of its visible blocks' times + send_r]
           + max_r composite_r + gather

with ``send_r = messages * latency + bytes / bandwidth`` (direct send of each partial
image to every other tile it overlaps), ``composite_r`` proportional to the pixels
received, and ``gather`` the tiles' bytes to rank 0. Culling per rank costs the
measured time per tested block times the blocks overlapping its tile; the visible set
itself does not depend on ``P`` (the union over tiles is the image's).
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .composite import clip, composite, tile_grid
from .distribute import assign

#: Interconnects: (latency s, bandwidth bytes/s). "myrinet": the paper's era (2003).
NETWORKS = {"myrinet": (10e-6, 200e6), "modern": (2e-6, 10e9)}


@dataclass
class BlockCosts:
    """Per-block measurements of one view (flat z-y-x block indices)."""

    shape: tuple
    size: tuple
    visible: np.ndarray  # bool (blocks,)
    seconds: np.ndarray  # float (blocks,): render time of the block alone (0 where not visible)
    samples: np.ndarray  # int (blocks,)
    rects: dict  # block -> (col, row, w, h)
    test_seconds: float  # culling time per candidate block
    candidates: np.ndarray  # bool (blocks,): blocks the culling tests (non-empty)
    pixel_seconds: float  # compositing time per received pixel
    bytes_per_pixel: int


def measure(volume, tf, camera, size, *, pof=None, block_size=16, repeat=1, **options):
    """Render every visible block of one view alone and time it (the serial block-wise
    render: ``render_parallel(comm=None)``'s work)."""
    from ..culling.cull import visible_blocks
    from ..culling.pof import nonempty_blocks
    from ..data.transfer import TransferFunctionFamily
    from ..raycast.grid import GridPlan, block_grid_shape, as_volume
    from .render import block_partials

    volume = as_volume(volume)
    plan = GridPlan(volume, tf, **options)
    shape = block_grid_shape(volume.dims, block_size)
    t = time.perf_counter()
    if pof is not None:
        result = visible_blocks(pof, volume, camera, size, getattr(plan.tf, "k", None))
        visible, candidates = result.visible.reshape(-1), result.nonempty.reshape(-1)
        test_seconds = (time.perf_counter() - t) / max(1, int(candidates.sum()))
    else:
        family = plan.tf if isinstance(plan.tf, TransferFunctionFamily) else TransferFunctionFamily([plan.tf])
        sigma = family.basis_tables(1.0, 1.0) * family.k[:, None]
        candidates = nonempty_blocks(np.asarray(volume.values, float), shape, block_size, sigma, family).any(-1).reshape(-1)
        visible, test_seconds = candidates.copy(), 0.0
    n = visible.size
    seconds, samples, rects = np.zeros(n), np.zeros(n, dtype=np.int64), {}
    blocks = np.nonzero(visible)[0]
    best = np.full(n, np.inf)
    for _ in range(repeat):
        generator = block_partials(plan, volume, camera, size, block_size, blocks)
        while True:
            t = time.perf_counter()
            try:
                b, rect, part = next(generator)
            except StopIteration:
                break
            best[b] = min(best[b], time.perf_counter() - t)
            rects[b], samples[b] = rect, part.metadata["samples"]
    seconds[np.isfinite(best)] = best[np.isfinite(best)]
    dtype = np.float64 if plan.options.precision == "float64" else np.float32
    pixel_seconds = _pixel_seconds(dtype)
    return BlockCosts(shape, tuple(size), visible, seconds, samples, rects, test_seconds, candidates, pixel_seconds,
                      4 * np.dtype(dtype).itemsize)


def _pixel_seconds(dtype, n=64, side=64):
    """Compositing time per pixel, measured on ``n`` overlapping partial images."""
    rng = np.random.default_rng(0)
    pieces = [(i, (0, 0, side, side), (rng.random((side, side, 4)) * 0.1).astype(dtype)) for i in range(n)]
    t = time.perf_counter()
    composite((0, 0, side, side), pieces, dtype)
    return (time.perf_counter() - t) / (n * side * side)


def simulate(costs, ranks, curve="hilbert", network="modern"):
    """Modelled time, balance and messages for each rank count in ``ranks``.

    Returns a list of dicts: ``ranks``, ``time`` (s), ``speedup`` (against the model at
    one rank), ``efficiency``, ``blocks_min/mean/max`` (visible blocks per rank),
    ``imbalance`` (largest render load over the mean), ``messages`` and ``bytes``
    (largest per rank), and the critical path's parts.
    """
    latency, bandwidth = NETWORKS[network] if isinstance(network, str) else network
    width, height = costs.size
    rects = costs.rects
    rows = []
    for p in ranks:
        owner = assign(costs.shape, p, curve).reshape(-1)
        tiles = tile_grid(p, width, height)
        render = np.zeros(p)
        count = np.zeros(p, dtype=np.int64)
        msgs = np.zeros(p, dtype=np.int64)
        sent = np.zeros(p)
        received = np.zeros(p)
        tested = np.zeros(p)
        for b, rect in rects.items():
            r = owner[b]
            render[r] += costs.seconds[b]
            count[r] += 1
            for t, tile in enumerate(tiles):
                part = clip(rect, tile)
                if part is None:
                    continue
                pixels = part[2] * part[3]
                received[t] += pixels
                if t != r:
                    msgs[r] += 1
                    sent[r] += pixels * costs.bytes_per_pixel
        for b in np.nonzero(costs.candidates)[0]:
            rect = rects.get(b)
            for t, tile in enumerate(tiles):
                if rect is None or clip(rect, tile) is not None:
                    tested[t] += 1
        cull = tested * costs.test_seconds
        send = msgs * latency + sent / bandwidth
        comp = received * costs.pixel_seconds
        gather = (p - 1) * latency + (width * height - tiles[0][2] * tiles[0][3]) * costs.bytes_per_pixel / bandwidth
        stage1 = cull + render + send
        total = float(stage1.max() + comp.max() + gather)
        mean = render.mean()
        rows.append({"ranks": p, "time": total, "cull": float(cull[stage1.argmax()]),
                     "render": float(render[stage1.argmax()]), "send": float(send[stage1.argmax()]),
                     "composite": float(comp.max()), "gather": gather, "blocks_min": int(count.min()),
                     "blocks_mean": float(count.mean()), "blocks_max": int(count.max()),
                     "imbalance": float(render.max() / mean) if mean > 0 else 1.0,
                     "messages": int(msgs.max()), "bytes": float(sent.max())})
    base = rows[0]["time"] if rows and rows[0]["ranks"] == 1 else simulate(costs, [1], curve, network)[0]["time"]
    for row in rows:
        row["speedup"] = base / row["time"]
        row["efficiency"] = row["speedup"] / row["ranks"]
    return rows
