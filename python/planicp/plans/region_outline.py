"""The outline of a region made of polygons: their union, less other polygons, as boundary segments.

A floor's walls cut at a height are polygons (one or more per wall) that overlap where walls meet,
and doors and windows are polygons to take away. The wall *surfaces* a LIDAR sees are the boundary
of (union of walls) minus (union of openings): `region_outline` finds it without a geometry
library. Every polygon edge is split where any other edge crosses or touches it; a piece is
boundary when the region lies on exactly one side of it (tested just off its middle, on both
sides). Shared faces of abutting walls and the inner ends of walls that run into others are
therefore not boundary; the jambs of a door (opening edges inside a wall) are.

Coordinates are metres in the map frame; the work is O(E^2) in the number of edges E (a storey of
a house: a few hundred; of a large building, a few thousand: seconds), the memory O(E).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

__all__ = ["region_outline"]

_BLOCK = 256
"""Edges whose crossings with all others are found at once (memory: 256 x E values per array)."""


def _edges(polygons: Sequence[NDArray[np.float64]]) -> NDArray[np.float64]:
    pieces = []
    for poly in polygons:
        p = np.asarray(poly, dtype=np.float64)
        if len(p) >= 2 and np.array_equal(p[0], p[-1]):
            p = p[:-1]
        if len(p) >= 3:
            pieces.append(np.stack([p, np.roll(p, -1, axis=0)], axis=1))
    return np.concatenate(pieces) if pieces else np.zeros((0, 2, 2))


def _inside(points: NDArray[np.float64], polygons: Sequence[NDArray[np.float64]]) -> NDArray[np.bool_]:
    """Whether each point is inside any of `polygons` (even-odd rule per polygon)."""
    result = np.zeros(len(points), dtype=bool)
    x, y = points[:, 0:1], points[:, 1:2]
    for poly in polygons:
        p = np.asarray(poly, dtype=np.float64)
        if len(p) >= 2 and np.array_equal(p[0], p[-1]):
            p = p[:-1]
        if len(p) < 3:
            continue
        x0, y0 = p[:, 0][None, :], p[:, 1][None, :]
        x1, y1 = np.roll(p[:, 0], -1)[None, :], np.roll(p[:, 1], -1)[None, :]
        straddles = (y0 > y) != (y1 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            cross_x = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        result |= (np.count_nonzero(straddles & (x < cross_x), axis=1) % 2) == 1
    return result


def region_outline(
    solids: Sequence[NDArray[np.float64]],
    holes: Sequence[NDArray[np.float64]] = (),
    *,
    tolerance: float = 1e-4,
) -> NDArray[np.float64]:
    """Boundary segments of (union of `solids`) minus (union of `holes`).

    Args:
        solids: polygons, each (K >= 3, 2) vertices in order (closed implicitly), metres.
        holes: polygons taken away, as `solids`.
        tolerance: how far off a piece's middle the region is tested, and how close a vertex
            must be to an edge to split it, metres.

    Returns:
        (M, 2, 2) segments, metres; (0, 2, 2) when the region is empty.
    """
    all_edges = np.concatenate([_edges(solids), _edges(holes)])
    if len(all_edges) == 0:
        return np.zeros((0, 2, 2))
    a, b = all_edges[:, 0], all_edges[:, 1]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    keep = length > tolerance
    a, b, d, length = a[keep], b[keep], d[keep], length[keep]
    splits: list[list[float]] = [[0.0, 1.0] for _ in range(len(a))]
    unit = d / length[:, None]
    for lo in range(0, len(a), _BLOCK):  # rows in blocks: memory O(_BLOCK x E), not O(E^2)
        hi = min(lo + _BLOCK, len(a))
        ai, di, li, ui = a[lo:hi], d[lo:hi], length[lo:hi], unit[lo:hi]
        # Where edge j crosses edge i: a_i + t d_i = a_j + u d_j.
        den = di[:, None, 0] * d[None, :, 1] - di[:, None, 1] * d[None, :, 0]
        w = a[None, :, :] - ai[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[..., 0] * d[None, :, 1] - w[..., 1] * d[None, :, 0]) / den
            u = (w[..., 0] * di[:, None, 1] - w[..., 1] * di[:, None, 0]) / den
        eps_t = tolerance / li[:, None]
        eps_u = tolerance / length[None, :]
        crossing = (np.abs(den) > 1e-12) & (t > eps_t) & (t < 1 - eps_t) & (u >= -eps_u) & (u <= 1 + eps_u)
        rows, cols = np.nonzero(crossing)
        for i, j in zip(rows.tolist(), cols.tolist()):
            splits[lo + i].append(float(t[i, j]))
        # Where an end of edge j lies on edge i (T-junctions, overlapping collinear edges).
        for end in (a, b):
            rel = end[None, :, :] - ai[:, None, :]  # (i, j, 2)
            along = (rel * ui[:, None, :]).sum(axis=2)
            off = np.abs(rel[..., 0] * ui[:, None, 1] - rel[..., 1] * ui[:, None, 0])
            on = (off <= tolerance) & (along > tolerance) & (along < li[:, None] - tolerance)
            rows, cols = np.nonzero(on)
            for i, j in zip(rows.tolist(), cols.tolist()):
                splits[lo + i].append(float(along[i, j] / li[i]))
    starts, ends = [], []
    for i, ts in enumerate(splits):
        params = np.unique(np.asarray(ts))
        starts.append(a[i] + params[:-1, None] * d[i])
        ends.append(a[i] + params[1:, None] * d[i])
    p0, p1 = np.concatenate(starts), np.concatenate(ends)
    piece = p1 - p0
    piece_len = np.hypot(piece[:, 0], piece[:, 1])
    good = piece_len > tolerance * 0.5
    p0, p1, piece, piece_len = p0[good], p1[good], piece[good], piece_len[good]
    mid = 0.5 * (p0 + p1)
    normal = np.column_stack([-piece[:, 1], piece[:, 0]]) / piece_len[:, None]

    def region(points: NDArray[np.float64]) -> NDArray[np.bool_]:
        return _inside(points, solids) & ~_inside(points, holes)

    left = region(mid + tolerance * normal)
    right = region(mid - tolerance * normal)
    boundary = left != right
    segs = np.stack([p0[boundary], p1[boundary]], axis=1)
    if len(segs) == 0:
        return np.zeros((0, 2, 2))
    # The same piece from two polygons (a wall face flush with an opening's face) once.
    x0, y0, x1, y1 = segs[:, 0, 0], segs[:, 0, 1], segs[:, 1, 0], segs[:, 1, 1]
    swap = (x0 > x1) | ((x0 == x1) & (y0 > y1))
    ordered = np.where(swap[:, None, None], segs[:, ::-1], segs)
    key = np.round(ordered.reshape(-1, 4) / tolerance).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    return np.ascontiguousarray(segs[np.sort(first)])
