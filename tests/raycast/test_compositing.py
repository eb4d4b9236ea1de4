"""One compositing operator (``pv_hdrvol.raycast.compositing.composite_over``): front to
back "over" of premultiplied layers, in float64 then the output dtype, equal to a direct
computation pixel by pixel; and the one operator that ``hv.render_parallel``'s tiles,
``composite_in_order`` (a composite dataset's blocks, the pieces of a distributed
volume) and the passes of an out-of-core frame composite through, each with the result
of a direct float64 numpy computation of their own layers."""
import numpy as np
import pytest

import pv_hdrvol as hv
from pv_hdrvol.image.hdr import HDRImage
from pv_hdrvol.raycast import compositing
from pv_hdrvol.raycast.compositing import composite_in_order, composite_over

pytestmark = pytest.mark.core


def _layer(rng, shape, dtype=np.float64):
    a = rng.random(shape + (1,)) * 0.8
    return np.concatenate([rng.random(shape + (3,)) * 2.0 * a, a], axis=-1).astype(dtype)  # HDR colour, premultiplied


def _over_pixel_by_pixel(layers, shape):
    """Front-to-back over, one pixel and one layer at a time in Python floats (IEEE
    float64): ``C = C + (1 - A) c``, ``A = A + (1 - A) a``."""
    out = np.zeros(shape + (4,))
    cover = np.zeros(shape, dtype=object)
    for index in np.ndindex(*shape):
        cover[index] = []
    for where, rgba in layers:
        for local in np.ndindex(*rgba.shape[:-1]):
            whole = tuple(s.start + i if isinstance(s, slice) else i for s, i in
                          zip(where if isinstance(where, tuple) else (slice(0, None),) * len(shape), local))
            cover[whole].append(rgba[local])
    for index in np.ndindex(*shape):
        c = [0.0, 0.0, 0.0, 0.0]
        for rgba in cover[index]:
            keep = 1.0 - c[3]
            c = [c[i] + keep * float(rgba[i]) for i in range(4)]
        out[index] = c
    return out


def _direct(layers, shape, work=np.float64):
    """The same operator as numpy array arithmetic over each layer's part."""
    total = np.zeros(tuple(shape) + (4,), dtype=work)
    for where, rgba in layers:
        dst = total[where]
        dst[...] = dst + (1 - dst[..., 3:4]) * np.asarray(rgba, dtype=work)
    return total


def test_composite_over_is_front_to_back_over_pixel_by_pixel_in_float64():
    rng = np.random.default_rng(4)
    shape = (7, 9)
    layers = [(..., _layer(rng, shape)), ((slice(2, 5), slice(1, 8)), _layer(rng, (3, 7))),
              ((slice(0, 7), slice(4, 6)), _layer(rng, (7, 2), np.float32)), (..., _layer(rng, shape))]
    expected = _over_pixel_by_pixel(layers, shape)
    out = composite_over(layers, shape)
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, expected)
    # the output dtype: the float64 composite cast once
    np.testing.assert_array_equal(composite_over(layers, shape, np.float32), expected.astype(np.float32))
    # no layer: transparent
    np.testing.assert_array_equal(composite_over([], (2, 3)), np.zeros((2, 3, 4)))


def test_composite_over_is_associative_to_rounding_and_reports_each_step():
    rng = np.random.default_rng(5)
    a, b, c = (_layer(rng, (6, 5)) for _ in range(3))
    whole = composite_over([(..., a), (..., b), (..., c)], (6, 5))
    grouped = composite_over([(..., a), (..., composite_over([(..., b), (..., c)], (6, 5)))], (6, 5))
    np.testing.assert_allclose(grouped, whole, rtol=1e-14, atol=1e-15)
    seen = []
    composite_over([(..., a), (..., b)], (6, 5), after_each=lambda j, total: seen.append((j, total[..., 3].copy())))
    assert [j for j, _ in seen] == [0, 1]
    np.testing.assert_array_equal(seen[0][1], a[..., 3])
    with pytest.raises(ValueError, match="where must be a basic index of the output"):
        composite_over([(np.array([0, 2]), a[:2])], (6, 5))


def test_render_parallels_tiles_keep_their_precision_through_the_operator():
    """The tiles of hv.render_parallel accumulate in the image's precision, as they always
    have: float32 tiles are the float32 arithmetic bit for bit, and the float64 one to
    float32 rounding."""
    from pv_hdrvol.parallel.composite import composite

    rng = np.random.default_rng(6)
    pieces = []
    for order in (2, 0, 3, 1, 0):
        col, row = (int(v) for v in rng.integers(-3, 8, 2))
        pieces.append((order, (col, row, 6, 5), _layer(rng, (5, 6), np.float32)))
    tile = (1, 2, 9, 8)
    layers = []
    for _, (col, row, w, h), rgba in sorted(pieces, key=lambda p: p[0]):
        c0, r0 = max(col, tile[0]), max(row, tile[1])
        c1, r1 = min(col + w, tile[0] + tile[2]), min(row + h, tile[1] + tile[3])
        if c1 > c0 and r1 > r0:
            layers.append(((slice(r0 - tile[1], r1 - tile[1]), slice(c0 - tile[0], c1 - tile[0])),
                           rgba[r0 - row:r1 - row, c0 - col:c1 - col]))
    for dtype in (np.float32, np.float64):
        out = composite(tile, pieces, dtype)
        assert out.dtype == dtype
        np.testing.assert_array_equal(out, _direct(layers, (8, 9), dtype))
    np.testing.assert_allclose(composite(tile, pieces, np.float32), _direct(layers, (8, 9)), rtol=0, atol=1e-6)


def test_composite_in_order_is_over_in_each_pixels_order_with_its_depth():
    rng = np.random.default_rng(7)
    h, w, n = 5, 6, 4
    images = [HDRImage(_layer(rng, (h, w), np.float32), np.where(rng.random((h, w)) < 0.3, np.inf,
                                                                 rng.random((h, w)) * 9),
                       metadata={"samples": 5, "depth_threshold": 0.3}) for _ in range(n)]
    entries = np.round(rng.random((n, h * w)) * 4, 1)
    entries[rng.random((n, h * w)) < 0.15] = np.inf
    out = composite_in_order(images, entries)
    assert out.rgba.dtype == np.float32 and out.metadata["samples"] == 5 * n
    expected = np.zeros((h * w, 4))
    depth = np.full(h * w, np.inf)
    for p in range(h * w):
        c = [0.0] * 4
        for k in sorted(range(n), key=lambda k: entries[k, p]):  # stable: ties keep the images' order
            keep = 1.0 - c[3]
            c = [c[i] + keep * float(images[k].rgba.reshape(-1, 4)[p, i]) for i in range(4)]
            if depth[p] == np.inf and c[3] >= 0.3 and np.isfinite(entries[k, p]):
                own = images[k].depth.reshape(-1)[p]
                depth[p] = own if np.isfinite(own) else entries[k, p]
        expected[p] = c
    np.testing.assert_array_equal(out.rgba, expected.reshape(h, w, 4).astype(np.float32))
    np.testing.assert_array_equal(composite_in_order(images, entries, np.float64).rgba, expected.reshape(h, w, 4))
    np.testing.assert_array_equal(out.depth, depth.reshape(h, w))


@pytest.fixture
def spy(monkeypatch):
    """Every call of the operator, its layers and its result, through the module's name
    (``composite_in_order`` and the out-of-core passes reach it there) and the tile
    compositor's."""
    from pv_hdrvol.parallel import composite as tiles

    calls = []
    real = compositing.composite_over

    def record(layers, shape, dtype=np.float64, **keywords):
        layers = list(layers)
        out = real(layers, shape, dtype, **keywords)
        calls.append((layers, shape, keywords.get("accumulate", np.float64), out))
        return out

    monkeypatch.setattr(compositing, "composite_over", record)
    monkeypatch.setattr(tiles, "composite_over", record)
    return calls


def _check_calls(calls, dtype):
    assert calls
    for layers, shape, work, out in calls:
        assert work == np.float64
        np.testing.assert_array_equal(out, _direct(layers, shape).astype(dtype))


def test_a_composite_datasets_blocks_composite_through_the_operator(spy):
    from pv_hdrvol.data.blocks import ImageBlock
    from pv_hdrvol.raycast.blocks import render_image_blocks

    z, y, x = np.mgrid[0:9, 0:8, 0:10]
    field = (np.sin(x / 3.0) + y / 8.0 + z / 9.0).astype(np.float64)
    blocks = [ImageBlock("a", field, np.zeros(3), np.full(3, 0.5)),
              ImageBlock("b", field, np.array([4.5, 0.0, 0.0]), np.full(3, 0.25))]
    image = render_image_blocks(blocks, None, "iso", (24, 20), precision="float64")
    assert image.rgba[..., 3].max() > 0.1
    _check_calls(spy, np.float64)
    assert len(spy[0][0]) == 2


def test_the_pieces_of_a_distributed_volume_composite_through_the_operator(spy):
    from pv_hdrvol.data.grid import volume_from_array
    from pv_hdrvol.parallel.pieces import composite_pieces, split_volume
    from pv_hdrvol.raycast.grid import GridPlan, resolve_transfer_function

    rng = np.random.default_rng(8)
    volume = volume_from_array(rng.random((14, 12, 16)), (1.0, 0.8, 1.2))
    tf = resolve_transfer_function(volume)
    camera = hv.Camera.fit(volume.bounds, "iso")
    parts = split_volume(volume, 3)
    images = [GridPlan(v, tf, precision="float32").execute(camera, (20, 16), piece=p, progress_bar=False)
              for v, p in parts]
    image = composite_pieces(images, [p.world_box(v.spacing) for v, p in parts], camera.rays((20, 16)))
    assert image.rgba.dtype == np.float32 and image.metadata["pieces"] == 3
    _check_calls(spy, np.float32)
    assert len(spy[0][0]) == 3


def test_render_parallels_tiles_composite_through_the_operator(spy):
    from pv_hdrvol.parallel.render import render_parallel

    rng = np.random.default_rng(9)
    volume = rng.random((20, 18, 22))
    tf = hv.TransferFunction([0.0, 1.0], [[1, 0.5, 0.2], [0.2, 0.5, 1]], [0.0, 0.2])
    camera = hv.Camera.fit((0, 21, 0, 17, 0, 19), "iso", parallel_projection=True)
    image = render_parallel(volume, tf, camera, (24, 20), comm=None, block_size=8, precision="float32")
    assert image.rgba[..., 3].max() > 0.1
    (layers, shape, work, out), = spy
    assert work == np.float32 and shape == (20, 24) and len(layers) > 1
    np.testing.assert_array_equal(out, _direct(layers, shape, np.float32))
    np.testing.assert_array_equal(image.rgba, out)


def test_the_passes_of_an_out_of_core_frame_composite_through_the_operator(spy, tmp_path):
    """A cache too small for the frame's chunks: the converged frame renders in passes,
    composited through the operator."""
    pytest.importorskip("zarr")  # multiresolution stores: not in the core run's Python (Debian's)
    from pv_hdrvol.data.grid import volume_from_array
    from pv_hdrvol.outofcore.cache import SLOT_VALUES
    from pv_hdrvol.outofcore.render import open_multiscale
    from pv_hdrvol.outofcore.store import write_multiscale
    from pv_hdrvol.raycast.grid import default_transfer_function

    z, y, x = np.mgrid[0:70, 0:70, 0:140].astype(np.float64)
    values = (np.sin(x / 9.0) * np.cos(y / 13.0) + z / 70.0).astype(np.float32)
    write_multiscale(values, tmp_path / "field.ome.zarr", progress_bar=False)
    volume = volume_from_array(values)
    tf = default_transfer_function(volume)
    camera = hv.Camera.fit(volume.bounds, "iso")
    with open_multiscale(tmp_path / "field.ome.zarr", cache_bytes=10 * SLOT_VALUES * 4) as ooc:
        image = ooc.render(tf, camera, (32, 24), screen_error=1e-9)
    assert image.metadata["passes"] >= 2 and image.rgba[..., 3].max() > 0.1
    _check_calls(spy, np.float32)
    assert len(spy[-1][0]) == image.metadata["passes"]
