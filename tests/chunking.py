"""Uneven chunking shared by the streaming-equals-whole-array tests."""

from __future__ import annotations


def uneven_bounds(n, sizes):
    """``(start, stop)`` pairs covering ``range(n)`` with chunk sizes cycling through ``sizes``
    (zeros give empty chunks)."""
    bounds, i, k = [], 0, 0
    while i < n:
        j = min(n, i + sizes[k % len(sizes)])
        bounds.append((i, j))
        i, k = j, k + 1
    return bounds


def uneven_chunks(x, sizes):
    """``x`` split into chunks of cycling, uneven sizes (empty chunks included)."""
    return [x[i:j] for i, j in uneven_bounds(len(x), sizes)]
