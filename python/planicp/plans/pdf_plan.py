"""Wall segments from a vector PDF drawing: its strokes, filtered by colour, width and layer, in metres.

A PDF exported from a CAD program draws walls, hatching, room outlines, furniture and text as
paths: sequences of lines and Bezier curves, each stroked (with a colour and a line width) or
filled. `pdf_walls` reads one page's paths with pdfminer.six, groups them into *stroke classes*
(stroked paths of one colour and width; filled paths of one colour) and keeps the wall class:

* by default (`default_wall_class`), among the DARK classes (every RGB channel at most
  `DARK_CHANNEL`) whose line work is mostly CONNECTED (paths that are closed, turn a corner, or
  meet another path of the class end to end), the longest: architectural drawings draw walls in
  black or dark grey, as outlines and runs meeting at corners, and walls are the line work that
  runs furthest; colour fills, coloured hatching and room tags are not dark, black hatching and
  dimension strokes are mostly single strokes whose ends meet nothing of their kind, and text is
  glyphs, not paths;
* or every path matching what the caller names: `colours`, `widths` (points) and `layers` (the
  PDF's optional content groups, the layers a CAD program exports).

Coordinates are the page as displayed (its /Rotate applied), in PDF points (1/72 inch on paper),
x right and y up, scaled to metres with the drawing's print scale: given (`scale`: "1:100",
'1"=24\\'', a ratio) or stated in the page's text (such as "SCALE 1/8\\" = 1'-0\\""), or metres per
point directly (`resolution`); a page that states none may give it by its legend: the areas it
lists beside colour swatches against the rooms filled in those colours (`legend_scale`), or by
its room labels (`label_scale.segments_label_scale`: a room's dimensions or area written inside
it, against the room the wall segments enclose; the page's text lines and their positions read by
pdfminer). The result is the map frame, metres.

A page with no dark line work (a scanned drawing) is rendered by `pdf_raster` (pypdfium2) into a
grey image for `PlanMap.from_image`.

Needs the optional extra `pdf`: ``pip install 'planicp[pdf]'`` (pdfminer.six, MIT; pypdfium2,
Apache-2.0 or BSD-3-Clause, with PDFium's BSD-style licence).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import one_line, positive
from .label_scale import RoomLabel, segments_label_scale
from .plan_formats import missing_extra
from .print_scale import find_print_scale, parse_print_scale

__all__ = [
    "DARK_CHANNEL",
    "POINT_METRES",
    "PdfWalls",
    "StrokeClass",
    "chain_length",
    "connected_length",
    "default_wall_class",
    "pdf_raster",
    "pdf_scale",
    "pdf_stroke_classes",
    "pdf_walls",
]

POINT_METRES = 0.0254 / 72.0
"""One PDF point (1/72 inch) on paper, metres."""

DARK_CHANNEL = 0.35
"""A colour is dark when none of its red, green and blue channels (0..1) exceeds this: black and
dark greys, not the blues, reds and yellows of fills, hatching and annotations."""

MAX_RENDER_PIXELS = 100_000_000
"""Most pixels of a page rendered for the raster fallback."""


@dataclass(frozen=True)
class StrokeClass:
    """The paths of a page drawn alike: stroked in one colour and width, or filled in one colour.

    Attributes:
        kind: "stroke" or "fill".
        colour: (red, green, blue), each 0..1 (grey and CMYK converted).
        width: line width in points on the page (0 for fills).
        length: total length of its paths on the page, points.
        paths: how many paths.
        layers: the optional content groups (layers) its paths are on ("" for none).
        connected: the length of its connected line work, points: paths that are closed, turn a
            corner, or meet another path of the class end to end (walls do; hatching does not).
    """

    kind: str
    colour: tuple[float, float, float]
    width: float
    length: float
    paths: int
    layers: tuple[str, ...]
    connected: float = 0.0

    @property
    def dark(self) -> bool:
        """Whether every channel of the colour is at most `DARK_CHANNEL`."""
        return max(self.colour) <= DARK_CHANNEL

    def describe(self) -> str:
        """One line: kind, colour as #rrggbb, width, length, paths, layers."""
        hexcolour = "#" + "".join(f"{round(c * 255):02x}" for c in self.colour)
        width = f" {self.width:.3g} pt" if self.kind == "stroke" else ""
        layers = f", layers {', '.join(self.layers)}" if any(self.layers) else ""
        return f"{self.kind} {hexcolour}{width}: {self.paths} paths, {self.length:.0f} pt{layers}"


@dataclass(frozen=True)
class PdfWalls:
    """The walls read from a PDF page.

    Attributes:
        segments: (M, 2, 2) wall segments, metres, map frame (the page as displayed, y up).
        metres_per_point: metres in the building per PDF point.
        scale_source: where the scale came from ("given", "resolution given", or the page's words).
        wall_classes: the stroke classes kept as walls.
        classes: every stroke class of the page, longest first.
        layers: the page's optional content groups (layers) that hold paths.
    """

    segments: NDArray[np.float64]
    metres_per_point: float
    scale_source: str
    wall_classes: tuple[StrokeClass, ...]
    classes: tuple[StrokeClass, ...]
    layers: tuple[str, ...]


@dataclass
class _Path:
    kind: str
    colour: tuple[float, float, float]
    width: float
    layer: str
    chains: list[NDArray[np.float64]]


def _require_pdf(path: Path) -> None:
    message = missing_extra("pdf", path)
    if message is not None:
        raise ImportError(message)


def _rgb(value: Any) -> tuple[float, float, float] | None:
    """A pdfminer colour (grey, RGB or CMYK components, 0..1) as RGB; None for a pattern."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        comps: tuple[float, ...] = (float(value),)
    elif isinstance(value, (list, tuple)) and all(isinstance(v, (int, float)) for v in value):
        comps = tuple(float(v) for v in value)
    else:
        return None
    comps = tuple(min(1.0, max(0.0, c)) for c in comps)
    if len(comps) == 1:
        return (comps[0],) * 3
    if len(comps) == 3:
        return (comps[0], comps[1], comps[2])
    if len(comps) == 4:
        c, m, y, k = comps
        return ((1 - c) * (1 - k), (1 - m) * (1 - k), (1 - y) * (1 - k))
    return None


def _bezier(
    p0: Sequence[float], p1: Sequence[float], p2: Sequence[float], p3: Sequence[float]
) -> list[tuple[float, float]]:
    """Points along a cubic Bezier after p0 (p0 excluded), within about 0.05 pt of it."""
    control = math.dist(p0, p1) + math.dist(p1, p2) + math.dist(p2, p3)
    n = min(64, max(2, math.ceil(math.sqrt(control / 0.4))))
    t = np.linspace(0.0, 1.0, n + 1)[1:, None]
    a, b, c, d = (np.asarray(p, dtype=np.float64) for p in (p0, p1, p2, p3))
    pts = (1 - t) ** 3 * a + 3 * (1 - t) ** 2 * t * b + 3 * (1 - t) * t**2 * c + t**3 * d
    return [(float(x), float(y)) for x, y in pts]


def _chains(path: Sequence[Any], ctm: Sequence[float]) -> list[NDArray[np.float64]]:
    """The subpaths of a PDF path (operators m, l, c, v, y, h), curves flattened, as (K >= 2, 2)
    chains of page points (`ctm` applied)."""
    chains: list[list[tuple[float, float]]] = []
    current: list[tuple[float, float]] = []
    for op in path:
        kind = op[0]
        args = [float(v) for v in op[1:]]
        if kind == "m":
            if len(current) >= 2:
                chains.append(current)
            current = [(args[0], args[1])]
        elif not current:
            continue
        elif kind == "l":
            current.append((args[0], args[1]))
        elif kind == "c":
            current.extend(_bezier(current[-1], args[0:2], args[2:4], args[4:6]))
        elif kind == "v":
            current.extend(_bezier(current[-1], current[-1], args[0:2], args[2:4]))
        elif kind == "y":
            current.extend(_bezier(current[-1], args[0:2], args[2:4], args[2:4]))
        elif kind == "h":
            if current[-1] != current[0]:
                current.append(current[0])
            chains.append(current)
            current = [current[0]]
    if len(current) >= 2:
        chains.append(current)
    a, b, c, d, e, f = (float(v) for v in ctm)
    out = []
    for chain in chains:
        xy = np.asarray(chain, dtype=np.float64)
        out.append(np.column_stack([a * xy[:, 0] + c * xy[:, 1] + e, b * xy[:, 0] + d * xy[:, 1] + f]))
    return out


def _read_paths(file: Path, page_index: int) -> tuple[list[_Path], str]:
    """Every painted path of page `page_index` (0-based) and the page's text."""
    from pdfminer.high_level import extract_text
    from pdfminer.pdfdevice import PDFDevice
    from pdfminer.pdfinterp import PDFPageInterpreter, PDFResourceManager
    from pdfminer.pdfpage import PDFPage
    from pdfminer.pdftypes import resolve1
    from pdfminer.psparser import PSLiteral

    class Collector(PDFDevice):
        def __init__(self, rsrcmgr: PDFResourceManager) -> None:
            super().__init__(rsrcmgr)
            self.paths: list[_Path] = []
            self.layers: list[str] = []
            self.properties: dict[str, str] = {}

        def begin_page(self, page: PDFPage, ctm: Any) -> None:
            super().begin_page(page, ctm)
            props = resolve1(resolve1(page.resources or {}).get("Properties", {})) or {}
            for key, value in dict(props).items():
                entry = resolve1(value)
                if isinstance(entry, dict):
                    name = resolve1(entry.get("Name"))
                    if name is None and "OCGs" in entry:  # a membership dictionary: its first group
                        groups = resolve1(entry["OCGs"])
                        first = resolve1(groups[0] if isinstance(groups, list) and groups else groups)
                        name = resolve1(first.get("Name")) if isinstance(first, dict) else None
                    if isinstance(name, bytes):
                        name = name.decode("utf-8", "replace")
                    if name is not None:
                        self.properties[str(key)] = str(name)

        def begin_tag(self, tag: PSLiteral, props: Any = None) -> None:
            layer = self.layers[-1] if self.layers else ""
            if getattr(tag, "name", None) == "OC":
                key = props.name if isinstance(props, PSLiteral) else None
                layer = self.properties.get(str(key), str(key)) if key is not None else layer
            self.layers.append(layer)

        def end_tag(self) -> None:
            if self.layers:
                self.layers.pop()

        def paint_path(self, gstate: Any, stroke: bool, fill: bool, evenodd: bool, path: Any) -> None:
            colour = _rgb(gstate.scolor if stroke else gstate.ncolor)
            if colour is None or not (stroke or fill):
                return
            ctm = self.ctm or (1.0, 0.0, 0.0, 1.0, 0.0, 0.0)
            a, b, c, d = (float(v) for v in ctm[:4])
            width = float(gstate.linewidth or 0.0) * math.sqrt(abs(a * d - b * c)) if stroke else 0.0
            chains = _chains(path, ctm)
            if chains:
                layer = self.layers[-1] if self.layers else ""
                self.paths.append(_Path("stroke" if stroke else "fill", colour, width, layer, chains))

    with open(file, "rb") as f:
        pages = list(PDFPage.get_pages(f))
        if not pages:
            raise ValueError(f"PDF file {str(file)!r} has no pages")
        if not 0 <= page_index < len(pages):
            raise ValueError(f"PDF file {str(file)!r} has {len(pages)} page(s); page {page_index + 1} does not exist")
        manager = PDFResourceManager()
        device = Collector(manager)
        PDFPageInterpreter(manager, device).process_page(pages[page_index])
    text = extract_text(str(file), page_numbers=[page_index])
    return device.paths, text


def _classes(paths: list[_Path]) -> tuple[dict[tuple[Any, ...], list[_Path]], list[StrokeClass]]:
    groups: dict[tuple[Any, ...], list[_Path]] = {}
    for p in paths:
        key = (p.kind, tuple(round(c, 2) for c in p.colour), round(p.width, 2))
        groups.setdefault(key, []).append(p)
    classes = []
    for (kind, colour, width), members in groups.items():
        chains = [ch for p in members for ch in p.chains]
        length = sum(chain_length(ch) for ch in chains)
        layers = tuple(sorted({p.layer for p in members}))
        classes.append(StrokeClass(kind, colour, width, length, len(members), layers, connected_length(chains)))
    classes.sort(key=lambda c: -c.length)
    return groups, classes


def default_wall_class(classes: Sequence[StrokeClass]) -> StrokeClass | None:
    """The class `pdf_walls` takes as walls when told nothing: among the dark classes whose line
    work is mostly connected (at least `CONNECTED_SHARE` of their length), the longest; if none is,
    the dark class with the most connected length; None without dark classes."""
    dark = [c for c in classes if c.dark]
    if not dark:
        return None
    runs = [c for c in dark if c.connected >= CONNECTED_SHARE * c.length]
    if runs:
        return max(runs, key=lambda c: c.length)
    return max(dark, key=lambda c: (c.connected, c.length))


CONNECTED_SHARE = 0.5
"""The share of a class's length that must be connected line work for it to count as walls first:
the CMU drawing's walls are 96 % connected, its hatching 21-23 %, its thin black labels' strokes 15 %."""


def chain_length(chain: NDArray[np.float64]) -> float:
    """Length of a (K, 2) chain of points, in its units."""
    return float(np.hypot(*np.diff(chain, axis=0).T).sum())


CONNECT_TOLERANCE = 0.5
"""Ends of two paths closer than this (points on the page, 0.18 mm) join them."""


def connected_length(chains: list[NDArray[np.float64]]) -> float:
    """Length of the chains that are part of connected line work: closed, turning a corner (three
    or more vertices), or meeting another chain of the class end to end (within
    `CONNECT_TOLERANCE`). Walls are drawn so, as outlines and runs meeting at corners; hatching
    and dimension strokes are single straight strokes whose ends meet nothing of their own kind."""
    ends: dict[tuple[int, ...], int] = {}
    keys = []
    for chain in chains:
        pair = [tuple(int(v) for v in np.floor(chain[k] / CONNECT_TOLERANCE)) for k in (0, -1)]
        keys.append(pair)
        for key in set(pair):
            ends[key] = ends.get(key, 0) + 1
    total = 0.0
    for chain, pair in zip(chains, keys):
        closed = len(chain) >= 3 and bool(np.allclose(chain[0], chain[-1]))
        if closed or len(chain) >= 3 or any(ends[key] > (2 if pair[0] == pair[1] else 1) for key in pair):
            total += chain_length(chain)
    return total


def _parse_colour(value: Any) -> tuple[float, float, float]:
    named = {"black": (0.0, 0.0, 0.0), "white": (1.0, 1.0, 1.0), "red": (1.0, 0.0, 0.0), "blue": (0.0, 0.0, 1.0)}
    if isinstance(value, str):
        text = value.strip().lower()
        if text in named:
            return named[text]
        if text.startswith("#") and len(text) in (4, 7):
            digits = text[1:] if len(text) == 7 else "".join(ch * 2 for ch in text[1:])
            try:
                return tuple(int(digits[i : i + 2], 16) / 255.0 for i in (0, 2, 4))  # type: ignore[return-value]
            except ValueError:
                pass
        raise ValueError(f"colour {value!r} is not understood: give '#rrggbb', 'black' or (r, g, b) in 0..1")
    rgb = _rgb(value)
    if rgb is None:
        raise ValueError(f"colour {value!r} is not understood: give '#rrggbb', 'black' or (r, g, b) in 0..1")
    return rgb


def pdf_walls(
    path: str | PathLike[str],
    *,
    scale: str | float | None = None,
    resolution: float | None = None,
    page: int = 1,
    colours: Iterable[Any] | None = None,
    widths: Iterable[float] | None = None,
    layers: Iterable[str] | None = None,
) -> PdfWalls:
    """The wall segments of one page of a vector PDF, in metres (see the module's description).

    Args:
        path: the PDF file.
        scale: the drawing's print scale ("1:100", '1"=24\\'', or the ratio, 100); None: the
            scale the page's text states, else the one its legend's areas give (`legend_scale`).
        resolution: metres in the building per PDF point, instead of `scale`.
        page: which page, from 1.
        colours: keep only paths of these colours ('#000000', 'black', (r, g, b) in 0..1),
            compared within 2 % per channel.
        widths: keep only strokes of these widths, points (within 0.01 pt or 5 %).
        layers: keep only paths on these optional content groups (the PDF's layers), compared
            case-insensitively.

    With none of `colours`, `widths` and `layers`, the wall class is `default_wall_class`: the
    longest dark class (stroked or filled) whose line work is mostly connected.

    Returns:
        `PdfWalls`: segments (metres, map frame), the scale and where it came from, and the page's
        stroke classes (for `planicp plan FILE --list-layers`).

    Raises:
        ImportError: the `pdf` extra is not installed (the message names it).
        FileNotFoundError: no such file.
        ValueError: not a readable PDF, no such page, no scale given or stated, no dark line work
            (draw it from the raster: `pdf_raster`), or nothing matches the filters; the message
            lists the page's classes and layers.
    """
    file = Path(path)
    _require_pdf(file)
    name = f"PDF file {str(file)!r}"
    if not file.is_file():
        raise FileNotFoundError(f"{name} does not exist" if not file.exists() else f"{name} is not a file")
    if isinstance(page, bool) or not isinstance(page, int) or page < 1:
        raise ValueError(f"page must be a page number from 1, got {page!r}")
    try:
        paths, text = _read_paths(file, page - 1)
    except (ValueError, ImportError):
        raise
    except Exception as exc:  # noqa: BLE001 - pdfminer raises what its parser meets (PSEOF, PDFSyntaxError, ...)
        raise ValueError(f"{name} could not be read as PDF: {one_line(f'{type(exc).__name__}: {exc}')}") from None

    try:
        metres, source = _scale(name, scale, resolution, text, file, page)
        stated = True
    except _NoStatedScale:  # its room labels may still say it (below, once the walls are known)
        metres, source, stated = math.nan, "", False
    groups, classes = _classes(paths)
    all_layers = tuple(sorted({p.layer for p in paths if p.layer}))
    listing = "; ".join(c.describe() for c in classes[:8]) or "none"
    if colours is None and widths is None and layers is None:
        wall_class = default_wall_class(classes)
        if wall_class is None:
            raise ValueError(
                f"{name}, page {page} has no dark line work (paths: {listing}): if it is a scanned drawing, "
                "read it as a raster (raster=True, planicp plan --raster); otherwise name the wall colour or layer"
            )
        chosen = [wall_class]
    else:
        want_colours = [_parse_colour(c) for c in colours] if colours is not None else None
        want_widths = [positive(w, "width", "points") for w in widths] if widths is not None else None
        want_layers = {str(layer).casefold() for layer in layers} if layers is not None else None
        if want_layers is not None:
            unknown = sorted(w for w in want_layers if w not in {a.casefold() for a in all_layers})
            if unknown:
                raise ValueError(
                    f"{name}, page {page} has no layer {', '.join(map(repr, unknown))}; its layers are: "
                    f"{', '.join(all_layers) or 'none (the PDF has no optional content groups)'}"
                )
        chosen = [
            c
            for c in classes
            if (want_colours is None or any(max(abs(a - b) for a, b in zip(c.colour, w)) <= 0.02 for w in want_colours))
            and (want_widths is None or any(abs(c.width - w) <= max(0.01, 0.05 * w) for w in want_widths))
            and (want_layers is None or any(layer.casefold() in want_layers for layer in c.layers))
        ]
        if not chosen:
            raise ValueError(
                f"{name}, page {page}: no path matches the colours, widths and layers given; its classes: {listing}"
            )
    pieces = []
    for cls in chosen:
        key = (cls.kind, cls.colour, cls.width)
        for p in groups[key]:
            if layers is not None and p.layer.casefold() not in {str(x).casefold() for x in layers}:
                continue
            for chain in p.chains:
                pieces.append(np.stack([chain[:-1], chain[1:]], axis=1))
    if not stated:  # the page states no print scale: its room labels may say what it is
        flipped = np.concatenate(pieces) * np.array([1.0, -1.0])  # y down, as label_scale measures
        labels = [
            RoomLabel(words, 0.5 * (x0 + x1), -0.5 * (y0 + y1))
            for words, (x0, y0, x1, y1) in _text_lines(file, page - 1)
        ]
        found = segments_label_scale(flipped, labels)
        if found is None:
            raise ValueError(f"{_no_print_scale(name)}; no room label (dimensions, area) in a room gives it either")
        metres, source = found.metres_per_unit, f"room labels: {found.source}"
    segments = np.concatenate(pieces) * metres
    keep = np.hypot(*(segments[:, 1] - segments[:, 0]).T) > 0.0
    segments = np.ascontiguousarray(segments[keep] if keep.any() else segments[:1])
    return PdfWalls(segments, metres, source, tuple(chosen), tuple(classes), all_layers)


def pdf_stroke_classes(path: str | PathLike[str], *, page: int = 1) -> tuple[list[StrokeClass], list[str]]:
    """The stroke classes of a PDF page, longest first, and its layers (optional content groups):
    what `pdf_walls` chooses from (`planicp plan FILE --list-layers`)."""
    file = Path(path)
    _require_pdf(file)
    try:
        paths, _ = _read_paths(file, page - 1)
    except (ValueError, ImportError):
        raise
    except Exception as exc:  # noqa: BLE001 - as in pdf_walls
        raise ValueError(f"PDF file {str(file)!r} could not be read as PDF: {one_line(str(exc))}") from None
    return _classes(paths)[1], sorted({p.layer for p in paths if p.layer})


def pdf_scale(
    path: str | PathLike[str], *, scale: str | float | None = None, resolution: float | None = None, page: int = 1
) -> tuple[float, str]:
    """Metres per PDF point of a drawing, and where that came from: `resolution` (metres per
    point) or `scale` (a print scale) when given, else the print scale page `page` states."""
    file = Path(path)
    _require_pdf(file)
    text = ""
    if scale is None and resolution is None:
        from pdfminer.high_level import extract_text

        try:
            text = extract_text(str(file), page_numbers=[page - 1])
        except Exception as exc:  # noqa: BLE001 - as in pdf_walls
            raise ValueError(f"PDF file {str(file)!r} could not be read as PDF: {one_line(str(exc))}") from None
    return _scale(f"PDF file {str(file)!r}", scale, resolution, text, file, page)


def _text_lines(file: Path, page_index: int) -> list[tuple[str, tuple[float, float, float, float]]]:
    """Each line of text on page `page_index` (0-based) with its box (x0, y0, x1, y1), points, in
    the frame of the page's paths (the page as displayed, y up)."""
    from pdfminer.high_level import extract_pages
    from pdfminer.layout import LTContainer, LTTextLine

    lines: list[tuple[str, tuple[float, float, float, float]]] = []

    def walk(item: Any) -> None:
        if isinstance(item, LTTextLine):
            lines.append((item.get_text().strip(), tuple(float(v) for v in item.bbox)))  # type: ignore[arg-type]
        elif isinstance(item, LTContainer):
            for child in item:
                walk(child)

    for page in extract_pages(str(file), page_numbers=[page_index]):
        walk(page)
    return lines


class _NoStatedScale(ValueError):
    """The page states no scale: no print scale in its text, no areas in a legend."""


def _no_print_scale(name: str) -> str:
    return (
        f"{name} states no print scale in its text (nor areas in a legend beside the colours of its rooms): "
        "give it, e.g. scale='1:100' or '1\"=24\\'' (planicp plan --scale '1:100'), or resolution= metres per "
        "PDF point"
    )


def _scale(
    name: str, scale: str | float | None, resolution: float | None, text: str, file: Path | None = None, page: int = 1
) -> tuple[float, str]:
    """Metres per PDF point and where that came from: given, else the print scale the text
    states, else (with `file`) the scale page `page`'s legend gives by its areas (`legend_scale`).

    Raises:
        _NoStatedScale: none of these gives it.
    """
    if scale is not None and resolution is not None:
        raise ValueError("give the PDF's print scale or its resolution (metres per point), not both")
    if resolution is not None:
        return positive(resolution, "resolution", "metres per point"), f"resolution given: {resolution:g} m per point"
    if scale is not None:
        ratio = parse_print_scale(scale)
        return POINT_METRES * ratio, f"print scale given: {scale} (1:{ratio:g})"
    stated = find_print_scale(text)
    if stated is None:
        if file is not None:
            from .legend_scale import legend_scale

            legend = legend_scale(file, page=page)
            if legend is not None:
                return legend.metres_per_point, legend.describe()
        raise _NoStatedScale(_no_print_scale(name))
    ratio, words = stated
    return POINT_METRES * ratio, f"print scale stated in the drawing: {words!r} (1:{ratio:g})"


def pdf_raster(
    path: str | PathLike[str],
    metres_per_point: float,
    *,
    page: int = 1,
    resolution: float = 0.025,
) -> tuple[NDArray[np.uint8], float]:
    """One page of a PDF rendered to a grey image (pypdfium2), for `PlanMap.from_image`.

    Args:
        path: the PDF file.
        metres_per_point: metres in the building per PDF point (from the print scale).
        page: which page, from 1.
        resolution: metres in the building per pixel wanted; the page is rendered at the pixel
            size that gives it, within `MAX_RENDER_PIXELS`.

    Returns:
        (grey image, row 0 the top of the page; metres per pixel of it).
    """
    file = Path(path)
    _require_pdf(file)
    import pypdfium2 as pdfium  # type: ignore[import-untyped,unused-ignore]

    mpp = positive(metres_per_point, "metres_per_point", "metres per point")
    res = positive(resolution, "resolution", "metres per pixel")
    try:
        document = pdfium.PdfDocument(str(file))
    except pdfium.PdfiumError as exc:
        raise ValueError(f"PDF file {str(file)!r} could not be read as PDF: {one_line(str(exc))}") from None
    try:
        if not 1 <= page <= len(document):
            raise ValueError(f"PDF file {str(file)!r} has {len(document)} page(s); page {page} does not exist")
        pdf_page = document[page - 1]
        width, height = pdf_page.get_size()
        pixels_per_point = mpp / res
        if width * height * pixels_per_point**2 > MAX_RENDER_PIXELS:
            pixels_per_point = math.sqrt(MAX_RENDER_PIXELS / (width * height))
        bitmap = pdf_page.render(scale=pixels_per_point, grayscale=True)
        image = np.array(bitmap.to_numpy(), dtype=np.uint8)
    finally:
        document.close()
    if image.ndim == 3:
        image = image[..., :3].mean(axis=2).astype(np.uint8)
    return np.ascontiguousarray(image), mpp / pixels_per_point
