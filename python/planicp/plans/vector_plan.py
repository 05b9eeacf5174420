"""Floor plans drawn as vectors (wall segments) and their wall points for `PlanMap.from_points`.

A plan arrives as line work: a HouseExpo outline polygon (JSON) or a CAD drawing (DXF). Both become
wall segments, an (M, 2, 2) float64 array of [[x0, y0], [x1, y1]] in metres in the map frame
(REP-103: x right/forward, y up/left), and `sample_segments` turns segments into the wall points
the localizer aligns scans to:

    segments = planicp.plans.vector_plan.dxf_segments("floor2.dxf", layers=["WALLS"])
    plan = planicp.PlanMap.from_points(planicp.plans.vector_plan.sample_segments(segments, spacing=0.02))

Only numpy is needed at import; reading DXF needs ezdxf (``pip install 'planicp[cad]'``).
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Iterable, Mapping
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from .._validation import brief, positive

if TYPE_CHECKING:
    # ezdxf is optional: without it (no 'cad' extra) mypy sees Any here, with it the real types.
    from ezdxf.entities.dxfgfx import DXFGraphic  # type: ignore[import-not-found,unused-ignore]

__all__ = ["dxf_segments", "house_expo_segments", "sample_segments"]

_MAX_SAMPLES = 50_000_000
"""More wall points than this (800 MB) is a spacing mistake, not a plan."""

_WALL_TYPES = ("LINE", "LWPOLYLINE", "POLYLINE", "ARC", "CIRCLE")

_METRES_PER_UNIT: dict[int, float] = {
    # $INSUNITS code -> metres per drawing unit (exact definitions; 0 = unitless is taken as metres).
    0: 1.0,
    1: 0.0254,  # inch
    2: 0.3048,  # foot
    3: 1609.344,  # mile
    4: 1e-3,  # millimetre
    5: 1e-2,  # centimetre
    6: 1.0,  # metre
    7: 1e3,  # kilometre
    8: 0.0254e-6,  # microinch
    9: 0.0254e-3,  # mil
    10: 0.9144,  # yard
    11: 1e-10,  # angstrom
    12: 1e-9,  # nanometre
    13: 1e-6,  # micron
    14: 1e-1,  # decimetre
    15: 1e1,  # decametre
    16: 1e2,  # hectometre
    17: 1e9,  # gigametre
    18: 149_597_870_700.0,  # astronomical unit
    19: 9_460_730_472_580_800.0,  # light year
    20: 30_856_775_814_913_673.0,  # parsec
    21: 1200.0 / 3937.0,  # US survey foot
    22: 100.0 / 3937.0,  # US survey inch
    23: 3600.0 / 3937.0,  # US survey yard
    24: 6_336_000.0 / 3937.0,  # US survey mile
}

_EZDXF_MISSING = "reading DXF plans needs ezdxf: pip install 'planicp[cad]'"


def sample_segments(segments: Any, spacing: float = 0.02) -> NDArray[np.float64]:
    """Wall points along wall segments, at most `spacing` apart along each segment.

    A segment of length L gets n = ceil(L / spacing) equal intervals, so n + 1 evenly spaced
    points including both endpoints exactly; a zero-length segment gives one point. Exact
    duplicate points, such as the endpoint consecutive segments share, appear once, at their
    first occurrence, so the order follows the order of the segments.

    Args:
        segments: (M, 2, 2) segments [[x0, y0], [x1, y1]], metres, map frame. M >= 1, finite.
        spacing: largest distance between neighbouring points along a segment, metres. About
            the scan's point spacing at typical ranges or finer; 0.02 m suits most indoor LIDARs.

    Returns:
        (N, 2) float64 wall points, metres, map frame.

    Raises:
        TypeError: `segments` or `spacing` is not made of real numbers.
        ValueError: wrong shape, no segments, a NaN/inf coordinate, `spacing` <= 0, or more than
            50 million points (the spacing is far too fine for the plan's size).
    """
    segs = as_segments(segments, "segments")
    step = positive(spacing, "spacing", "metres")
    p0, p1 = segs[:, 0, :], segs[:, 1, :]
    delta = p1 - p0
    length = np.hypot(delta[:, 0], delta[:, 1])
    with np.errstate(over="ignore"):
        ratio = length / step
    if not np.isfinite(ratio).all() or float(ratio.sum()) + len(segs) > _MAX_SAMPLES:
        raise ValueError(
            f"sampling {float(length.sum()):.6g} m of walls every {step:g} m gives more than {_MAX_SAMPLES} points: "
            "use a larger spacing"
        )
    intervals = np.ceil(ratio).astype(np.int64)
    # ceil of a rounded ratio can fall one short of the true one; the spacing is a promise.
    intervals[(intervals > 0) & (length / np.maximum(intervals, 1) > step)] += 1
    counts = intervals + 1
    seg_of = np.repeat(np.arange(len(segs)), counts)
    first = np.cumsum(counts) - counts
    k = np.arange(int(counts.sum()), dtype=np.int64) - first[seg_of]
    t = k / np.maximum(intervals, 1)[seg_of]
    points = p0[seg_of] + t[:, None] * delta[seg_of]
    last = k == intervals[seg_of]
    points[last] = p1[seg_of[last]]  # exact endpoints, whatever the rounding of p0 + 1 * delta
    points += 0.0  # -0.0 -> 0.0: numpy < 2 compares rows by their bytes in np.unique(axis=0)
    _, keep = np.unique(points, axis=0, return_index=True)
    return np.ascontiguousarray(points[np.sort(keep)])


def house_expo_segments(
    source: str | PathLike[str] | Mapping[str, Any],
) -> tuple[NDArray[np.float64], tuple[float, float, float, float]]:
    """The wall outline of a HouseExpo floor plan (JSON) as segments, and its bounding box.

    HouseExpo (T. Li et al., 2019) stores each floor as `verts`, the outline polygon as a list of
    [x, y] in metres (implicitly closed: the last vertex connects to the first), and `bbox`,
    {"min": [x, y], "max": [x, y]} in metres. Coordinates are used as they are, as map-frame x, y.

    Args:
        source: path of the JSON file, or its already parsed content (a dict).

    Returns:
        (segments, bbox): the (M, 2, 2) float64 edges of the closed polygon in vertex order, metres,
        map frame (M = number of vertices; a last vertex repeating the first is not a separate
        edge), and the bbox as (xmin, ymin, xmax, ymax), metres.

    Raises:
        FileNotFoundError: the file does not exist.
        TypeError: `source` is neither a path nor a mapping.
        ValueError: invalid JSON, a missing `verts` or `bbox`, fewer than 3 vertices, or a
            malformed or non-finite value; the message names the file and the key.
    """
    if isinstance(source, Mapping):
        data: Any = source
        name = "HouseExpo data (dict)"
    elif isinstance(source, (str, PathLike)):
        path = Path(source)
        name = f"HouseExpo file {str(path)!r}"
        if not path.is_file():
            raise FileNotFoundError(f"{name} does not exist" if not path.exists() else f"{name} is not a file")
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise ValueError(f"{name} is not valid JSON: {exc}") from None
        except RecursionError:
            raise ValueError(f"{name} nests its values too deeply to be a HouseExpo plan") from None
        except ValueError as exc:  # an integer of thousands of digits
            raise ValueError(f"{name} is not a HouseExpo plan: {str(exc)[:120]}") from None
    else:
        raise TypeError(f"source must be a path (str or Path) or a parsed dict, got {type(source).__name__}")
    if not isinstance(data, Mapping):
        raise ValueError(f"{name} must hold a JSON object with 'verts' and 'bbox', got {type(data).__name__}")
    for key in ("verts", "bbox"):
        if key not in data:
            raise ValueError(f"{name} has no {key!r} key (keys: {brief(sorted(map(str, data)))})")

    verts = _json_points(data["verts"], f"{name}, key 'verts'")
    if len(verts) >= 2 and (verts[-1] == verts[0]).all():
        verts = verts[:-1]  # explicitly closed: the closing edge is implied anyway
    if len(verts) < 3:
        raise ValueError(f"{name}, key 'verts': an outline polygon needs at least 3 vertices, got {len(verts)}")

    bbox = data["bbox"]
    if not isinstance(bbox, Mapping):
        raise ValueError(f"{name}, key 'bbox' must be an object with 'min' and 'max', got {type(bbox).__name__}")
    corners = []
    for key in ("min", "max"):
        if key not in bbox:
            raise ValueError(f"{name} has no 'bbox.{key}' key")
        corner = _json_points([bbox[key]], f"{name}, key 'bbox.{key}'")
        corners.append((float(corner[0, 0]), float(corner[0, 1])))
    (xmin, ymin), (xmax, ymax) = corners
    if xmin > xmax or ymin > ymax:
        raise ValueError(f"{name}, key 'bbox': min {corners[0]} exceeds max {corners[1]}")

    segments = np.stack([verts, np.roll(verts, -1, axis=0)], axis=1)
    return np.ascontiguousarray(segments), (xmin, ymin, xmax, ymax)


def dxf_segments(
    path: str | PathLike[str],
    layers: str | Iterable[str] | None = None,
    *,
    arc_tolerance: float = 0.01,
) -> NDArray[np.float64]:
    """The wall line work of a DXF drawing as segments in metres.

    The file is read with `ezdxf.recover.readfile`, which repairs what it can of damaged files.
    Walls are the LINE, LWPOLYLINE (closed flag and bulge arcs), 2D POLYLINE, ARC and CIRCLE
    entities of the modelspace on the chosen layers, block references expanded; everything else
    (text, hatches, dimensions, 3D polylines, meshes) is skipped, and so are door swings (an arc
    and its leaf). Without `layers`, frozen, off, non-plotting and door layers are skipped, and of
    the others the layers named as walls are read with the building's shell around them (all of
    them when none is named as walls: `dxf_plan.dxf_walls`, which also says what it read and left
    out). Arcs, circles and
    bulges become chords whose sagitta (largest gap between chord and true arc) is at most
    `arc_tolerance`; the chord ends lie on the true arc, and segment endpoints are kept exactly.

    Coordinates are the drawing's world coordinates (WCS) projected onto its XY plane, used as
    map-frame x, y, and scaled from the drawing units in the header variable `$INSUNITS` to metres:
    1 inch, 2 feet, 4 millimetres, 5 centimetres, 6 metres, and the other codes DXF defines
    (miles, yards, US survey feet, ...). A unitless drawing (0, or no `$INSUNITS`) is ASSUMED TO BE
    IN METRES: check the extent of the result if the drawing might be in millimetres.

    Args:
        path: the DXF file.
        layers: names of the wall layers, compared case-insensitively (a single str is one
            layer), read whatever their state; None: of the layers shown (on, thawed, plotted)
            and not door layers, those named as walls and their shell, or all when none is.
        arc_tolerance: largest sagitta of a chord replacing an arc, metres.

    Returns:
        (M, 2, 2) float64 segments [[x0, y0], [x1, y1]], metres, map frame, in drawing order
        (entities in modelspace order, each curve's chords in order along it).

    Raises:
        ImportError: ezdxf is not installed.
        FileNotFoundError: the file does not exist.
        TypeError: `layers` is not None, a str or an iterable of str.
        ValueError: a requested layer does not exist (the message lists those that do), no wall
            entity was found, the file is not a readable DXF, its `$INSUNITS` is unknown, or
            `arc_tolerance` <= 0; each message names the file.
    """
    from .dxf_plan import dxf_walls

    return dxf_walls(path, layers, arc_tolerance=arc_tolerance).segments


_DAMAGED = (AttributeError, TypeError, IndexError, KeyError, ZeroDivisionError, OverflowError, ValueError)
"""What ezdxf raises when a document its recovery returned lacks a value (a None where a point
should be): reading such a document is refused naming the file (and the entity)."""


def as_segments(value: Any, name: str) -> NDArray[np.float64]:
    """`value` as a C-contiguous (M, 2, 2) float64 array of finite coordinates, M >= 1."""
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged nested sequences
        raise ValueError(f"{name} must be an (M, 2, 2) array of numbers: {exc}") from None
    if arr.dtype.kind not in "fiu":
        raise TypeError(f"{name} must hold real numbers (float or int), got dtype {arr.dtype}")
    if arr.ndim != 3 or arr.shape[1:] != (2, 2):
        raise ValueError(f"{name} must have shape (M, 2, 2) ([[x0, y0], [x1, y1]] per segment), got {arr.shape}")
    if arr.shape[0] == 0:
        raise ValueError(f"{name} is empty: it needs at least one segment")
    out = np.ascontiguousarray(arr, dtype=np.float64)
    finite = np.isfinite(out).all(axis=(1, 2))
    if not finite.all():
        row = int(np.flatnonzero(~finite)[0])
        raise ValueError(f"{name} has a non-finite coordinate (NaN or inf) in segment {row}: {out[row].tolist()}")
    return out


def _json_points(value: Any, where: str) -> NDArray[np.float64]:
    """A JSON list of [x, y] pairs as a finite (N, 2) float64 array; ValueError naming `where`."""
    if not isinstance(value, (list, tuple)) or not all(
        isinstance(p, (list, tuple))
        and len(p) == 2
        and all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in p)
        for p in value
    ):
        raise ValueError(f"{where} must be a list of [x, y] number pairs")
    try:
        arr = np.array(value, dtype=np.float64).reshape(-1, 2)
    except OverflowError:
        raise ValueError(f"{where} holds a number too large for a coordinate in metres") from None
    finite = np.isfinite(arr).all(axis=1)
    if not finite.all():
        row = int(np.flatnonzero(~finite)[0])
        raise ValueError(f"{where} has a non-finite value at index {row}: {arr[row].tolist()}")
    return arr


def _layer_names(layers: str | Iterable[str] | None) -> frozenset[str] | None:
    """Requested layer names, case-folded; None means all layers."""
    if layers is None:
        return None
    if isinstance(layers, str):
        layers = [layers]
    if not isinstance(layers, Iterable):
        raise TypeError(f"layers must be None, a str or an iterable of str, got {type(layers).__name__}")
    folded = []
    for layer in layers:
        if not isinstance(layer, str):
            raise TypeError(f"layer names must be str, got {type(layer).__name__} {layer!r}")
        folded.append(layer.casefold())
    if not folded:
        raise ValueError("layers is empty: name at least one layer, or pass None for all layers")
    return frozenset(folded)


def _entity_polyline(entity: DXFGraphic, tol: float) -> NDArray[np.float64] | None:
    """The entity as a (K >= 2, 2) chain of WCS XY vertices in drawing units, None if not a wall type.

    `tol` is the largest chord sagitta, in drawing units. The geometry is ezdxf's: `bulge_to_arc`
    for the arc of a bulge, `Circle.vertices` and `ConstructionArc.vertices` for points on the true
    circle, the entity's OCS for the world coordinates. Only the number of chords is this module's
    (`_chord_count`).
    """
    from ezdxf.entities.arc import Arc  # type: ignore[import-not-found,unused-ignore]
    from ezdxf.entities.circle import Circle  # type: ignore[import-not-found,unused-ignore]
    from ezdxf.entities.line import Line  # type: ignore[import-not-found,unused-ignore]
    from ezdxf.entities.lwpolyline import LWPolyline  # type: ignore[import-not-found,unused-ignore]
    from ezdxf.entities.polyline import Polyline  # type: ignore[import-not-found,unused-ignore]
    from ezdxf.math import Vec3  # type: ignore[import-not-found,unused-ignore]

    if isinstance(entity, Line):
        start, end = entity.dxf.start, entity.dxf.end
        return np.array([[start.x, start.y], [end.x, end.y]], dtype=np.float64)
    if isinstance(entity, Circle):  # ARC is a CIRCLE subclass
        start_deg, sweep_deg = 0.0, 360.0  # equal start and end angles of an ARC draw a full circle
        if isinstance(entity, Arc):
            sweep = (float(entity.dxf.end_angle) - float(entity.dxf.start_angle)) % 360.0
            if sweep != 0.0:
                start_deg, sweep_deg = float(entity.dxf.start_angle), sweep
        n = _chord_count(abs(float(entity.dxf.radius)), entity.dxf.center, math.radians(sweep_deg), tol)
        # Circle.vertices: points on the true circle at OCS angles (degrees), in WCS. Not the
        # entity's own flattening(): it counts with ezdxf's arc_segment_count (see _chord_count),
        # and draws nothing for an ARC whose start and end angles are equal.
        points = entity.vertices(np.linspace(start_deg, start_deg + sweep_deg, n + 1))
        chain = np.array([(p.x, p.y) for p in points], dtype=np.float64)
        if sweep_deg == 360.0:
            chain[-1] = chain[0]
        return chain
    if isinstance(entity, LWPolyline):
        xyb = [(float(x), float(y), float(b)) for x, y, b in entity.get_points("xyb")]
        closed, elevation = bool(entity.closed), float(entity.dxf.elevation)
    elif isinstance(entity, Polyline) and entity.is_2d_polyline:
        xyb = [(float(v.dxf.location.x), float(v.dxf.location.y), float(v.dxf.bulge)) for v in entity.vertices]
        closed, elevation = bool(entity.is_closed), float(entity.dxf.elevation.z)
    else:
        return None
    if len(xyb) < 2:
        return None
    wcs = entity.ocs().points_to_wcs(Vec3(x, y, elevation) for x, y in _bulge_chain(xyb, closed, tol))
    return np.array([(p.x, p.y) for p in wcs], dtype=np.float64)


def _bulge_chain(xyb: list[tuple[float, float, float]], closed: bool, tol: float) -> list[tuple[float, float]]:
    """Polyline vertices (x, y, bulge), >= 2 of them, as a chain of OCS points, bulge arcs flattened.

    The polyline's own vertices are kept exactly, the points between them lie on the bulge's arc.
    Not the polyline's `virtual_entities()`: its ARCs lose the vertices (their ends are recomputed
    from the centre) and the direction of a negative bulge, and it drops a bulge whose radius is
    not positive (NaN) or whose vertices coincide.
    """
    from ezdxf.math import ConstructionArc, bulge_to_arc  # type: ignore[import-not-found,unused-ignore]

    vertices = [*xyb, xyb[0]] if closed else xyb
    chain = [vertices[0][:2]]
    for (x0, y0, bulge), (x1, y1, _) in itertools.pairwise(vertices):
        if bulge != 0.0 and (x0, y0) != (x1, y1):
            # bulge = tan(sweep / 4), counter-clockwise when positive; bulge_to_arc returns the arc
            # counter-clockwise, so from the end vertex to the start one when the bulge is negative.
            center, ccw_start, ccw_end, radius = bulge_to_arc((x0, y0), (x1, y1), bulge)
            sweep = 4.0 * math.atan(bulge)
            n = _chord_count(radius, center, sweep, tol)
            first = ccw_start if bulge > 0.0 else ccw_end
            inner = np.degrees(first + sweep * np.arange(1, n) / n)
            chain.extend((p.x, p.y) for p in ConstructionArc(center, radius).vertices(inner))
        chain.append((x1, y1))
    return chain


MAX_ARC_POINTS = 1_000_000
"""Most points one arc or circle of a drawing is flattened to: a 3 km circle followed within 15 nm
(at the default 0.01 m, a circle of radius 2e9 m). More is a units mistake, not a wall."""


def _chord_count(radius: float, center: Any, sweep: float, tol: float) -> int:
    """How many equal chords follow `sweep` radians of a circle of `radius` within `tol`.

    As few as keep each sagitta, r (1 - cos(step / 2)), at most `tol`; a full turn gets at least 3,
    a circle of radius 0 one (from its centre to itself). Counted before ezdxf makes any point, so
    that an absurd arc is refused here rather than allocated there.

    Not ezdxf's `arc_segment_count` (which the entities' `flattening` use): it gives 1 when `tol`
    exceeds the diameter, so a small circle would become one chord from a point to itself; it has
    no minimum for a full turn; and it counts by asin, which overestimates once `tol` exceeds the
    radius.
    """
    if not (math.isfinite(radius) and math.isfinite(center[0]) and math.isfinite(center[1])):
        raise ValueError("an arc with no finite radius (its centre or start is not finite)")
    if radius == 0.0:
        return 1
    # 1 - tol / r rounds to 1 for a nearly straight arc (a bulge of 1e-15, ordinary CAD noise): the
    # small-angle form of the same step, r (1 - cos(step / 2)) ~ r step^2 / 8, keeps it positive.
    max_step = max(2.0 * math.acos(max(-1.0, 1.0 - tol / radius)), 2.0 * math.sqrt(2.0 * tol / radius))
    n = max(1, math.ceil(abs(sweep) / max_step))
    if n > MAX_ARC_POINTS:
        raise ValueError(
            f"an arc of radius {radius:.3g} drawing units would take {n} points to follow within "
            f"{tol:.3g}; check the drawing's units (or the entity: a circle that large is no wall)"
        )
    return max(n, 3) if abs(sweep) >= 2.0 * math.pi else n
