"""Plenoptic opacity functions: per block, the smallest opacity it shows over its
screen footprint, for 36 x 36 sampled view directions and each basis of a
transfer-function family (Gao, Huang, Shen, Kohl, IEEE Visualization 2003).

``PlenopticOpacity.compute`` precomputes them once per volume and basis set;
``block_opacity`` turns them into a lower bound on each block's opacity for any view
and any weights ``k`` of the family, which the culling pass composites front to back.
"""
from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .._validate import as_choice, as_int, as_real
from ..data.transfer import SCALE_CODES, TransferFunction, TransferFunctionFamily, table_entry_span
from . import _kernels as K

#: The paper's view sampling: 36 azimuths theta_i = i 10 deg and 36 polar angles
#: phi_j = (j + 1/2) 5 deg (cell-centred: no duplicate views at the poles).
N_THETA = 36
N_PHI = 36
#: Layout version of saved files.
FILE_VERSION = 1
_MONOMIALS = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3))


def view_angles():
    """``(theta, phi)`` in radians of the sample views, shapes (36,) and (36,)."""
    theta = np.arange(N_THETA) * (2 * np.pi / N_THETA)
    phi = (np.arange(N_PHI) + 0.5) * (np.pi / N_PHI)
    return theta, phi


def direction(theta, phi):
    """Unit view direction(s) of spherical angles (phi from +z, theta from +x)."""
    theta, phi = np.broadcast_arrays(np.asarray(theta, dtype=np.float64), np.asarray(phi, dtype=np.float64))
    return np.stack([np.sin(phi) * np.cos(theta), np.sin(phi) * np.sin(theta), np.cos(phi)], axis=-1)


def angles_of(d):
    """``(theta, phi)`` of unit direction ``d``: theta in [0, 2 pi), phi in [0, pi]."""
    d = np.asarray(d, dtype=np.float64)
    d = d / np.linalg.norm(d)
    theta = math.atan2(d[1], d[0]) % (2 * math.pi)
    return theta, math.acos(min(1.0, max(-1.0, d[2])))


def view_frames(directions):
    """(V, 9) direction, right, up of orthographic views along ``directions`` (V, 3)."""
    d = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    ref = np.where(np.abs(d[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    right = np.cross(d, ref)
    right /= np.linalg.norm(right, axis=1, keepdims=True)
    up = np.cross(right, d)
    return np.ascontiguousarray(np.hstack([d, right, up]))


def _poly_design(theta, phi):
    """Monomials of the normalised angles ``u = theta / pi - 1``, ``w = 2 phi / pi - 1``."""
    u = np.asarray(theta, dtype=np.float64) / np.pi - 1.0
    w = 2.0 * np.asarray(phi, dtype=np.float64) / np.pi - 1.0
    return np.stack([u**a * w**b for a, b in _MONOMIALS], axis=-1)


def spike_filter(table):
    """``min(table, median_3x3(table))`` over (theta, phi), theta periodic, phi edges
    replicated: removes upward spikes and never raises a value (stays a lower bound).
    ``table`` (..., 36, 36) with theta on the second-last axis."""
    t = np.asarray(table)
    padded = np.concatenate([t[..., -1:, :], t, t[..., :1, :]], axis=-2)
    padded = np.concatenate([padded[..., :, :1], padded, padded[..., :, -1:]], axis=-1)
    n0, n1 = t.shape[-2], t.shape[-1]
    stack = np.stack([padded[..., i:i + n0, j:j + n1] for i in range(3) for j in range(3)], axis=0)
    return np.minimum(t, np.median(stack, axis=0))


def fit_polynomial(table):
    """Cubic polynomials in (theta, phi) shifted below ``table`` at every sample view.

    ``table`` (..., 36, 36) float opacities. Returns float32 coefficients (..., 10) of the
    monomials ``1, u, w, u^2, uw, w^2, u^3, u^2 w, u w^2, w^3`` whose evaluation (in
    float64, from the float32 coefficients) is <= the table at all 1,296 views: the least-
    squares fit moved down by its largest excess (the paper's shift).
    """
    theta, phi = view_angles()
    design = _poly_design(theta[:, None], phi[None, :]).reshape(-1, 10)
    flat = np.asarray(table, dtype=np.float64).reshape(-1, N_THETA * N_PHI)
    coef, *_ = np.linalg.lstsq(design, flat.T, rcond=None)
    coef = coef.T.astype(np.float32)
    for _ in range(4):  # float32 rounding of the shift itself: repeat until below
        excess = (coef.astype(np.float64) @ design.T - flat).max(axis=1)
        if not np.any(excess > 0):
            break
        shift = np.maximum(excess, 0.0).astype(np.float32)
        coef[:, 0] = np.nextafter(coef[:, 0] - shift, np.float32(-np.inf)) * (excess > 0) + coef[:, 0] * (excess <= 0)
    return coef.reshape(np.shape(table)[:-2] + (10,))


def _as_bases(bases):
    if isinstance(bases, TransferFunctionFamily):
        return list(bases.bases)
    if isinstance(bases, TransferFunction):
        return [bases]
    if isinstance(bases, (str, bytes)) or not hasattr(bases, "__len__") or len(bases) == 0:
        raise TypeError(f"bases must be a TransferFunction, a family or a non-empty sequence of them; got {bases!r}")
    return list(TransferFunctionFamily(bases).bases)


class PlenopticOpacity:
    """Per-block, per-view minimum opacities of each basis of a transfer-function family.

    Attributes
    ----------
    table : ndarray, uint8, shape (bz, by, bx, p, 36, 36)
        ``floor(255 a)`` of the minimum opacity ``a`` (one unit of optical depth per the
        bases' extinction, ``global_alpha = 1``) over the block's footprint, after the
        spike filter: decoded ``q / 255`` it is a lower bound.
    poly : ndarray, float32, shape (bz, by, bx, p, 10)
        The shifted cubic polynomials (``fit_polynomial``).
    nonempty : ndarray, bool, shape (bz, by, bx, p)
        Whether the block's value range meets a non-zero extinction of the basis.
    sets : ndarray, uint8, shape (bz, by, bx, p, p, 36, 36), or None
        The paper's "POF sets" (``compute(..., sets=True)``): ``sets[..., i, j, :, :]``
        is ``floor(255 a)`` of basis ``j``'s opacity at the pixel where basis ``i`` has
        its minimum (the diagonal is ``table``). ``p**2`` tables per block.
    block_size, shape, spacing, pitch, step, chord_min
        How they were computed (block edge in cells, volume points (x, y, z), ...).
    """

    def __init__(self, table, poly, nonempty, *, block_size, dims, spacing, pitch, step, chord_min, bases,
                 footprint="chord", sets=None):
        self.table, self.poly, self.nonempty, self.sets = table, poly, nonempty, sets
        self.block_size = int(block_size)
        self.dims = tuple(int(n) for n in dims)
        self.spacing = np.asarray(spacing, dtype=np.float64)
        self.pitch, self.step, self.chord_min = float(pitch), float(step), float(chord_min)
        self.bases = list(bases)
        self.footprint = footprint

    @property
    def grid_shape(self):
        """Blocks along (z, y, x)."""
        return self.table.shape[:3]

    @property
    def n_bases(self):
        return self.table.shape[3]

    # -- precomputation ---------------------------------------------------------------
    @classmethod
    def compute(cls, volume, bases, *, block_size=16, pitch=1.0, step=1.0, chord_min=1.0, footprint="chord",
                sets=False, threads=None, progress_bar=False):
        """Precompute the POFs of ``volume`` (a :class:`~pv_hdrvol.GridVolume`, array or
        image dataset) for ``bases`` (TransferFunctions, or a family's bases).

        ``pitch`` (pixel size of the precompute's orthographic images), ``step`` (ray
        step) and ``chord_min`` (footprint pixels must cross the block over at least this
        length) are in voxels of the smallest spacing. Blocks are computed in parallel
        on ``threads`` threads (default: the machine's cores); each is independent, so
        the result does not depend on the thread count.

        ``footprint="chord"`` (default): the minimum over every footprint pixel, zeros
        included (conservative). ``"nonempty_pixels"``: over the pixels where the basis
        is not 0, the paper's Fig. 1 caption read literally; NOT conservative (a
        half-empty block gets its full half's opacity over its whole footprint), for
        measuring what the paper's numbers may rest on.

        ``sets=True`` also keeps the paper's POF sets (``p**2`` tables per block, the
        ``method="sets"`` of :meth:`block_opacity`); they cost no extra rendering.
        """
        from ..raycast.grid import block_grid_shape, as_volume

        volume = as_volume(volume)
        bases = _as_bases(bases)
        block_size = as_int("block_size", block_size, low=2, high=256)
        if block_size & (block_size - 1):
            raise ValueError(f"block_size must be a power of two; got {block_size}")
        unit = float(np.min(volume.spacing))
        pitch = as_real("pitch", pitch, low=0, low_open=True) * unit
        step = as_real("step", step, low=0, low_open=True) * unit
        chord_min = as_real("chord_min", chord_min, low=0, low_open=True) * unit
        threads = (os.cpu_count() or 1) if threads is None else as_int("threads", threads, low=1)
        skip_empty_pixels = as_choice("footprint", footprint, ("chord", "nonempty_pixels")) == "nonempty_pixels"
        family = TransferFunctionFamily(bases)
        size = family.table_size
        # extinction per world unit at the family's entries; opacities are per voxel of
        # the smallest spacing, as the renderer's default opacity_unit_distance
        sigma = np.ascontiguousarray(family.basis_tables(1.0, unit, size))
        a0, a1 = family.axis_range
        scale = SCALE_CODES[family.scale]
        axis_inv = 1.0 / (a1 - a0) if a1 > a0 else 0.0
        values = np.ascontiguousarray(volume.values, dtype=np.float64)
        dims = volume.dims
        shape = block_grid_shape(dims, block_size)
        nonempty = nonempty_blocks(values, shape, block_size, sigma, family)
        theta, phi = view_angles()
        frames = view_frames(direction(theta[:, None], phi[None, :]).reshape(-1, 3))
        p = len(bases)
        depth = np.full(shape + (p, N_THETA * N_PHI), np.inf)
        keep_sets = bool(sets)
        # uint8 per block as it is computed: p**2 float tables of a large volume would not fit
        set_table = np.zeros(shape + (p, p, N_THETA * N_PHI), dtype=np.uint8) if keep_sets else None
        todo = [b for b in np.ndindex(*shape) if nonempty[b].any()]
        spacing = np.asarray(volume.spacing, dtype=np.float64)

        def one(b):
            kz, ky, kx = b
            lo = np.array([kx, ky, kz], dtype=np.int64) * block_size
            hi = np.minimum(lo + block_size, np.array(dims) - 1)
            out = np.empty((frames.shape[0], p))
            out_sets = np.empty((frames.shape[0], p, p))
            K.block_min_depth(values, spacing, sigma, scale, float(family.linthresh), float(a0), axis_inv, lo, hi,
                              frames, pitch, step, chord_min, skip_empty_pixels, out, out_sets)
            depth[b] = out.T
            if keep_sets:  # inf (no qualifying pixel) counts as 0, as for the table
                alpha_sets = np.where(np.isfinite(out_sets), -np.expm1(-out_sets), 0.0)
                set_table[b] = np.floor(alpha_sets * 255.0).astype(np.uint8).transpose(1, 2, 0)

        bar = None
        if progress_bar:
            from tqdm.auto import tqdm

            bar = tqdm(total=len(todo), desc="POF blocks", unit="block")
        with ThreadPoolExecutor(max_workers=threads) as pool:
            for _ in pool.map(one, todo):
                if bar is not None:
                    bar.update()
        if bar is not None:
            bar.close()
        # inf (no qualifying pixel: a tiny block, or no non-empty pixel) counts as 0
        alpha = np.where(np.isfinite(depth), -np.expm1(-depth), 0.0)
        alpha[~nonempty] = 0.0
        alpha = spike_filter(alpha.reshape(shape + (p, N_THETA, N_PHI)))
        table = np.floor(alpha * 255.0).astype(np.uint8)
        poly = fit_polynomial(alpha)
        if keep_sets:
            set_table = set_table.reshape(shape + (p, p, N_THETA, N_PHI))
            for i in range(p):
                set_table[..., i, i, :, :] = table[..., i, :, :]
        return cls(table, poly, nonempty, block_size=block_size, dims=dims, spacing=volume.spacing,
                   pitch=pitch / unit, step=step / unit, chord_min=chord_min / unit, bases=bases, footprint=footprint,
                   sets=set_table)

    # -- run time ----------------------------------------------------------------------
    @staticmethod
    def _sample_views(d):
        """The four sample views around unit direction ``d``: ``(i0, i1, j0, j1, ft, fp)``,
        theta indices, phi indices and the fractions between them."""
        theta, phi = angles_of(d)
        ti = theta / (2 * np.pi / N_THETA)
        pj = min(max(phi / (np.pi / N_PHI) - 0.5, 0.0), N_PHI - 1.0)
        i0 = int(math.floor(ti)) % N_THETA
        j0 = min(int(math.floor(pj)), N_PHI - 2)
        return i0, (i0 + 1) % N_THETA, j0, j0 + 1, ti - math.floor(ti), pj - j0

    def _looked_up(self, t, d, lookup, combine):
        """``combine`` (uint8 views -> float opacities) of table ``t`` (..., 36, 36) at
        the sample views around ``d``: the smallest of the four (``min4``), the nearest,
        or ``combine`` of the bilinear blend."""
        i0, i1, j0, j1, ft, fp = self._sample_views(d)
        if lookup == "nearest":
            return combine(np.asarray(t[..., (i0 if ft < 0.5 else i1), (j0 if fp < 0.5 else j1)], dtype=np.float64))
        corners = [np.asarray(t[..., i, j], dtype=np.float64) for i, j in ((i0, j0), (i1, j0), (i0, j1), (i1, j1))]
        if lookup == "min4":
            values = [combine(c) for c in corners]
            return np.minimum(np.minimum(values[0], values[1]), np.minimum(values[2], values[3]))
        return combine((1 - ft) * (1 - fp) * corners[0] + ft * (1 - fp) * corners[1] + (1 - ft) * fp * corners[2]
                       + ft * fp * corners[3])

    def view_minimum(self, d, *, encoding="table", lookup="min4"):
        """(bz, by, bx, p) float64 POF values for the unit view direction ``d``.

        ``lookup``: ``"min4"`` (default) the smallest of the four sample views around
        ``d``; ``"nearest"``; ``"bilinear"`` (the paper's, not conservative between views).
        ``encoding``: ``"table"`` or ``"poly"`` (the polynomial, clamped to [0, 1]).
        """
        as_choice("encoding", encoding, ("table", "poly"))
        as_choice("lookup", lookup, ("min4", "nearest", "bilinear"))
        if encoding == "poly":
            x = _poly_design(*angles_of(d))
            return np.clip(self.poly.astype(np.float64) @ x, 0.0, 1.0)
        return self._looked_up(self.table, d, lookup, lambda q: q / 255.0)

    def block_opacity(self, d, k=None, *, encoding="table", lookup="min4", method="conservative"):
        """(bz, by, bx) each block's opacity under the family with weights ``k``.

        ``method="conservative"`` (default): ``1 - prod_i (1 - POF_i)^{k_i}``, a lower
        bound (the paper's conservative method). ``"sets"``: the paper's POF sets,
        ``min_i [1 - prod_j (1 - POF_ij)^{k_j}]``, the family's opacity at each basis's
        minimising pixel. Before rounding it is never below the true minimum over the
        footprint at a sample view (each candidate is a real pixel), so it is NOT a lower
        bound: faster culling, no guarantee (needs ``compute(..., sets=True)`` and the
        table encoding).
        """
        k = np.ones(self.n_bases) if k is None else np.asarray(k, dtype=np.float64).reshape(-1)
        if k.shape != (self.n_bases,) or not np.all(np.isfinite(k)) or np.any(k < 0):
            raise ValueError(f"k must be {self.n_bases} finite weights >= 0; got {k.tolist()}")
        as_choice("method", method, ("conservative", "sets"))
        if method == "conservative":
            return _family_opacity(self.view_minimum(d, encoding=encoding, lookup=lookup), k)
        if self.sets is None:
            raise ValueError("method='sets' needs POF sets: PlenopticOpacity.compute(..., sets=True)")
        as_choice("encoding", encoding, ("table",))
        as_choice("lookup", lookup, ("min4", "nearest", "bilinear"))
        return self._looked_up(self.sets, d, lookup, lambda q: _family_opacity(q / 255.0, k).min(axis=-1))

    def mask_for(self, volume, tf, camera, size, options, render_shape):
        """What ``render(..., cull=pof)`` calls: :meth:`Culling.mask_for` with the defaults."""
        from .cull import Culling

        return Culling(self).mask_for(volume, tf, camera, size, options, render_shape)

    # -- files -------------------------------------------------------------------------
    def save(self, path):
        """Write an ``.npz`` file (tables, polynomials, how they were computed, the bases)."""
        import json

        meta = {"version": FILE_VERSION, "block_size": self.block_size, "dims": list(self.dims),
                "spacing": self.spacing.tolist(), "pitch": self.pitch, "step": self.step, "chord_min": self.chord_min,
                "footprint": self.footprint,
                "bases": [b.to_dict() for b in self.bases]}
        extra = {} if self.sets is None else {"sets": self.sets}
        np.savez_compressed(path, table=self.table, poly=self.poly, nonempty=self.nonempty,
                            meta=np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8), **extra)

    @classmethod
    def load(cls, path):
        """Read a file written by :meth:`save`.

        Raises
        ------
        FileNotFoundError
            No file at ``path``.
        ValueError
            The file is not one :meth:`save` wrote, is truncated or corrupt, or has
            another version; the message names it.
        """
        import json
        import zipfile
        import zlib

        name = os.fspath(path)
        try:
            # every array is read here: an .npz reads lazily, so a truncated member fails on access
            with np.load(name, allow_pickle=False) as f:
                meta = json.loads(bytes(f["meta"]).decode())
                arrays = [f[key] for key in ("table", "poly", "nonempty")]
                sets = f["sets"] if "sets" in f.files else None
            version = meta.get("version")
            if version != FILE_VERSION:
                raise _VersionError(f"{name!r} is a POF file of version {version!r}; this version of pv_hdrvol reads "
                                    f"{FILE_VERSION}: compute it again (python -m pv_hdrvol.parallel pof)")
            bases = [TransferFunction.from_dict(b) for b in meta["bases"]]
            kwargs = {key: meta[key] for key in ("block_size", "dims", "spacing", "pitch", "step", "chord_min")}
        except (FileNotFoundError, IsADirectoryError, _VersionError):
            raise
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError, KeyError, TypeError, AttributeError,
                UnicodeDecodeError) as exc:  # what numpy's, zipfile's and json's parsers raise on a bad file
            detail = str(exc) or type(exc).__name__
            raise ValueError(f"{name!r} is not a readable POF file (truncated or corrupt: write it again with "
                             f"PlenopticOpacity.save or python -m pv_hdrvol.parallel pof): {detail}") from None
        return cls(*arrays, bases=bases, footprint=meta.get("footprint", "chord"), sets=sets, **kwargs)

    def check_volume(self, volume, block_size=None):
        """Raise ``ValueError`` unless ``volume`` is the shape (and spacing) these POFs describe."""
        if tuple(volume.dims) != self.dims:
            raise ValueError(f"these POFs describe a volume of {self.dims} points; got {tuple(volume.dims)}")
        if not np.allclose(volume.spacing, self.spacing, rtol=1e-12, atol=0):
            raise ValueError(f"these POFs describe spacing {self.spacing.tolist()}; got {list(volume.spacing)}")
        if block_size is not None and block_size != self.block_size:
            raise ValueError(f"these POFs have block_size {self.block_size}; got {block_size}")


class _VersionError(ValueError):
    """A POF file of another version (its message names the file)."""


def _family_opacity(m, k):
    """``1 - prod_i (1 - m_i)^{k_i}`` over the last axis of opacities ``m``."""
    with np.errstate(divide="ignore", invalid="ignore"):  # log 0 = -inf; -inf * 0 is discarded
        log_keep = np.log1p(-np.minimum(m, 1.0))  # -inf where a basis is opaque
        return -np.expm1(np.where(k > 0, log_keep * k, 0.0).sum(axis=-1))


def block_ranges(values, block_size):
    """``(lo, hi)`` (bz, by, bx): the smallest and largest value of each block's points
    (block ``(k, j, i)`` spans points ``i * block_size`` to ``(i + 1) * block_size``
    along x, clipped, and so on: neighbours share their faces), NaN ignored (NaN where
    a block is all NaN). Separable: a running min/max along each axis in turn."""
    lo = np.asarray(values, dtype=np.float64)
    hi = lo
    for axis in (2, 1, 0):
        n = lo.shape[axis]
        starts = np.arange(0, max(n - 1, 1), block_size)
        ends = np.minimum(starts + block_size, n - 1)  # the shared face, inclusive
        lo = np.fmin(np.fmin.reduceat(lo, starts, axis=axis), np.take(lo, ends, axis=axis))
        hi = np.fmax(np.fmax.reduceat(hi, starts, axis=axis), np.take(hi, ends, axis=axis))
    return lo, hi


def nonempty_blocks(values, shape, block_size, sigma, family):
    """(bz, by, bx, p): the block's value range (its points, NaN ignored) reaches an
    entry of non-zero extinction of the basis (``table_entry_span``: the entries
    ``block_min_depth``'s interpolation reads, no more)."""
    lo, hi = block_ranges(values, block_size)  # shape (bz, by, bx) == shape
    a0, a1 = family.axis_range
    axis_inv = 1.0 / (a1 - a0) if a1 > a0 else 0.0  # as compute() gives the kernel
    i0, i1 = table_entry_span(lo, hi, family.scale, family.linthresh, a0, axis_inv, sigma.shape[1])
    # any(sigma[:, i0:i1 + 1] > 0) per basis from prefix counts of the non-zero entries
    counts = np.concatenate([np.zeros((sigma.shape[0], 1), dtype=np.int64),
                             np.cumsum(sigma > 0, axis=1)], axis=1)  # (p, n + 1)
    out = (counts[:, i1 + 1] - counts[:, i0]) > 0  # (p, bz, by, bx)
    out &= ~np.isnan(lo)[None]  # a block of NaN only is empty
    return np.ascontiguousarray(np.moveaxis(out, 0, -1))


__all__ = ["PlenopticOpacity", "spike_filter", "fit_polynomial", "view_angles", "direction", "view_frames"]
