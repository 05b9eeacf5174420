#!/usr/bin/env python3
"""Walls out of the real vector drawings (PDF, DXF, IFC) with default settings, scored against
their true walls, with an overlay per drawing.

    python benches/vector_walls.py [--drawings ../shared/data/drawings] [--out out/vector_walls]

For each drawing, the wall points planicp's default reading gives (`load_plan`, points every
`--spacing` metres) are compared with a truth made WITHOUT planicp's selection logic:

* `cmu_newell_simon_floor3.pdf`: the black 0.06 pt strokes, selected here by colour and width
  from pdfminer's layout objects (their own path walk, Bezier curves flattened here), in page
  points scaled by the drawing's true print scale 1"=24' (0.1016 m per point, known from the
  legend's areas). planicp reads it with `scale='1"=24\\''`, and without (it states no scale in
  its text: the scale its legend gives, `legend_scale`).
* `raumzeitlabor_floorplan.dxf`: the entities of the wall layers `Base` and `Wand (neu)` (the
  drawings' README: the room's shell and the new walls), read with ezdxf directly (block references
  expanded with ezdxf's `virtual_entities`), in centimetres ($INSUNITS 5).
* `AC20-FZK-Haus.ifc`: the footprints of the ground storey's IfcWall solids (their extruded
  profile polygons placed by their IfcLocalPlacement chains, world x, y), united; in the first
  truth less the footprints of those openings (IfcRelVoidsElement) whose vertical extent
  contains the cut height, 1 m above the storey's floor (doors, and windows whose sill is below
  1 m: each opening's extent is printed), in the second with no opening taken away. The
  STEP file is parsed with planicp's `step_file` (a parser only: which instances are walls,
  openings and placements is decided here). Rasterised at 1 cm; the truth's surface is the
  outline of that area, one point per centimetre of outline.

The truth's segments are sampled every `--spacing` metres (the IFC's outline every centimetre).
Precision: the share of extracted points within `--tolerance` (0.05 m) of a true surface point;
recall: the share of true surface points within it of an extracted point (as
`benches/drawing_walls.py`). The overlays (`--out`) draw the truth in grey under the extracted
points, green where within the tolerance of the truth and red where not; the truth's points
missed are drawn blue.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from planicp.plans.plan_loading import read_plan_file

PDF_METRES_PER_POINT = 24 * 12 * 0.0254 / 72  # 1" = 24': one inch on paper is 24 feet
IFC_CUT_HEIGHT = 1.0


def sample_segments(segments: NDArray[np.float64], spacing: float) -> NDArray[np.float64]:
    """(N, 2) points every `spacing` (at most) along each segment (M, 2, 2), both ends included."""
    out = []
    for a, b in segments:
        n = max(1, math.ceil(float(np.hypot(*(b - a))) / spacing))
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        out.append(a + t * (b - a))
    return np.concatenate(out)


def near_share(points: NDArray[np.float64], others: NDArray[np.float64], tol: float) -> NDArray[np.bool_]:
    """For each of `points`, whether one of `others` is within `tol` (same units)."""
    dist, _ = cKDTree(others).query(points, distance_upper_bound=tol * 1.000001)
    return np.asarray(np.isfinite(dist) & (dist <= tol))


# --- PDF ---------------------------------------------------------------------------------------


def _bezier(p0: Any, p1: Any, p2: Any, p3: Any, n: int = 16) -> list[tuple[float, float]]:
    t = np.linspace(0.0, 1.0, n + 1)[1:, None]
    q = np.array([p0, p1, p2, p3], np.float64)
    pts = (1 - t) ** 3 * q[0] + 3 * (1 - t) ** 2 * t * q[1] + 3 * (1 - t) * t**2 * q[2] + t**3 * q[3]
    return [(float(x), float(y)) for x, y in pts]


def pdf_truth(path: Path) -> NDArray[np.float64]:
    """The black (grey level 0) 0.06 pt strokes of page 1 as segments, page points (y up)."""
    from pdfminer.high_level import extract_pages
    from pdfminer.layout import LTCurve, LTPage

    segments: list[tuple[tuple[float, float], tuple[float, float]]] = []

    def walk(obj: Any) -> None:
        if isinstance(obj, LTCurve):
            colour = obj.stroking_color
            black = colour in (0, 0.0, (0,), (0.0,), [0], [0.0]) or (
                isinstance(colour, (tuple, list)) and len(colour) == 3 and max(colour) == 0
            )
            if obj.stroke and not obj.fill and black and abs(obj.linewidth - 0.06) < 0.005:
                chains: list[list[tuple[float, float]]] = []
                path = obj.original_path or [("m", obj.pts[0]), *(("l", q) for q in obj.pts[1:])]
                for op, *pts in path:
                    xy = [(float(x), float(y)) for x, y in pts]
                    if op == "m":
                        chains.append(xy)
                    elif op == "l":
                        chains[-1].extend(xy)
                    elif op == "c":
                        chains[-1].extend(_bezier(chains[-1][-1], *xy))
                    elif op == "h":
                        chains[-1].append(chains[-1][0])
                    else:
                        raise ValueError(f"path operator {op} not handled by this bench")
                for chain in chains:
                    segments.extend(zip(chain[:-1], chain[1:]))
        for child in getattr(obj, "_objs", []):
            walk(child)

    for page in extract_pages(str(path), page_numbers=[0]):
        assert isinstance(page, LTPage)
        walk(page)
    return np.array(segments, np.float64)


# --- DXF ---------------------------------------------------------------------------------------


def dxf_truth(path: Path, layers: tuple[str, ...], arc_step_deg: float = 2.0) -> NDArray[np.float64]:
    """The LINE, LWPOLYLINE, ARC and CIRCLE entities on `layers` (blocks expanded) as segments in
    drawing units (arcs every `arc_step_deg`)."""
    import ezdxf

    doc = ezdxf.readfile(path)

    def entities(items: Any) -> Any:
        for e in items:
            if e.dxftype() == "INSERT":
                yield from entities(e.virtual_entities())
            else:
                yield e

    segments: list[Any] = []
    for e in entities(doc.modelspace()):
        if e.dxf.layer not in layers:
            continue
        kind = e.dxftype()
        if kind == "LINE":
            segments.append((tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]))
        elif kind in ("LWPOLYLINE", "ARC", "CIRCLE"):
            pts = [tuple(v)[:2] for v in e.flattening(0.01 if kind != "LWPOLYLINE" else 0.01)]
            segments.extend(zip(pts[:-1], pts[1:]))
        elif kind not in ("POINT", "TEXT", "MTEXT"):
            raise ValueError(f"{kind} on a wall layer: not handled by this bench")
    return np.array(segments, np.float64)


# --- IFC ---------------------------------------------------------------------------------------


class _Ifc:
    def __init__(self, path: Path) -> None:
        from planicp.plans.step_file import Ref, StepFile

        self.step = StepFile(path)
        self.Ref = Ref
        unit = 1.0
        for u in self.step.types.get("IFCSIUNIT", []):
            a = self.step.attributes(u)
            if getattr(a[1], "name", "") == "LENGTHUNIT":
                unit = {"MILLI": 0.001, "CENTI": 0.01}.get(getattr(a[2], "name", ""), 1.0)
        self.unit = unit

    def a(self, ref: Any) -> list[Any]:
        return self.step.attributes(ref)

    def axis2(self, ref: Any) -> NDArray[np.float64]:
        """4x4 transform of an IfcAxis2Placement3D/2D (lengths in model units)."""
        attrs = self.a(ref)
        origin = np.array(self.a(attrs[0])[0], np.float64)
        origin = np.pad(origin, (0, 3 - len(origin)))
        kind = self.step.type_of(ref)
        z = np.array([0.0, 0.0, 1.0])
        x = np.array([1.0, 0.0, 0.0])
        if kind == "IFCAXIS2PLACEMENT3D":
            if attrs[1] is not None:
                z = np.array(self.a(attrs[1])[0], np.float64)
            if attrs[2] is not None:
                x = np.array(self.a(attrs[2])[0], np.float64)
        elif attrs[1] is not None:
            x = np.pad(np.array(self.a(attrs[1])[0], np.float64), (0, 1))
        z = z / np.linalg.norm(z)
        x = x - z * (x @ z)
        x = x / np.linalg.norm(x)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, np.cross(z, x), z, origin
        return m

    def placement(self, ref: Any) -> NDArray[np.float64]:
        """World transform of an IfcLocalPlacement chain."""
        if ref is None:
            return np.eye(4)
        relto, rel = self.a(ref)[:2]
        return self.placement(relto) @ self.axis2(rel)

    def solids(self, product: int) -> list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]]:
        """(profile polygon (K, 2) in the solid's position frame, 4x4 world transform of that frame,
        extrusion vector in that frame, model units) of each extruded solid of the product's Body
        representation."""
        attrs = self.a(product)
        world = self.placement(attrs[5])
        out = []
        for rep in self.a(attrs[6])[2]:
            r = self.a(rep)
            if r[1] != "Body":
                continue
            for item in r[3]:
                while self.step.type_of(item) == "IFCBOOLEANCLIPPINGRESULT":
                    item = self.a(item)[1]
                if self.step.type_of(item) != "IFCEXTRUDEDAREASOLID":
                    raise ValueError(f"#{product}: body {self.step.type_of(item)} not handled by this bench")
                profile, position, direction, depth = self.a(item)
                d = np.array(self.a(direction)[0], np.float64)
                out.append((self.profile(profile), world @ self.axis2(position), float(depth) * d / np.linalg.norm(d)))
        return out

    def profile(self, ref: Any) -> NDArray[np.float64]:
        kind = self.step.type_of(ref)
        attrs = self.a(ref)
        if kind == "IFCRECTANGLEPROFILEDEF":
            m = self.axis2(attrs[2]) if attrs[2] is not None else np.eye(4)
            hx, hy = attrs[3] / 2, attrs[4] / 2
            corners = np.array([[-hx, -hy, 0, 1], [hx, -hy, 0, 1], [hx, hy, 0, 1], [-hx, hy, 0, 1]])
            return (corners @ m.T)[:, :2]
        if kind == "IFCARBITRARYCLOSEDPROFILEDEF":
            curve = attrs[2]
            if self.step.type_of(curve) != "IFCPOLYLINE":
                raise ValueError(f"profile curve {self.step.type_of(curve)} not handled by this bench")
            return np.array([self.a(p)[0][:2] for p in self.a(curve)[0]], np.float64)
        raise ValueError(f"profile {kind} not handled by this bench")


def ifc_truth(path: Path, grid: float = 0.01) -> tuple[dict[str, NDArray[np.float64]], list[str]]:
    """The truths' outline points (world x, y, metres) for the lowest storey: "walls less openings at
    the cut" and "walls, no openings"; and one line per opening (its vertical extent)."""
    ifc = _Ifc(path)
    step, u = ifc.step, ifc.unit
    storeys = sorted(step.types["IFCBUILDINGSTOREY"], key=lambda s: ifc.placement(ifc.a(s)[5])[2, 3])
    storey = storeys[0]
    floor_z = ifc.placement(ifc.a(storey)[5])[2, 3] * u
    walls = []
    for rel in step.types.get("IFCRELCONTAINEDINSPATIALSTRUCTURE", []):
        attrs = ifc.a(rel)
        if attrs[5].id == storey:
            walls += [e.id for e in attrs[4] if step.type_of(e).startswith("IFCWALL")]
    voids = {ifc.a(r)[4].id: ifc.a(r)[5].id for r in step.types.get("IFCRELVOIDSELEMENT", [])}
    wall_polys: list[NDArray[np.float64]] = []
    open_polys: list[NDArray[np.float64]] = []
    notes = []
    for wall in walls:
        for poly, m, extrusion in ifc.solids(wall):
            if abs(abs(extrusion[2]) - np.linalg.norm(extrusion)) > 1e-9:
                raise ValueError(f"wall #{wall}: extrusion {extrusion} not vertical: not handled by this bench")
            pts = np.column_stack([poly, np.zeros(len(poly)), np.ones(len(poly))]) @ m.T
            wall_polys.append(pts[:, :2] * u)
    for rel in step.types.get("IFCRELVOIDSELEMENT", []):
        wall, opening = ifc.a(rel)[4].id, ifc.a(rel)[5].id
        if wall not in walls:
            continue
        for poly, m, extrusion in ifc.solids(opening):
            base = np.column_stack([poly, np.zeros(len(poly)), np.ones(len(poly))]) @ m.T
            top = np.column_stack([poly + extrusion[:2], np.full(len(poly), extrusion[2]), np.ones(len(poly))]) @ m.T
            z0 = min(base[:, 2].min(), top[:, 2].min()) * u - floor_z
            z1 = max(base[:, 2].max(), top[:, 2].max()) * u - floor_z
            cut = z0 <= IFC_CUT_HEIGHT <= z1
            fills = [
                step.type_of(step.attributes(r)[5])
                for r in step.types.get("IFCRELFILLSELEMENT", [])
                if step.attributes(r)[4].id == opening
            ]
            notes.append(
                f"opening #{opening} in {ifc.a(wall)[2]} ({', '.join(fills) or 'empty'}): "
                f"{z0:.2f} to {z1:.2f} m above the floor{' - cut' if cut else ''}"
            )
            if cut:  # the opening's footprint: the hull of its prism's corners (openings are boxes)
                hull = cv2.convexHull(np.vstack([base, top])[:, :2].astype(np.float32))[:, 0]
                open_polys.append(hull.astype(np.float64) * u)
    del voids
    everything = np.vstack(wall_polys)
    lo = everything.min(axis=0) - 0.1
    shape = tuple(np.ceil((everything.max(axis=0) + 0.1 - lo) / grid).astype(int))[::-1]

    def fill(polys: list[NDArray[np.float64]]) -> Any:
        mask = np.zeros(shape, np.uint8)
        for p in polys:
            cv2.fillPoly(mask, [np.round((p - lo) / grid * 16).astype(np.int32)], 1, cv2.LINE_8, shift=4)
        return mask

    from drawing_walls import outline_points  # type: ignore[import-not-found]

    walls_mask = fill(wall_polys)
    opened = walls_mask & ~fill(open_polys) & 1
    truths = {}
    for label, mask in (("walls less openings at 1 m", opened), ("walls, no openings", walls_mask)):
        cr = outline_points(mask)  # (col, row) of the faces, pixel units: x = col, y = row
        truths[label] = cr * grid + lo
    return truths, notes


# --- the table ---------------------------------------------------------------------------------


def overlay(
    path: Path, truth: NDArray[np.float64], got: NDArray[np.float64], tol: float, size: int = 900
) -> tuple[float, float]:
    """Draws the overlay PNG (truth grey, extracted green / red, missed truth blue); returns
    (precision, recall)."""
    good = near_share(got, truth, tol)
    found = near_share(truth, got, tol)
    both = np.vstack([truth, got])
    lo, hi = both.min(axis=0), both.max(axis=0)
    px = float((hi - lo).max()) / (size - 20)
    w, h = (np.ceil((hi - lo) / px).astype(int) + 20).tolist()
    img = np.full((h, w, 3), 255, np.uint8)

    def draw(points: NDArray[np.float64], colour: tuple[int, int, int], radius: int) -> None:
        q = np.round((points - lo) / px).astype(int) + 10
        for x, y in q:
            cv2.circle(img, (int(x), int(h - 1 - y)), radius, colour, -1)

    draw(truth, (190, 190, 190), 2)
    draw(truth[~found], (230, 120, 0), 2)
    draw(got[good], (0, 150, 0), 1)
    draw(got[~good], (0, 0, 230), 1)
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), img, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return float(good.mean()), float(found.mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--drawings", type=Path, default=Path("../shared/data/drawings"))
    parser.add_argument("--out", type=Path, default=Path("out/vector_walls"))
    parser.add_argument("--tolerance", type=float, default=0.05, help="metres")
    parser.add_argument("--spacing", type=float, default=0.02, help="metres between points")
    args = parser.parse_args()
    d, tol, spacing = args.drawings, args.tolerance, args.spacing
    truths: list[tuple[str, str, NDArray[np.float64], dict[str, Any]]] = []
    pdf = d / "cmu_newell_simon_floor3.pdf"
    truths.append(
        (
            pdf.name,
            "black 0.06 pt strokes",
            sample_segments(pdf_truth(pdf) * PDF_METRES_PER_POINT, spacing),
            {"scale": "1\"=24'"},
        )
    )
    truths.append((pdf.name, "black 0.06 pt strokes", truths[-1][2], {}))  # its scale from its legend
    dxf = d / "raumzeitlabor_floorplan.dxf"
    dxf_segments = dxf_truth(dxf, ("Base", "Wand (neu)")) * 0.01
    truths.append((dxf.name, "layers Base, Wand (neu)", sample_segments(dxf_segments, spacing), {}))
    ifc = d / "AC20-FZK-Haus.ifc"
    ifc_truths, ifc_notes = ifc_truth(ifc)
    for label, points in ifc_truths.items():
        truths.append((ifc.name, label, points, {}))
    print("| drawing | truth | options | wall points | true points | precision | recall | time |")
    print("|---|---|---|---|---|---|---|---|")
    loaded: dict[tuple[str, str], tuple[NDArray[np.float64], float, tuple[str, ...]]] = {}
    for name, label, truth, options in truths:
        key = (name, repr(options))
        if key not in loaded:
            start = time.perf_counter()
            result = read_plan_file(d / name, spacing=spacing, cache=False, **options)
            loaded[key] = (result.plan.points, time.perf_counter() - start, result.notes)
        got, seconds, _ = loaded[key]
        stem = Path(name).stem + ("_no_openings" if label == "walls, no openings" else "")
        stem += "_legend_scale" if name.endswith(".pdf") and not options else ""
        p, r = overlay(args.out / f"{stem}.png", truth, got, tol)
        shown = " ".join(f"--{k} {v!r}" for k, v in options.items()) or "none"
        print(f"| {name} | {label} | {shown} | {len(got):,} | {len(truth):,} | {p:.1%} | {r:.1%} | {seconds:.1f} s |")
    print()
    for (name, _), (_, _, notes) in loaded.items():
        for note in notes:
            print(f"<!-- {name}: {note} -->")
    for note in dict.fromkeys(ifc_notes):  # an opening with two solids is listed once
        print(f"<!-- {ifc.name}: {note} -->")


if __name__ == "__main__":
    main()
