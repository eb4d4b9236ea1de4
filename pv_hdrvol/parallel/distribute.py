"""Static block distribution along space-filling curves (Gao et al. 2003, section 4.1).

Blocks are ordered along a curve and dealt round-robin: ``rank = position mod P``.
The curve keeps neighbours together, so a contiguous visible region spreads evenly
over the ranks. Keys are computed on the padded ``2^m`` cube and absent blocks skipped.
"""
from __future__ import annotations

import numpy as np

from .._validate import as_choice, as_int

CURVES = ("hilbert", "z", "contiguous", "random")


def _bits(shape):
    return max(1, int(np.ceil(np.log2(max(max(shape), 2)))))


def morton_keys(shape):
    """(bz, by, bx) int64 Z-order (Morton) keys of the blocks, x the lowest bit."""
    m = _bits(shape)
    kz, ky, kx = np.meshgrid(*(np.arange(n, dtype=np.int64) for n in shape), indexing="ij")
    key = np.zeros(shape, dtype=np.int64)
    for b in range(m):
        key |= ((kx >> b) & 1) << (3 * b) | ((ky >> b) & 1) << (3 * b + 1) | ((kz >> b) & 1) << (3 * b + 2)
    return key


def hilbert_keys(shape):
    """(bz, by, bx) int64 positions of the blocks along a 3-D Hilbert curve (Skilling's
    transpose algorithm, vectorised): consecutive keys are face neighbours."""
    m = _bits(shape)
    kz, ky, kx = np.meshgrid(*(np.arange(n, dtype=np.int64) for n in shape), indexing="ij")
    x = [kx.reshape(-1).copy(), ky.reshape(-1).copy(), kz.reshape(-1).copy()]
    n = 3
    top = np.int64(1) << (m - 1)
    # inverse undo of excess work (Skilling 2004, "Programming the Hilbert curve")
    q = top
    while q > 1:
        p = q - 1
        for i in range(n):
            hit = (x[i] & q) != 0
            x[0] = np.where(hit, x[0] ^ p, x[0])
            t = np.where(hit, 0, (x[0] ^ x[i]) & p)
            x[0] ^= t
            x[i] ^= t
        q >>= 1
    for i in range(1, n):  # Gray encode
        x[i] ^= x[i - 1]
    t = np.zeros_like(x[0])
    q = top
    while q > 1:
        t = np.where((x[n - 1] & q) != 0, t ^ (q - 1), t)
        q >>= 1
    for i in range(n):
        x[i] ^= t
    # interleave the transposed bits: the most significant bit of x[0] first
    key = np.zeros_like(x[0])
    for b in range(m - 1, -1, -1):
        for i in range(n):
            key = (key << 1) | ((x[i] >> b) & 1)
    return key.reshape(shape)


def curve_order(shape, curve="hilbert", seed=0):
    """Flat block indices (z-y-x order of ``shape``) along ``curve``."""
    as_choice("curve", curve, CURVES)
    n = int(np.prod(shape))
    if curve == "contiguous":
        return np.arange(n)
    if curve == "random":
        return np.random.default_rng(seed).permutation(n)
    keys = hilbert_keys(shape) if curve == "hilbert" else morton_keys(shape)
    return np.argsort(keys.reshape(-1), kind="stable")


def assign(shape, n_ranks, curve="hilbert", *, seed=0, chunk=1):
    """(bz, by, bx) int owner rank of every block: blocks along ``curve`` dealt
    round-robin in runs of ``chunk`` (``"contiguous"``: ``P`` equal runs in memory order)."""
    n_ranks = as_int("n_ranks", n_ranks, low=1)
    chunk = as_int("chunk", chunk, low=1)
    order = curve_order(shape, curve, seed)
    owner = np.empty(order.size, dtype=np.int64)
    if curve == "contiguous":
        owner[order] = np.arange(order.size) * n_ranks // order.size
    else:
        owner[order] = (np.arange(order.size) // chunk) % n_ranks
    return owner.reshape(shape)
