"""Walls out of a cluttered raster drawing: wall pixels kept; text, symbols, door swings,
hatching and fills dropped; each decision recorded pixel by pixel for the overlay.

A drawing is read in pixels (row 0 at the top); the metric settings (`min_run`, `max_opening`)
are turned into pixels with its resolution (metres per pixel). The steps, all OpenCV:

1. **Ink.** The dark pixels: grey below `threshold`, or Otsu's threshold (as `wall_mask`). In a
   colour drawing, ink whose chroma is above `max_chroma` is dropped as "coloured ink": walls are
   drawn black or grey; wood, water, annotations are coloured.
2. **Stroke thickness** of every ink pixel by granulometry: the largest disc (an ellipse kernel
   of k pixels) whose morphological opening still holds the pixel. A 1-2 px pen line (text,
   symbol, door swing, dimension line, hatching, tile) has thickness 1-3; a wall drawn as a band
   has its own width. Ink thicker than `max_wall_thickness` is no wall: it is dropped as
   "fills" (a filled room, a logo, a dark legend box).
3. **Drawing style.** The ink's thicknesses (area-weighted, in log scale) are split in two by
   Otsu's method; the pen width is the thin class's median, and ink is thick above the split
   and above `thick_factor` pen widths. When at least `min_thick_share` of the ink is thick, the
   drawing draws its walls as bands (CubiCasa, CAD exports with poche walls): **thick-wall
   style**. Otherwise its walls are pen lines like everything else: **line style**.
4. **Thick-wall style.** The bands are the union of the openings of the ink by a disc and by a
   square of the thick size (the square keeps the corners of axis-aligned walls square). The
   walls' tone is the bands' median grey; ink further than `tone_tolerance` from it is dropped
   as "another tone" (CubiCasa's black symbols beside its grey walls), and the bands taken again,
   unless that ink makes bands of its own (more than `max_other_tone_share` of the bands): walls
   drawn in two tones.
   Every pen stroke is dropped as "thin strokes", also where it touches a wall (a door swing
   hinged on it, a window's frame lines). Band components longer than `min_run` (the longer side
   of their rotated bounding box) are wall runs; a shorter one is kept as a wall piece (a pier
   between windows, a stub beside a door) when it lies within `max_opening` (the widest door or
   window) of a run and fills at least `min_rectangularity` of its rotated bounding box (a
   straight band), else dropped as "small shapes" (a bold arrow, a stove).
5. **Line style.** The ink is opened with 1-px line kernels of `min_run` metres in 4 directions
   plus the dominant directions of its straight segments (OpenCV's line segment detector): what
   remains are the straight runs at least that long. Text, door swings (arcs), short symbol
   strokes and short hatching hold none and are dropped as "short or curved strokes". A wall
   drawn as two lines (its ends closed) encloses a strip: a hole in the ink at most
   `max_wall_thickness` wide and at least twice `min_run` long. The runs beside such strips are
   the walls; single lines (furniture outlines, dimension lines), small closed shapes (a pillow,
   a chair) and strips side by side, most of their lines between two strips (long hatching), are
   dropped as "unpaired lines". When less than `min_paired` of the runs are paired (walls drawn
   as single lines), the runs are grouped into networks instead (8-connected after closing gaps
   of 2 pen widths); a network with less than `min_network` of the largest one's run pixels (a
   bed or a table apart from the walls) is dropped as "detached shapes".

Doors are openings: a door's leaf and swing are pen strokes (thin in thick-wall drawings, curved
or short in line drawings) and are dropped, leaving the gap in the wall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass as settings_dataclass

from .._settings import SETTINGS, Real, Settings

WALL = 1
"""Label of kept wall pixels in `ExtractedWalls.labels` (0: no ink)."""

DROPPED_CLASSES: dict[int, str] = {
    2: "thin strokes (text, symbols, door swings, hatching)",
    3: "small shapes apart from the walls",
    4: "fills (thicker than walls)",
    5: "short or curved strokes (text, door swings, hatching)",
    6: "detached shapes (furniture)",
    9: "unpaired lines (furniture outlines, dimension lines)",
    7: "coloured ink (not black or grey)",
    8: "ink of another tone than the walls",
}
"""Labels of the dropped ink pixels and what each class is."""

THIN, SMALL, FILL, SHORT, DETACHED, COLOURED, TONE, UNPAIRED = 2, 3, 4, 5, 6, 7, 8, 9


@settings_dataclass(frozen=True, config=SETTINGS)
class WallExtraction(Settings):
    """How walls are told from the rest of a raster drawing (see the module's steps).

    Attributes:
        thick_factor: walls drawn as bands at least this many times the pen width (the thin
            strokes' median thickness) make a thick-wall drawing.
        min_thick_share: ... and the thick ink is at least this share of all ink.
        min_run: metres: a wall run is at least this long (line style: straight runs; thick
            style: a short component apart from every long one is dropped).
        min_network: line style: a network of straight runs shorter than this share of the
            longest network is a detached shape (furniture), not walls.
        max_chroma: ink of a colour image whose chroma (largest minus smallest of its red, green
            and blue values, 0..255) is above this is coloured, not wall: walls are drawn black or
            grey (wood, water, hatching and annotations are coloured).
        min_rectangularity: thick style: a short component kept beside the long ones (a pier
            between two windows, a wall stub beside a door) fills at least this share of its
            rotated bounding box: wall pieces are straight bands, symbols (a stove, a basin) are not.
        max_opening: metres, thick style: a short rectangular component within this of a long
            one is a wall piece between doors and windows (the widest opening it can be across).
        tone_tolerance: thick style, with the grey image: the walls' tone is the median grey of
            the bands; ink further than this (grey levels) from it is another kind of line work
            (CubiCasa's black symbols beside its grey walls) and is dropped before the bands are
            taken again; unless it makes bands of its own, more than `max_other_tone_share` of
            the bands' area: then the drawing draws walls in two tones (new and existing walls)
            and both are kept.
        max_wall_thickness: metres: the thickest wall. Ink thicker is a fill; in line style, the
            widest strip between a wall's two face lines.
        min_paired: line style: when at least this share of the straight runs are paired (a
            parallel run at the drawing's wall thickness beside them), the walls are the paired
            runs; otherwise (walls drawn as single lines) the networks of runs.
    """

    thick_factor: Annotated[float, Real(ge=1.0)] = 2.5
    min_thick_share: Annotated[float, Real(gt=0.0, lt=1.0)] = 0.1
    min_run: Annotated[float, Real(gt=0.0, unit="metres")] = 0.6
    min_network: Annotated[float, Real(gt=0.0, le=1.0)] = 0.1
    max_chroma: Annotated[float, Real(ge=0.0, le=255.0)] = 60.0
    min_rectangularity: Annotated[float, Real(gt=0.0, le=1.0)] = 0.85
    max_opening: Annotated[float, Real(gt=0.0, unit="metres")] = 2.0
    tone_tolerance: Annotated[float, Real(gt=0.0, le=255.0)] = 40.0
    max_other_tone_share: Annotated[float, Real(ge=0.0, le=1.0)] = 0.25
    max_wall_thickness: Annotated[float, Real(gt=0.0, unit="metres")] = 0.6
    min_paired: Annotated[float, Real(ge=0.0, le=1.0)] = 0.5


@dataclass(frozen=True, eq=False)
class ExtractedWalls:
    """What `extract_walls` decided, pixel by pixel.

    Attributes:
        walls: (H, W) bool, image order: the wall pixels kept.
        labels: (H, W) uint8: 0 no ink, `WALL` kept, else the key of `DROPPED_CLASSES` of the
            dropped class.
        style: "thick" (walls drawn as bands) or "line" (walls drawn as pen lines).
        pen_px: the pen width, pixels (median thickness of the thin strokes).
        wall_px: the walls' median stroke thickness, pixels.
        notes: one line per decision, for `planicp plan` to print.
    """

    walls: NDArray[np.bool_]
    labels: NDArray[np.uint8]
    style: str
    pen_px: float
    wall_px: float
    notes: tuple[str, ...] = field(default=())


def _cv2() -> Any:
    import cv2

    return cv2


def stroke_thickness(ink: NDArray[np.bool_], limit: int | None = None) -> NDArray[np.int32]:
    """(H, W) int32: for each ink pixel, the diameter in pixels of the largest disc whose opening
    of `ink` still holds it (0 off the ink). Diameters 1..16 (OpenCV's ellipse kernels), then
    every 15 % (discs by distance transforms, whose cost does not grow with the disc) up to the
    thickest stroke or `limit`, the last disc tried (thicker strokes get `limit`)."""
    cv2 = _cv2()
    top = max(2, min(ink.shape)) if limit is None else max(2, int(limit))
    mask = ink.astype(np.uint8)
    thickness = np.where(ink, 1, 0).astype(np.int32)
    k = 2
    while k <= top:
        if k <= 16:
            opened = _open(mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
        else:
            opened = _open_disc(mask, (k - 1) / 2.0)
        if not opened.any():
            break
        thickness[opened > 0] = k
        mask = opened  # an opening by a larger disc lies within the opening by a smaller one
        if k == top:
            break
        k = min(top, k + 1 if k < 16 else int(k * 1.15) + 1)  # the last disc: `limit` itself
    return thickness


def stroke_thickness_upto(ink: NDArray[np.bool_], limit: int) -> NDArray[np.int32]:
    """`stroke_thickness` with discs up to `limit` pixels."""
    return stroke_thickness(ink, limit)


def _open_disc(mask: NDArray[np.uint8], radius: float) -> NDArray[np.uint8]:
    """Opening of `mask` by a Euclidean disc of `radius` pixels (outside the image no ink), with
    two distance transforms: the centres whose disc fits in the mask, grown by the disc."""
    cv2 = _cv2()
    padded = np.pad(mask, 1)
    inside = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    centres = (inside > radius).astype(np.uint8)
    if not centres.any():
        return np.zeros_like(mask)
    reach = cv2.distanceTransform(1 - centres, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    opened: NDArray[np.uint8] = (reach[1:-1, 1:-1] <= radius).astype(np.uint8) & mask
    return opened


def _open(mask: NDArray[np.uint8], kernel: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Morphological opening, outside the image counted as no ink (a stroke at the edge is not
    lengthened beyond it)."""
    cv2 = _cv2()
    opened: NDArray[np.uint8] = cv2.morphologyEx(
        mask, cv2.MORPH_OPEN, kernel, borderType=cv2.BORDER_CONSTANT, borderValue=0
    )
    return opened


def _otsu_split(values: NDArray[np.float64]) -> float:
    """Otsu's split of `values` (the largest between-class variance): the largest value of the lower class."""
    levels, counts = np.unique(values, return_counts=True)
    if len(levels) < 2:
        return float(levels[0])
    w0 = np.cumsum(counts)[:-1].astype(np.float64)
    s0 = np.cumsum(levels * counts)[:-1]
    total_w, total_s = float(counts.sum()), float((levels * counts).sum())
    w1 = total_w - w0
    between = w0 * w1 * (s0 / w0 - (total_s - s0) / w1) ** 2
    return float(levels[int(np.argmax(between))])


def extract_walls(
    ink: NDArray[np.bool_],
    resolution: float,
    settings: WallExtraction | None = None,
    chroma: NDArray[np.uint8] | None = None,
    gray: NDArray[np.uint8] | None = None,
) -> ExtractedWalls:
    """The walls of a drawing whose dark pixels are `ink` ((H, W) bool, image order), drawn at
    `resolution` metres per pixel (see the module's steps). `chroma` ((H, W), 0..255, from
    `plan_raster.load_gray_and_chroma`) of a colour drawing: its coloured ink is dropped first.
    `gray` ((H, W) uint8, the drawing `ink` was thresholded from): the walls' tone is told from it.

    Raises:
        ValueError: no ink, or nothing of it looks like a wall (the message says how to read the
            image with every dark pixel a wall instead: walls="all-dark").
    """
    cv2 = _cv2()
    s = settings or WallExtraction()
    if not ink.any():
        raise ValueError("the drawing has no dark pixels (no walls to find)")
    coloured = np.zeros(ink.shape, bool) if chroma is None else ink & (chroma > s.max_chroma)
    ink = ink & ~coloured
    if not ink.any():
        raise ValueError(
            f"every dark pixel of the drawing is coloured (chroma above max_chroma={s.max_chroma:g}): raise "
            'max_chroma, or read it with every dark pixel a wall: walls="all-dark"'
        )
    # Discs up to just beyond the thickest wall: thicker ink is a fill, however thick.
    widest = int(math.ceil(s.max_wall_thickness / resolution)) + 1  # a disc wider than any wall
    thickness = stroke_thickness(ink, widest)
    fills = thickness >= widest
    ink = ink & ~fills
    if not ink.any():
        raise ValueError(
            f"every dark pixel of the drawing is in areas thicker than max_wall_thickness={s.max_wall_thickness:g} m "
            '(fills): check the resolution, or read it with every dark pixel a wall: walls="all-dark"'
        )
    values = thickness[ink]
    split = math.exp(_otsu_split(np.log(values.astype(np.float64))))
    thin_values = values[values <= split]
    pen = float(np.median(thin_values)) if len(thin_values) else 1.0
    cut = max(split, s.thick_factor * pen)  # thicker than this: bands (walls, or fills)
    thick_share = float((values > cut).mean())
    run_px = max(3, int(round(s.min_run / resolution)))
    labels = np.zeros(ink.shape, np.uint8)
    labels[coloured] = COLOURED
    labels[fills] = FILL
    if thick_share >= s.min_thick_share:
        walls, labels, wall_px, notes = _thick_walls(
            ink, thickness, int(math.floor(cut)) + 1, run_px, s, labels, gray, resolution
        )
        style = "thick"
        notes = (
            f"thick-wall drawing: pen {pen:.0f} px, walls {wall_px:.0f} px thick (bands thicker than "
            f"{cut:.0f} px are walls, {thick_share:.0%} of the ink)",
            *notes,
        )
    else:
        walls, labels, notes = _line_walls(ink, pen, run_px, s, labels, resolution)
        wall_px = pen
        style = "line"
        notes = (
            f"line drawing: pen {pen:.0f} px; {thick_share:.0%} of the ink thicker than {cut:.0f} px "
            f"(below {s.min_thick_share:.0%}: walls are pen lines)",
            *notes,
        )
    if not walls.any():
        raise ValueError(
            "no walls found in the drawing (nothing long, straight or thick enough): read it with every "
            'dark pixel a wall instead: walls="all-dark" (planicp plan --walls all-dark)'
        )
    labels[walls] = WALL
    counts = np.bincount(labels.ravel(), minlength=256)
    kept = f"kept {int(counts[WALL])} wall pixels of {int(ink.sum())} dark ones"
    dropped = "; ".join(f"{int(counts[k])} px {name}" for k, name in DROPPED_CLASSES.items() if counts[k])
    notes = (*notes, kept + (f"; dropped {dropped}" if dropped else ""))
    del cv2
    return ExtractedWalls(walls, labels, style, pen, wall_px, notes)


def _thick_walls(
    ink: NDArray[np.bool_],
    thickness: NDArray[np.int32],
    k: int,
    run_px: int,
    s: WallExtraction,
    labels: NDArray[np.uint8],
    gray: NDArray[np.uint8] | None,
    resolution: float,
) -> tuple[NDArray[np.bool_], NDArray[np.uint8], float, tuple[str, ...]]:
    cv2 = _cv2()
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    square = cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))

    def bands_of(ink_: NDArray[np.bool_]) -> Any:
        mask = ink_.astype(np.uint8)
        return _open(mask, disc) | _open(mask, square)

    opened = bands_of(ink)
    tone_note = ""
    if gray is not None and opened.any():
        tone = float(np.median(gray[opened > 0]))
        other = ink & (np.abs(gray.astype(np.float64) - tone) > s.tone_tolerance)
        # Another tone with bands of its own is a second wall tone (new and existing walls), kept.
        own = int((bands_of(other) > 0).sum()) if other.any() else 0
        if own > s.max_other_tone_share * int((opened > 0).sum()):
            tone_note = f"walls in two tones: {own} px of bands in another tone than grey {tone:.0f}, kept"
            other = np.zeros_like(other)
        if other.any():
            labels[other] = TONE
            ink = ink & ~other
            opened = bands_of(ink)
            tone_note = (
                f"walls' tone grey {tone:.0f}: {int(other.sum())} px of ink further than {s.tone_tolerance:g} from it"
            )
    bands = opened > 0
    labels[ink & ~bands] = THIN
    count, comp, stats, _ = cv2.connectedComponentsWithStats(opened, connectivity=8)
    wall_px = float(np.median(thickness[bands])) if bands.any() else float(k)
    long = np.zeros(count, bool)
    rectangular = np.zeros(count, bool)
    for i in range(1, count):
        x, y, w, h, area = stats[i]
        sub = comp[y : y + h, x : x + w] == i
        points = np.column_stack(np.nonzero(sub)).astype(np.float32)
        (_, (a, b), _) = cv2.minAreaRect(points)
        long[i] = max(a, b) >= run_px
        rectangular[i] = area >= s.min_rectangularity * max(1.0, (a + 1) * (b + 1))
    anchors = long[comp].astype(np.uint8)
    reach_px = max(1, int(round(s.max_opening / resolution)))
    near = cv2.distanceTransform(1 - anchors, cv2.DIST_L2, 3) <= reach_px
    small = np.zeros(count, bool)
    for i in range(1, count):
        if not long[i]:
            x, y, w, h, _ = stats[i]
            beside = bool(near[y : y + h, x : x + w][comp[y : y + h, x : x + w] == i].any())
            small[i] = not (beside and rectangular[i])
    small_px = small[comp] & bands
    labels[small_px] = SMALL
    walls = bands & ~small_px
    notes = (
        *((tone_note,) if tone_note else ()),
        f"{int(long[1:].sum())} wall runs of at least {run_px} px, {int((~long[1:] & ~small[1:]).sum())} "
        f"short pieces beside them; dropped {int(small.sum())} small shapes",
    )
    return walls, labels, wall_px, notes


def _line_kernel(length: int, angle: float) -> NDArray[np.uint8]:
    """A 1-px line of `length` pixels at `angle` radians (image x right, y down) as a kernel."""
    cv2 = _cv2()
    half = (length - 1) / 2.0
    dx, dy = half * math.cos(angle), half * math.sin(angle)
    size = 2 * int(math.ceil(max(abs(dx), abs(dy)))) + 1
    kernel = np.zeros((size, size), np.uint8)
    c = size // 2
    cv2.line(kernel, (round(c - dx), round(c - dy)), (round(c + dx), round(c + dy)), 1, 1)
    return kernel


def _dominant_angles(ink: NDArray[np.bool_], run_px: int) -> list[float]:
    """Directions (radians in [0, pi)) of the ink's long straight segments (OpenCV's LSD), beyond
    the axes and diagonals: the directions of a rotated drawing's walls."""
    cv2 = _cv2()
    lsd = cv2.createLineSegmentDetector()
    lines = lsd.detect(np.where(ink, 0, 255).astype(np.uint8))[0]
    if lines is None:
        return []
    seg = lines.reshape(-1, 4).astype(np.float64)
    length = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
    angle = np.mod(np.arctan2(seg[:, 3] - seg[:, 1], seg[:, 2] - seg[:, 0]), math.pi)
    keep = length >= run_px / 2
    if not keep.any():
        return []
    hist, edges = np.histogram(angle[keep], bins=90, range=(0.0, math.pi), weights=length[keep])
    found = []
    for i in np.argsort(hist)[::-1][:4]:
        if hist[i] < 0.05 * hist.sum():
            break
        found.append(float((edges[i] + edges[i + 1]) / 2))
    return found


def _paired_runs(
    ink: NDArray[np.bool_], runs: NDArray[np.bool_], pen: float, run_px: int, s: WallExtraction, resolution: float
) -> tuple[NDArray[np.bool_], int]:
    """The straight runs that are a wall's face lines, and the walls' median thickness in pixels
    (0: no wall strip found).

    A wall drawn as two lines (its ends closed) encloses a strip of free space: a hole of the ink,
    at most `max_wall_thickness` wide and at least twice `min_run` long (its area over its width;
    a pillow or a chair drawn as a small rectangle is shorter). The
    runs along such strips are paired; a single line (a furniture outline, a dimension line) has
    no enclosed strip beside it, and the space a room's or a bed's outline encloses is wide. Strips
    side by side (most of their lines with another strip beyond) are hatching."""
    cv2 = _cv2()
    widest = max(3.0, s.max_wall_thickness / resolution)
    free = (~ink).astype(np.uint8)
    count, comp, stats, _ = cv2.connectedComponentsWithStats(free, connectivity=4)
    depth = cv2.distanceTransform(free, cv2.DIST_L2, 3)
    rows, cols = ink.shape
    strip = np.zeros(count, bool)
    widths = np.zeros(count)
    for i in range(1, count):
        x, y, w, h, area = stats[i]
        if x == 0 or y == 0 or x + w == cols or y + h == rows or area < run_px:
            continue  # open to the drawing's edge: outside, not a wall's inside
        sub = comp[y : y + h, x : x + w] == i
        width = 2.0 * float(depth[y : y + h, x : x + w][sub].max())
        if width <= widest and area / max(width, 1.0) >= 2 * run_px:  # long: not a pillow or a chair
            strip[i] = True
            widths[i] = width
    if not strip.any():
        return np.zeros_like(runs), 0
    reach = 2 * max(2, int(math.ceil(2 * pen))) + 1  # the face lines beside the strip, two pens thick
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (reach, reach))
    # Hatching: parallel lines whose strips lie side by side, each line between two strips. A
    # wall's face line has its strip on one side and a room on the other. A strip most of whose
    # lines have another strip beyond them is hatching, not a wall.
    ids = np.where(strip[comp], comp, 0).astype(np.float32)
    highest = cv2.dilate(ids, disc)
    lowest = -cv2.dilate(np.where(ids > 0, -ids, -np.float32(count)), disc)
    lines = runs & (highest > 0)
    shared = lines & (lowest < highest)
    near = np.bincount(highest[lines].astype(np.int64), minlength=count) + np.bincount(
        lowest[lines & (lowest < count)].astype(np.int64), minlength=count
    )
    both = np.bincount(highest[shared].astype(np.int64), minlength=count) + np.bincount(
        lowest[shared].astype(np.int64), minlength=count
    )
    hatching = both > 0.5 * np.maximum(near, 1)
    strip &= ~hatching
    if not strip.any():
        return np.zeros_like(runs), 0
    beside = cv2.dilate(strip[comp].astype(np.uint8), disc) > 0
    return runs & beside, int(round(float(np.median(widths[strip]))))


def _line_walls(
    ink: NDArray[np.bool_], pen: float, run_px: int, s: WallExtraction, labels: NDArray[np.uint8], resolution: float
) -> tuple[NDArray[np.bool_], NDArray[np.uint8], tuple[str, ...]]:
    cv2 = _cv2()
    mask = ink.astype(np.uint8)
    angles = [0.0, math.pi / 4, math.pi / 2, 3 * math.pi / 4]
    for a in _dominant_angles(ink, run_px):
        if min(abs((a - b + math.pi / 2) % math.pi - math.pi / 2) for b in angles) > math.radians(3):
            angles.append(a)
    # A pen line of 2-3 px: a 1-px kernel fits in it along its length; widened by the pen to the line's width.
    runs = np.zeros(ink.shape, np.uint8)
    for a in angles:
        runs |= _open(mask, _line_kernel(run_px, a))
    labels[ink & (runs == 0)] = SHORT
    paired, gap = _paired_runs(ink, runs > 0, pen, run_px, s, resolution)
    if gap > 0 and paired.sum() >= s.min_paired * max(1, int((runs > 0).sum())):
        walls = paired
        labels[(runs > 0) & ~walls] = UNPAIRED
        unpaired = int(((runs > 0) & ~walls).sum())
        notes: tuple[str, ...] = (
            f"straight runs of at least {run_px} px in {len(angles)} directions; walls drawn as pairs of lines "
            f"about {gap} px apart: {int(walls.sum())} px of runs paired, {unpaired} px unpaired",
        )
        return walls, labels, notes
    gap_px = max(3, int(round(2 * pen)) + 1)
    joined = cv2.morphologyEx(runs, cv2.MORPH_CLOSE, np.ones((gap_px, gap_px), np.uint8))
    count, comp, stats, _ = cv2.connectedComponentsWithStats(joined, connectivity=8)
    sizes = np.bincount(comp[runs > 0], minlength=count).astype(np.float64)
    sizes[0] = 0
    keep = sizes >= s.min_network * sizes.max()
    keep[0] = False
    walls = (runs > 0) & keep[comp]
    labels[(runs > 0) & ~walls] = DETACHED
    notes = (
        f"straight runs of at least {run_px} px in {len(angles)} directions, single wall lines; {int(keep.sum())} "
        f"wall networks kept, {int((~keep[1:]).sum())} detached shapes dropped",
    )
    return walls, labels, notes


WALLS_OPTIONS = ("drawing", "all-dark")
"""How an image's walls are read: "drawing" (`extract_walls`) or "all-dark" (every dark pixel)."""


def check_walls_option(walls: Any, settings: WallExtraction | None) -> WallExtraction | None:
    """The extraction settings `walls` asks for (None: every dark pixel is wall).

    Raises:
        ValueError: `walls` is not one of `WALLS_OPTIONS`, or settings given with "all-dark".
        TypeError: `settings` is not a `WallExtraction`.
    """
    if walls not in WALLS_OPTIONS:
        raise ValueError(
            f'walls must be "drawing" (the walls of a drawing, clutter dropped) or "all-dark" (every dark pixel '
            f"a wall), got {walls!r}"
        )
    if settings is not None and not isinstance(settings, WallExtraction):
        raise TypeError(f"wall_extraction must be a WallExtraction, got {type(settings).__name__}")
    if walls == "all-dark":
        if settings is not None:
            raise ValueError('wall_extraction applies to walls="drawing"; with walls="all-dark" leave it out')
        return None
    return settings or WallExtraction()


def explain_image(
    source: str | Path | NDArray[Any],
    resolution: float,
    *,
    threshold: int | None = None,
    open_px: int = 0,
    close_px: int = 0,
    walls: str = "drawing",
    wall_extraction: WallExtraction | None = None,
) -> ExtractedWalls:
    """What `PlanMap.from_image` with the same arguments keeps and drops of an image, pixel by
    pixel, for the overlay `planicp plan` draws on the drawing (`plan_figure.plot_drawing_overlay`).
    With walls="all-dark" every dark pixel is labelled wall."""
    from .plan_raster import load_gray_and_chroma, wall_mask

    extraction = check_walls_option(walls, wall_extraction)
    what = f"plan image {source}" if isinstance(source, (str, Path)) else "plan image"
    gray, chroma = load_gray_and_chroma(source)
    mask = wall_mask(gray, threshold, open_px=open_px, close_px=close_px, what=what)
    if extraction is None:
        labels = np.where(mask, WALL, 0).astype(np.uint8)
        return ExtractedWalls(mask, labels, "all-dark", 0.0, 0.0, ('every dark pixel is a wall (walls="all-dark")',))
    try:
        return extract_walls(mask, resolution, extraction, chroma, gray)
    except ValueError as exc:
        raise ValueError(f"{what}: {exc}") from None
