"""Wall segments from an SVG drawing: its shapes, picked by class, id, layer or colour, in metres.

SVG files are read with svgelements (MIT), which applies transforms, the viewBox and CSS styles:
every path, line, polyline, polygon, rect, circle and ellipse becomes chains of points (curves
followed within about 1 % of their size), in SVG pixels (1/96 inch, the viewBox mapped onto the
drawing's width and height).

Which shapes are walls (`svg_walls`):

* `select`: names of classes, ids or layers. A shape matches a class or id when its own, or that
  of its nearest ancestor that has one, is named (so a wall group's polygon matches the group's
  class "Wall", but the window group nested in the wall group, with its own class "Window", does
  not); it matches a layer when any enclosing Inkscape layer (a group with
  `inkscape:groupmode="layer"`) has that label or id. Compared case-insensitively.
* by default, the shapes of class or id "wall" or "walls" where the drawing names any (CubiCasa
  and BIM exports do), else those on a layer of that name; otherwise the wall colour class as for
  PDFs (`pdf_plan.default_wall_class`: the longest dark class whose line work is mostly connected).

A filled shape's outline is its wall surface (a wall drawn as a filled polygon gives both faces).
When every wall shape is a filled area, the outline of their union is taken (`region_outline`:
the seams between wall polygons are no walls), less the areas of the door and window shapes, so
that doors are gaps.
Coordinates are flipped to y up (map frame), x right, and scaled to metres by `resolution`
(metres per SVG pixel) or `scale` (a print scale: the drawing's physical size times the ratio).
Without either, the room labels in its <text> (a room's dimensions or area written inside it,
`svg_text`) give the scale against the rooms the wall segments enclose
(`label_scale.segments_label_scale`), or the drawing is refused naming both.

Needs the optional extra `svg`: ``pip install 'planicp[svg]'``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import one_line, positive
from .label_scale import RoomLabel, segments_label_scale
from .pdf_plan import StrokeClass, chain_length, connected_length, default_wall_class
from .plan_formats import missing_extra
from .print_scale import parse_print_scale
from .region_outline import region_outline

__all__ = ["SvgWalls", "svg_names", "svg_walls"]

PIXEL_METRES = 0.0254 / 96.0
"""One SVG (CSS) pixel on paper, metres."""

_INKSCAPE = "{http://www.inkscape.org/namespaces/inkscape}"

_OPENINGS = frozenset({"door", "doors", "window", "windows", "opening", "openings"})


@dataclass(frozen=True)
class SvgWalls:
    """The walls read from an SVG drawing.

    Attributes:
        segments: (M, 2, 2) wall segments, metres, map frame (y up).
        metres_per_pixel: metres in the building per SVG pixel.
        selected: what picked the walls ("class, id or layer 'wall'", "stroke #000000 1 px", ...).
        shapes: how many shapes were kept as walls, and how many the drawing has.
        notes: what was read and left out, one line each (for `planicp plan`).
    """

    segments: NDArray[np.float64]
    metres_per_pixel: float
    selected: str
    shapes: tuple[int, int]
    notes: tuple[str, ...]


@dataclass(eq=False)
class _Shape:
    classes: frozenset[str]
    ident: str
    layers: frozenset[str]
    kind: str
    colour: tuple[float, float, float] | None
    width: float
    chains: list[NDArray[np.float64]]
    filled: bool

    @property
    def areas(self) -> list[NDArray[np.float64]]:
        """The closed chains of a filled shape (the areas it covers)."""
        return [c for c in self.chains if self.filled and len(c) >= 4 and np.allclose(c[0], c[-1])]


def _attrs(element: Any) -> dict[str, Any]:
    values = getattr(element, "values", None) or {}
    attributes = values.get("attributes")
    return dict(attributes) if isinstance(attributes, dict) else {}


def _colour(value: Any) -> tuple[float, float, float] | None:
    if value is None or getattr(value, "value", None) is None:
        return None
    try:
        if float(value.opacity) == 0.0:
            return None
        return (float(value.red) / 255.0, float(value.green) / 255.0, float(value.blue) / 255.0)
    except (AttributeError, TypeError, ValueError):
        return None


def _chains(shape: Any) -> list[NDArray[np.float64]]:
    from svgelements import Close, Line, Move, Path  # type: ignore[import-untyped,unused-ignore]

    chains: list[list[tuple[float, float]]] = []
    current: list[tuple[float, float]] = []
    for seg in Path(shape):
        if isinstance(seg, Move):
            if len(current) >= 2:
                chains.append(current)
            current = [(float(seg.end.x), float(seg.end.y))]
            continue
        if seg.start is None or seg.end is None:
            continue
        if not current:
            current = [(float(seg.start.x), float(seg.start.y))]
        if isinstance(seg, (Line, Close)):
            current.append((float(seg.end.x), float(seg.end.y)))
            if isinstance(seg, Close):
                chains.append(current)
                current = [current[-1]]
            continue
        size = math.dist((seg.start.x, seg.start.y), (seg.end.x, seg.end.y))
        try:
            size = max(size, float(seg.length(error=1e-3)))
        except (AttributeError, TypeError, ValueError, ZeroDivisionError):
            pass
        n = min(64, max(4, math.ceil(math.sqrt(max(size, 0.0) / 0.5))))
        for t in np.linspace(0.0, 1.0, n + 1)[1:]:
            p = seg.point(float(t))
            current.append((float(p.x), float(p.y)))
    if len(current) >= 2:
        chains.append(current)
    out = [np.asarray(c, dtype=np.float64) for c in chains]
    return [c for c in out if len(c) >= 2 and np.isfinite(c).all()]


def _walk(group: Any, classes: frozenset[str], ident: str, layers: frozenset[str]) -> Iterator[_Shape]:
    from svgelements import Group, Shape, Text  # type: ignore[import-untyped,unused-ignore]

    for element in group:
        attrs = _attrs(element)
        own_classes = frozenset(str(attrs.get("class", "")).casefold().split())
        here_classes = own_classes or classes
        here_ident = str(attrs.get("id", "")).casefold() or ident
        here_layers = layers
        if attrs.get(f"{_INKSCAPE}groupmode") == "layer" or attrs.get("inkscape:groupmode") == "layer":
            label = str(attrs.get(f"{_INKSCAPE}label", attrs.get("inkscape:label", ""))).casefold()
            here_layers = layers | {label, str(attrs.get("id", "")).casefold()} - {""}
        if isinstance(element, Group):
            yield from _walk(element, here_classes, here_ident, here_layers)
        elif isinstance(element, Shape) and not isinstance(element, Text):
            stroke = _colour(element.stroke)
            width = float(element.stroke_width or 0.0) if stroke is not None else 0.0
            fill = _colour(element.fill)
            if stroke is not None and width > 0.0:
                kind, colour = "stroke", stroke
            elif fill is not None:
                kind, colour, width = "fill", fill, 0.0
            else:
                continue  # neither stroked nor filled: not drawn
            chains = _chains(element)
            if chains:
                yield _Shape(here_classes, here_ident, here_layers, kind, colour, width, chains, fill is not None)


def _matches(shape: _Shape, wanted: frozenset[str]) -> bool:
    return bool(shape.classes & wanted) or shape.ident in wanted or bool(shape.layers & wanted)


def svg_walls(
    path: str | PathLike[str],
    *,
    select: str | Iterable[str] | None = None,
    resolution: float | None = None,
    scale: str | float | None = None,
    openings: bool = True,
) -> SvgWalls:
    """The wall segments of an SVG drawing, in metres (see the module's description).

    Args:
        path: the SVG file.
        select: class, id or layer names of the wall shapes (a str is one); None: the shapes of
            class or id "wall"/"walls", else of layer "wall"/"walls", else the longest dark colour
            class.
        resolution: metres in the building per SVG pixel (user unit after the viewBox).
        scale: instead, the drawing's print scale ("1:100", '1"=8\\'', or the ratio).
        openings: when the walls are filled areas, outline their union and take away the areas
            of shapes of class, id or layer "door", "window" or "opening" (doors become gaps).

    Raises:
        ImportError: the `svg` extra is not installed (the message names it).
        FileNotFoundError: no such file.
        ValueError: not a readable SVG, neither or both of `resolution` and `scale`, or no shape
            matches (the message lists the classes, ids and layers the drawing has).
    """
    file = Path(path)
    message = missing_extra("svg", file)
    if message is not None:
        raise ImportError(message)
    name = f"SVG file {str(file)!r}"
    if not file.is_file():
        raise FileNotFoundError(f"{name} does not exist" if not file.exists() else f"{name} is not a file")
    give = (
        f"{name}: give its scale: resolution= metres per SVG pixel (--resolution), or scale= its print scale "
        "such as '1:100' (--scale); "
    )
    if resolution is not None and scale is not None:
        raise ValueError(give + "not both")
    metres: float | None = None
    if resolution is not None:
        metres = positive(resolution, "resolution", "metres per SVG pixel")
        source = f"resolution given: {metres:g} m per SVG pixel"
    elif scale is not None:
        ratio = parse_print_scale(scale)
        metres = PIXEL_METRES * ratio
        source = f"print scale given: {scale} (1:{ratio:g}) of 1/96-inch SVG pixels"

    from svgelements import SVG  # type: ignore[import-untyped,unused-ignore]

    try:
        svg = SVG.parse(str(file), reify=True)
        shapes = list(_walk(svg, frozenset(), "", frozenset()))
    except (ValueError, ImportError):
        raise
    except Exception as exc:  # noqa: BLE001 - the XML parser and svgelements raise what they meet
        raise ValueError(f"{name} could not be read as SVG: {one_line(f'{type(exc).__name__}: {exc}')}") from None
    if not shapes:
        raise ValueError(f"{name} has no drawn shape (path, line, polyline, polygon, rect, circle)")

    if select is not None:
        wanted = frozenset(s.casefold() for s in ([select] if isinstance(select, str) else list(select)))
        if not wanted:
            raise ValueError("select is empty: name at least one class, id or layer, or pass None")
        chosen = [s for s in shapes if _matches(s, wanted)]
        selected = f"class, id or layer {', '.join(sorted(wanted))}"
    else:
        wanted = frozenset({"wall", "walls"})
        chosen = [s for s in shapes if s.classes & wanted or s.ident in wanted]
        selected = "class or id 'wall' (the drawing names its walls)"
        if not chosen:
            chosen = [s for s in shapes if s.layers & wanted]
            selected = "layer 'walls' (the drawing names its wall layer)"
        if not chosen:
            chosen, selected = _dominant_dark(shapes)
    if not chosen:
        classes = sorted({c for s in shapes for c in s.classes})
        layers = sorted({layer for s in shapes for layer in s.layers})
        raise ValueError(
            f"{name}: no shape matches {selected}; its classes: {one_line(', '.join(classes), 300) or 'none'}; "
            f"layers: {one_line(', '.join(layers), 200) or 'none'} (select=[...], --layer NAME)"
        )
    height = float(svg.height) if isinstance(getattr(svg, "height", None), (int, float)) else 0.0
    areas = [a for s in chosen for a in s.areas]
    holes: list[NDArray[np.float64]] = []
    if openings and areas and all(s.areas for s in chosen):
        # Walls drawn as filled areas: their union's outline, less the doors' and windows' areas.
        holes = [a for s in shapes if s not in chosen and _matches(s, _OPENINGS) for a in s.areas]
        segments = region_outline(areas, holes, tolerance=1e-3)
    else:
        segments = np.concatenate([np.stack([c[:-1], c[1:]], axis=1) for s in chosen for c in s.chains])
    if metres is None:  # neither given: the room labels in its text may say it
        found = segments_label_scale(segments, svg_text(file))
        if found is None:
            raise ValueError(give + "it states none, and no room label in its text gives a room's size")
        metres, source = found.metres_per_unit, f"room labels: {found.source}"
    segments[..., 1] = height - segments[..., 1]
    segments *= metres
    keep = np.hypot(*(segments[:, 1] - segments[:, 0]).T) > 0.0
    segments = np.ascontiguousarray(segments[keep] if keep.any() else segments[:1])
    notes = (
        f"scale: {source}",
        f"walls: {len(segments)} segments from {len(chosen)} shapes picked by {selected}",
        f"dropped: {len(shapes) - len(chosen)} other shapes"
        + (f"; {len(holes)} door and window areas taken away from the wall areas" if holes else ""),
    )
    return SvgWalls(segments, metres, selected, (len(chosen), len(shapes)), notes)


def _length(value: str | None, font_size: float) -> float:
    """An SVG coordinate attribute's first value in user units (px; em and ex of the font size)."""
    match = re.match(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(em|ex|px)?", value or "")
    if match is None:
        return 0.0
    number = float(match.group(1))
    return number * {"em": font_size, "ex": 0.5 * font_size}.get(match.group(2) or "", 1.0)


def svg_text(path: str | PathLike[str]) -> list[RoomLabel]:
    """Every <text> of an SVG with the estimated centre of its words, in user units after the
    transforms and the root's viewBox (y down), hidden text included (a label states a room's
    size whether it is displayed or not: CubiCasa's annotations hide theirs). The position is in
    the first (start-anchored; the last for end-anchored, the middle for middle-anchored) glyph:
    the anchor moved 0.3 em along the text and a third of an em up from the baseline. Without
    the font's metrics the text's extent is unknown, but the room that holds the text holds that
    glyph."""
    import xml.etree.ElementTree as ET

    from svgelements import Matrix  # type: ignore[import-untyped,unused-ignore]

    root = ET.parse(str(path)).getroot()
    viewbox = [float(v) for v in re.split(r"[\s,]+", root.get("viewBox", "").strip()) if v] or None
    top = Matrix()
    if viewbox is not None and len(viewbox) == 4 and viewbox[2] > 0 and viewbox[3] > 0:
        width = _length(root.get("width"), 16.0) or viewbox[2]
        height = _length(root.get("height"), 16.0) or viewbox[3]
        top = Matrix(f"translate({-viewbox[0]},{-viewbox[1]})") * Matrix(
            f"scale({width / viewbox[2]},{height / viewbox[3]})"
        )
    labels: list[RoomLabel] = []

    def style_of(element: Any, name: str) -> str | None:
        found = re.search(rf"(?:^|;)\s*{name}\s*:\s*([^;]+)", element.get("style", ""))
        return found.group(1).strip() if found else element.get(name)

    def walk(element: Any, matrix: Any, font_size: float, anchor: str) -> None:
        transform = element.get("transform")
        here = (Matrix(transform) * matrix) if transform else matrix
        size = _length(style_of(element, "font-size"), font_size) or font_size
        anchored = style_of(element, "text-anchor") or anchor
        if element.tag.rsplit("}", 1)[-1] == "text":
            words = " ".join("".join(element.itertext()).split())
            if words:
                x, y = _length(element.get("x"), size), _length(element.get("y"), size)
                shift = {"start": 0.3, "middle": 0.0, "end": -0.3}.get(anchored, 0.3) * size
                centre = here.point_in_matrix_space((x + shift, y - size / 3.0))
                labels.append(RoomLabel(words, float(centre.x), float(centre.y)))
            return
        for child in element:
            walk(child, here, size, anchored)

    walk(root, top, 16.0, "start")
    return labels


def svg_names(path: str | PathLike[str]) -> list[tuple[str, int]]:
    """The classes ("class Wall"), and layers ("layer Walls") of an SVG drawing's shapes with how
    many shapes each covers: what `svg_walls` can select (`planicp plan FILE --list-layers`)."""
    file = Path(path)
    message = missing_extra("svg", file)
    if message is not None:
        raise ImportError(message)
    from svgelements import SVG  # type: ignore[import-untyped,unused-ignore]

    try:
        shapes = list(_walk(SVG.parse(str(file), reify=True), frozenset(), "", frozenset()))
    except Exception as exc:  # noqa: BLE001 - as in svg_walls
        raise ValueError(f"SVG file {str(file)!r} could not be read as SVG: {one_line(str(exc))}") from None
    counts: dict[str, int] = {}
    for s in shapes:
        for c in s.classes:
            counts[f"class {c}"] = counts.get(f"class {c}", 0) + 1
        for layer in s.layers:
            counts[f"layer {layer}"] = counts.get(f"layer {layer}", 0) + 1
    return sorted(counts.items())


def _dominant_dark(shapes: list[_Shape]) -> tuple[list[_Shape], str]:
    """The shapes of the wall colour class, chosen as for PDFs (`pdf_plan.default_wall_class`: the
    longest dark class whose line work is mostly connected), and how they were chosen."""
    groups: dict[tuple[Any, ...], list[_Shape]] = {}
    for s in shapes:
        if s.colour is not None:
            groups.setdefault((s.kind, tuple(round(c, 2) for c in s.colour), round(s.width, 2)), []).append(s)
    classes = {}
    for key, members in groups.items():
        chains = [c for s in members for c in s.chains]
        length = sum(chain_length(c) for c in chains)
        classes[key] = StrokeClass(key[0], key[1], key[2], length, len(members), (), connected_length(chains))
    best = default_wall_class(list(classes.values()))
    if best is None:
        return [], "the longest dark colour class (the drawing has no dark shape)"
    key = next(k for k, c in classes.items() if c is best)
    hexcolour = "#" + "".join(f"{round(c * 255):02x}" for c in best.colour)
    width = f" {best.width:g} px" if best.kind == "stroke" else ""
    return groups[key], f"the longest dark colour class ({best.kind} {hexcolour}{width})"
