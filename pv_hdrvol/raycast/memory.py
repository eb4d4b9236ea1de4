"""How much memory a render will allocate, checked against what the machine has free,
so that a render too large fails at once with a message instead of after minutes.

The estimates count the arrays a render allocates (read from ``grid.py`` and
``tets.py``), not numpy's temporaries of a few bytes per pixel or block.
"""
from __future__ import annotations

import sys


class RenderMemoryError(MemoryError):
    """A render would need more memory than is available.

    Attributes
    ----------
    needed : int
        Estimated bytes the render allocates.
    available : int
        Bytes available when it was checked.
    parts : dict
        ``{what: bytes}``, the estimate's terms.
    """

    def __init__(self, message, needed, available, parts):
        super().__init__(message)
        self.needed, self.available, self.parts = needed, available, dict(parts)


def available_memory(meminfo="/proc/meminfo"):
    """Bytes the system can give without swapping: ``MemAvailable`` of ``meminfo`` on
    Linux, else ``psutil.virtual_memory().available`` if psutil is installed, else None
    (no check)."""
    if sys.platform.startswith("linux"):
        try:
            with open(meminfo) as f:
                for line in f:
                    if line.startswith("MemAvailable:"):
                        return int(line.split()[1]) * 1024
        except (OSError, ValueError, IndexError):
            pass
    try:
        import psutil
    except ImportError:
        return None
    return int(psutil.virtual_memory().available)


def format_bytes(n):
    """``n`` bytes in binary units, e.g. ``'11.5 GiB'``."""
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB"):
        if n < 1024 or unit == "TiB":
            return f"{n:.0f} bytes" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1024


def check_memory(parts, advice):
    """Raise :class:`RenderMemoryError` when the sum of ``parts`` (``{what: bytes}``)
    exceeds :func:`available_memory`; ``advice`` says what to change."""
    needed = int(sum(parts.values()))
    available = available_memory()  # looked up at call time: tests replace it
    if available is None or needed <= available:
        return
    terms = ", ".join(f"{what} {format_bytes(b)}" for what, b in parts.items() if b)
    raise RenderMemoryError(f"this render needs about {format_bytes(needed)} ({needed} bytes: {terms}) but only "
                            f"{format_bytes(available)} of memory is available; {advice}", needed, available, parts)
