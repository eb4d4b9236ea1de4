"""Small checks shared by every public entry point.

Each raises ``ValueError``/``TypeError`` naming the parameter, the value received and
what is allowed, so that kernels never see unvalidated input.
"""
from __future__ import annotations

import numbers

import numpy as np


def as_choice(name, value, allowed):
    """Return ``value`` if it is one of ``allowed`` (strings), else raise."""
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, one of {list(allowed)}; got {value!r}")
    if value not in allowed:
        raise ValueError(f"{name} must be one of {list(allowed)}; got {value!r}")
    return value


def as_real(name, value, *, low=None, high=None, low_open=False, high_open=False):
    """Return ``value`` as a finite Python float inside the stated interval."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a real number; got {value!r} ({type(value).__name__})")
    v = float(value)
    if not np.isfinite(v):
        raise ValueError(f"{name} must be finite; got {value!r}")
    if low is not None and (v < low or (low_open and v == low)):
        op = ">" if low_open else ">="
        raise ValueError(f"{name} must be {op} {low}; got {value!r}")
    if high is not None and (v > high or (high_open and v == high)):
        op = "<" if high_open else "<="
        raise ValueError(f"{name} must be {op} {high}; got {value!r}")
    return v


def as_int(name, value, *, low=None, high=None):
    """Return ``value`` as a Python int inside ``[low, high]``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer; got {value!r} ({type(value).__name__})")
    v = int(value)
    if low is not None and v < low:
        raise ValueError(f"{name} must be >= {low}; got {value!r}")
    if high is not None and v > high:
        raise ValueError(f"{name} must be <= {high}; got {value!r}")
    return v


def as_vector(name, value, length=3):
    """Return ``value`` as a finite float64 vector of ``length`` entries."""
    try:
        arr = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a sequence of {length} numbers; got {value!r}") from None
    if arr.shape != (length,):
        raise ValueError(f"{name} must have {length} entries; got {value!r}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite; got {value!r}")
    return arr


def as_size(value):
    """Return an image size ``(width, height)`` of positive ints.

    An int means a square image.
    """
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        value = (value, value)
    try:
        w, h = value
    except (TypeError, ValueError):
        raise TypeError(f"size must be an int or a (width, height) pair; got {value!r}") from None
    w = as_int("size[0] (width)", w, low=1)
    h = as_int("size[1] (height)", h, low=1)
    if w * h > 2**28:
        raise ValueError(f"size {w}x{h} is larger than the 2**28 pixels allowed")
    return w, h
