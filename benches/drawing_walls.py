#!/usr/bin/env python3
"""Walls out of the real raster drawings: what the default extraction keeps and drops, and its
precision and recall against the true walls where a drawing has them.

    python benches/drawing_walls.py [--drawings ../shared/data/drawings] [--notes] [--track SECONDS]

For each raster drawing, the wall surface points `PlanMap.from_image` extracts by default
(walls="drawing") and with every dark pixel a wall (walls="all-dark", the reading before) are
compared with the true wall surfaces:

* `cubicasa_F1_original.png`: the truth is the CubiCasa5K annotation `cubicasa_F1_model.svg`, its
  polygons of class "Wall", united and filled, less the polygons of class "Door" (doors are
  openings) and, in the first reading, of class "Window" too (planicp's SVG reader does the same);
  the truth's surface is the outline of that area. The annotation is drawn in the coordinates
  of the data set's scaled image, not of the original: it is registered to the original by the
  scale and shift (no rotation) that best overlay its filled walls on the drawing's wall-grey
  pixels (the grey level of most of the ink, below Otsu's threshold), searched around the match of the
  bounding boxes of the walls and of the large wall-grey components (5 % of the largest); the fit is printed.
* the apartments have no annotation: what is kept and dropped is reported, with the overlays.

Precision: the share of extracted points within `--tolerance` (0.05 m) of a true surface point;
recall: the share of true surface points (one per pixel of outline) within it of an extracted
point. Distances in pixels of the drawing, the tolerance converted with the drawing's scale
(CubiCasa: 0.0056 m per pixel, from its room label 5'4" x 20'4" through the SVG).
"""

from __future__ import annotations

import argparse
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from planicp import PlanMap
from planicp.plans.plan_raster import PlanRaster, load_gray
from planicp.plans.wall_extraction import explain_image

SVG = "{http://www.w3.org/2000/svg}"

DRAWINGS = {
    # file: metres per pixel (README of the drawings: from a room label / area label)
    "cubicasa_F1_original.png": 0.0056,
    "apartment_se.png": 0.015,
    "apartment_us_feet.png": 0.02,
}


def svg_polygons(path: Path) -> dict[str, list[NDArray[np.float64]]]:
    """The polygons of the groups of class Wall, Door, Window and Space (rooms; first word of the
    class), SVG units."""
    found: dict[str, list[NDArray[np.float64]]] = {"Wall": [], "Door": [], "Window": [], "Space": []}
    for group in ET.parse(path).iter(SVG + "g"):
        kind = (group.get("class") or "").split()[:1]
        if not kind or kind[0] not in found:
            continue
        if group.get("transform"):
            raise ValueError(f"{path}: a {kind[0]} group with a transform: not handled by this bench")
        for polygon in group.findall(SVG + "polygon"):
            xy = np.array([float(v) for v in polygon.get("points", "").replace(",", " ").split()], np.float64)
            found[kind[0]].append(xy.reshape(-1, 2))
    return found


def fill(polygons: list[NDArray[np.float64]], shape: tuple[int, int], scale: float, shift: NDArray[np.float64]) -> Any:
    mask = np.zeros(shape, np.uint8)
    pts = [np.round((p * scale + shift) * 16).astype(np.int32) for p in polygons]
    cv2.fillPoly(mask, pts, 1, lineType=cv2.LINE_8, shift=4)
    return mask


def register(walls: list[NDArray[np.float64]], gray: NDArray[np.uint8]) -> tuple[float, NDArray[np.float64], float]:
    """Scale and shift taking SVG units to image pixels, and the overlap (IoU) they give."""
    otsu, _ = cv2.threshold(gray, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    ink = gray <= otsu
    level = int(np.argmax(np.bincount(gray[ink].ravel(), minlength=256)))  # the wall grey: most of the ink
    target = (np.abs(gray.astype(np.int32) - level) <= 12).astype(np.uint8)
    _, comp, stats, _ = cv2.connectedComponentsWithStats(target, connectivity=8)
    areas = stats[:, cv2.CC_STAT_AREA].copy()
    areas[0] = 0
    large = np.nonzero(areas >= 0.05 * areas.max())[0]  # the wall network, broken by doors; not the text
    rows, cols = np.nonzero(np.isin(comp, large))
    lo_svg, hi_svg = np.vstack(walls).min(axis=0), np.vstack(walls).max(axis=0)
    lo_img = np.array([cols.min(), rows.min()], np.float64)
    hi_img = np.array([cols.max() + 1, rows.max() + 1], np.float64)
    scale0 = float(np.mean((hi_img - lo_img) / (hi_svg - lo_svg)))
    best = (-1.0, scale0, lo_img - lo_svg * scale0)
    for step_s, step_t in ((0.01, 4.0), (0.002, 1.0), (0.0005, 0.25)):
        _, s0, t0 = best
        for s in s0 + step_s * np.arange(-3, 4):
            for dx in step_t * np.arange(-3, 4):
                for dy in step_t * np.arange(-3, 4):
                    t = t0 + np.array([dx, dy]) + (s0 - s) * (lo_svg + hi_svg) / 2
                    m = fill(walls, gray.shape, s, t)
                    iou = float((m & target).sum() / max(1, (m | target).sum()))
                    if iou > best[0]:
                        best = (iou, float(s), t)
    return best[1], best[2], best[0]


def outline_points(area: NDArray[np.uint8]) -> NDArray[np.float64]:
    """(N, 2) (col, row) pixel positions of the faces between area and non-area pixels (as
    `PlanRaster.surface_points` places them)."""
    a = np.pad(area.astype(bool), 1)
    vr, vc = np.nonzero(a[:-1, :] != a[1:, :])
    hr, hc = np.nonzero(a[:, :-1] != a[:, 1:])
    rows = np.concatenate([vr.astype(np.float64), hr - 1 + 0.5])
    cols = np.concatenate([vc - 1 + 0.5, hc.astype(np.float64)])
    return np.column_stack([cols, rows])


def near_share(points: NDArray[np.float64], others: NDArray[np.float64], shape: tuple[int, int], tol: float) -> float:
    """Share of `points` (col, row) within `tol` pixels of one of `others`."""
    grid = np.ones((shape[0] * 2 + 2, shape[1] * 2 + 2), np.uint8)  # half-pixel grid: faces sit on it
    idx = np.round(others * 2).astype(np.int64) + 1
    grid[idx[:, 1], idx[:, 0]] = 0
    dist = cv2.distanceTransform(grid, cv2.DIST_L2, cv2.DIST_MASK_PRECISE) / 2.0
    q = np.round(points * 2).astype(np.int64) + 1
    return float((dist[q[:, 1], q[:, 0]] <= tol).mean())


def plan_pixels(plan: PlanMap, resolution: float, height: int) -> NDArray[np.float64]:
    """The plan's points as (col, row) pixel positions of its image (origin (0, 0, 0))."""
    xy = plan.points
    return np.column_stack([xy[:, 0] / resolution, height - xy[:, 1] / resolution])


def true_building(drawings: Path) -> PlanRaster:
    """The CubiCasa building's TRUE walls in the drawing's map frame (origin (0, 0, 0), 0.0056 m
    per pixel): the SVG's wall polygons less the doors, the windows solid, registered to the
    drawing's pixels; outside the footprint of its rooms and walls solid."""
    name, resolution = "cubicasa_F1_original.png", DRAWINGS["cubicasa_F1_original.png"]
    gray = load_gray(drawings / name)
    polygons = svg_polygons(drawings / "cubicasa_F1_model.svg")
    scale, shift, _ = register(polygons["Wall"], gray)
    walls = fill(polygons["Wall"], gray.shape, scale, shift) & ~fill(polygons["Door"], gray.shape, scale, shift)
    # The building's footprint: its rooms (the balcony too), walls, doors and windows. Outside it is
    # solid, so that the robot stays in the building: the exterior door leads nowhere, and the
    # balcony's open side (a railing in the drawing) is a barrier the LIDAR sees.
    footprint = fill([p for k in ("Space", "Wall", "Door", "Window") for p in polygons[k]], gray.shape, scale, shift)
    footprint = cv2.morphologyEx(footprint, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))  # seams between polygons
    return PlanRaster((walls | (1 - footprint)).astype(bool), resolution, (0.0, 0.0, 0.0))


def track_in_true_walls(
    drawings: Path, duration: float, seeds: list[int], walls_mode: str = "drawing"
) -> list[tuple[int, float, float, float, int, int]]:
    """The drift experiment (`planicp.sim.run_experiment`) in the CubiCasa building: the robot
    drives, and its LIDAR scans, in the TRUE walls (the SVG's wall polygons less the doors, the
    windows solid, registered to the drawing's pixels; outside the footprint of its rooms and walls
    solid), furnished with furniture and people;
    planicp tracks it on the plan EXTRACTED from the drawing (by default; `walls_mode` "all-dark":
    every dark pixel a wall, as before). Both in the drawing's
    map frame (origin (0, 0, 0), 0.0056 m per pixel). Per seed: (seed, position RMS m, position
    max m, heading RMS deg, scans, lost scans)."""
    from planicp.sim.experiment import ExperimentConfig, run_experiment

    name, resolution = "cubicasa_F1_original.png", DRAWINGS["cubicasa_F1_original.png"]
    building = true_building(drawings)
    plan = PlanMap.from_image(drawings / name, resolution, walls=walls_mode, cache=False)
    rows = []
    for seed in seeds:
        recording, _ = run_experiment(plan, ExperimentConfig(duration_s=duration, seed=seed), building=building)
        d, dyaw = recording.errors("estimate")
        lost = 0 if recording.lost is None else int(recording.lost.sum())
        rows.append(
            (
                seed,
                float(np.sqrt(np.mean(d**2))),
                float(d.max()),
                float(np.degrees(np.sqrt(np.mean(dyaw**2)))),
                len(recording.times),
                lost,
            )
        )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--drawings", type=Path, default=Path("../shared/data/drawings"))
    parser.add_argument("--tolerance", type=float, default=0.05, help="metres")
    parser.add_argument("--notes", action="store_true", help="print what the extraction decided on each drawing")
    parser.add_argument("--track", type=float, default=0.0, metavar="SECONDS", help="simulated tracking run length")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--track-walls", default="drawing", choices=("drawing", "all-dark"), help="plan reading")
    args = parser.parse_args()
    print("| drawing | truth | walls | points | precision | recall | time |")
    print("|---|---|---|---|---|---|---|")
    for name, resolution in DRAWINGS.items():
        path = args.drawings / name
        gray = load_gray(path)
        truths: list[tuple[str, NDArray[np.float64]]] = []
        if name == "cubicasa_F1_original.png":
            polygons = svg_polygons(args.drawings / "cubicasa_F1_model.svg")
            scale, shift, iou = register(polygons["Wall"], gray)
            print(f"<!-- {name}: SVG registered x {scale:.4f} + ({shift[0]:.1f}, {shift[1]:.1f}) px, IoU {iou:.3f} -->")
            walls = fill(polygons["Wall"], gray.shape, scale, shift)
            doors = fill(polygons["Door"], gray.shape, scale, shift)
            windows = fill(polygons["Window"], gray.shape, scale, shift)
            truths.append(("walls less doors and windows", outline_points(walls & ~doors & ~windows)))
            truths.append(("walls less doors", outline_points(walls & ~doors)))
        else:
            truths.append(("none", np.zeros((0, 2))))
        for mode in ("drawing", "all-dark"):
            start = time.perf_counter()
            plan = PlanMap.from_image(path, resolution, walls=mode, cache=False)
            seconds = time.perf_counter() - start
            got = plan_pixels(plan, resolution, gray.shape[0])
            tol = args.tolerance / resolution
            for label, truth in truths:
                if len(truth):
                    p = near_share(got, truth, gray.shape, tol)
                    r = near_share(truth, got, gray.shape, tol)
                    cells = f"{p:.1%} | {r:.1%}"
                else:
                    cells = "- | -"
                print(f"| {name} | {label} | {mode} | {len(plan)} | {cells} | {seconds:.1f} s |")
        if args.notes:
            for note in explain_image(path, resolution).notes:
                print(f"<!-- {name}: {note} -->")
    if args.track > 0:
        print()
        print("| seed | position RMS | position max | heading RMS | scans | lost |")
        print("|---|---|---|---|---|---|")
        for seed, rms, worst, heading, scans, lost in track_in_true_walls(
            args.drawings, args.track, args.seeds, args.track_walls
        ):
            print(f"| {seed} | {rms * 100:.1f} cm | {worst * 100:.1f} cm | {heading:.2f} deg | {scans} | {lost} |")


if __name__ == "__main__":
    main()
