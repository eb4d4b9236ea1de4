"""Small multiresolution stores for the out-of-core front-end tests, and a loader made
slow on purpose (so that frames come before their chunks)."""
import time

import numpy as np


def smooth_values(n=130):
    """A smooth float32 field on ``n**3`` points (z, y, x): a blob over a gentle wave,
    nonzero nearly everywhere, so that every block shows something."""
    z, y, x = np.mgrid[0:n, 0:n, 0:n].astype(np.float64) / (n - 1)
    blob = np.exp(-((x - 0.55) ** 2 + (y - 0.5) ** 2 + (z - 0.45) ** 2) / 0.06)
    return (blob + 0.25 + 0.15 * np.sin(7.0 * x) * np.cos(5.0 * y)).astype(np.float32)


def write_store(path, n=130):
    """``smooth_values(n)`` as a store at ``path`` (3 levels for n = 130); returns the path."""
    import pv_hdrvol as hv

    hv.write_multiscale(smooth_values(n), path, spacing=(1.0, 1.0, 1.0), progress_bar=False)
    return path


def slow_loader(volume, seconds):
    """Make ``volume``'s store read each chunk ``seconds`` late (the loader threads wait,
    the renderer does not)."""
    read = volume.store.read_chunk

    def slow(level, index):
        time.sleep(seconds)
        return read(level, index)
    volume.store.read_chunk = slow
    return volume
