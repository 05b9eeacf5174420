"""One plan from whatever file a user has: the dispatch the command line shares."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .image_files import check_image_file, require_regular_file
from .plan_formats import missing_extra, plan_format, unsupported_format
from .plan_map import CacheSetting, PlanMap
from .wall_extraction import ExtractedWalls, explain_image


def house_expo_files(folder: str | Path) -> list[Path]:
    """The HouseExpo plans (`*.json`) directly in `folder`, sorted by name (a study's plan set).

    Raises:
        FileNotFoundError: `folder` does not exist.
        NotADirectoryError: it is a file.
        ValueError: it holds no `.json` file.
    """
    path = Path(folder)
    if not path.exists():
        raise FileNotFoundError(f"plan folder {path} does not exist")
    if not path.is_dir():
        raise NotADirectoryError(f"{path} is not a folder")
    files = sorted(p for p in path.iterdir() if p.suffix.lower() == ".json" and p.is_file())
    if not files:
        raise ValueError(f"plan folder {path} holds no HouseExpo .json file")
    return files


@dataclass(frozen=True)
class LoadedPlan:
    """A plan read from a file, with what the reader decided (for `planicp plan` to report).

    Attributes:
        plan: the plan (wall points in metres, map frame).
        kind: the file's format ("image", "ros_map", "house_expo", "dxf", "pdf", "svg", "ifc").
        notes: one line per decision: the scale and where it came from, what was kept as walls
            and what was dropped.
        drawing: of an image read with `explain=True`: what its wall extraction kept and dropped,
            pixel by pixel (for the overlay on the drawing); None otherwise.
    """

    plan: PlanMap
    kind: str
    notes: tuple[str, ...] = ()
    drawing: ExtractedWalls | None = None


def load_plan(
    source: str | Path,
    *,
    resolution: float | None = None,
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    cache: CacheSetting = True,
    spacing: float = 0.02,
    layers: Sequence[str] | None = None,
    scale: str | float | None = None,
    page: int = 1,
    storey: str | int | None = None,
    cut_height: float = 1.0,
    raster: bool | float = False,
    **image_options: Any,
) -> PlanMap:
    """The plan in `source`, chosen by its first bytes and its suffix (see `read_plan_file`)."""
    return read_plan_file(
        source,
        resolution=resolution,
        origin=origin,
        cache=cache,
        spacing=spacing,
        layers=layers,
        scale=scale,
        page=page,
        storey=storey,
        cut_height=cut_height,
        raster=raster,
        **image_options,
    ).plan


def read_plan_file(
    source: str | Path,
    *,
    resolution: float | None = None,
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    cache: CacheSetting = True,
    spacing: float = 0.02,
    layers: Sequence[str] | None = None,
    scale: str | float | None = None,
    page: int = 1,
    storey: str | int | None = None,
    cut_height: float = 1.0,
    raster: bool | float = False,
    explain: bool = False,
    **image_options: Any,
) -> LoadedPlan:
    """The plan in `source`, with what its reader decided. The format is recognised by the file's
    first bytes (PDF, SVG, IFC, DXF, DWG) and otherwise by its suffix (`plan_formats.plan_format`):

    * `.yaml`/`.yml`: a map_server map (its own resolution and origin);
    * `.json`: a HouseExpo plan: its outline sampled every `spacing` metres or, with `resolution`,
      rasterised at that many metres per pixel with 15 cm walls (a plan with a raster, as the
      simulation needs: `PlanMap.from_house_expo`);
    * `.dxf`: a CAD drawing (`layers`: the wall layers, default of the layers shown those named as
      walls and the building's shell around them, all when none is; needs `planicp[cad]`);
    * `.pdf`: a vector PDF (`pdf_plan.pdf_walls`): `layers` its optional content groups, `scale`
      the print scale (default: the one the drawing states), `resolution` metres per point
      instead, `page` from 1; `raster=True` (or a page with no dark line work) renders the page
      at 0.025 m per pixel (`raster=` a number: that many metres per pixel) and reads it as an
      image; needs `planicp[pdf]`;
    * `.svg`: an SVG drawing (`svg_plan.svg_walls`): `layers` the classes, ids or layer names of
      the wall elements, `resolution` metres per user unit or `scale` a print scale; needs
      `planicp[svg]`;
    * `.ifc`: a BIM model (`ifc_plan.ifc_walls`): the walls of `storey` (name or number from 1;
      default the lowest storey with walls) cut `cut_height` metres above its floor, doors and
      windows open;
    * anything else: a plan image, at `resolution` metres per pixel or, without one, at the scale
      its room labels give, read by OCR (`raster_scale`; needs RapidOCR, `drawing_text`); it takes `origin`
      (x, y, yaw of the image's lower-left corner in the map frame) and `image_options`
      (`threshold`, `open_px`, `close_px`, `edge_detector`, `walls`, `wall_extraction`: see
      `PlanMap.from_image`); with `explain`, the wall extraction's decisions are returned too
      (`LoadedPlan.drawing`, and its notes), as `planicp plan` prints and draws them.

    Vector plans are sampled every `spacing` metres, in metres in the map frame.

    Raises:
        FileNotFoundError: `source` does not exist.
        ImportError: the optional extra the format needs is not installed (the message names it).
        ValueError: an image without a resolution whose labels give none (or without RapidOCR
            installed to read them), a format planicp does not read (DWG, ...: the
            message says what to export instead), or a file the reader rejects.
    """
    path = Path(source)
    if not path.exists():
        raise FileNotFoundError(f"plan {path} does not exist")
    kind = plan_format(path)
    refusal = unsupported_format(kind, path)
    if refusal is not None:
        raise ValueError(refusal)
    missing = missing_extra(kind, path)
    if missing is not None:
        raise ImportError(missing)
    if kind == "ros_map":
        return LoadedPlan(PlanMap.from_ros_map(path, cache=cache), kind)
    if kind == "house_expo":
        return LoadedPlan(PlanMap.from_house_expo(path, spacing=spacing, resolution=resolution), kind)
    if kind == "dxf":
        return _dxf_plan(path, layers, spacing)
    if kind == "pdf":
        return _pdf_plan(path, resolution, scale, page, layers, spacing, raster, origin, cache, image_options)
    if kind == "svg":
        return _svg_plan(path, resolution, scale, layers, spacing)
    if kind == "ifc":
        return _ifc_plan(path, storey, cut_height, spacing)
    extraction_options = {k: v for k, v in image_options.items() if k != "edge_detector"}
    scale_notes: tuple[str, ...] = ()
    if resolution is None:
        resolution, scale_notes = _scale_from_labels(path, extraction_options, cache)
    plan = PlanMap.from_image(path, resolution, tuple(origin), cache=cache, **image_options)
    if not explain:
        return LoadedPlan(plan, kind, scale_notes)
    drawing = explain_image(path, resolution, **extraction_options)
    return LoadedPlan(plan, kind, scale_notes + drawing.notes, drawing)


LABEL_SCALE_FORMAT = 1
"""Bumped whenever how a raster's scale is read from its labels changes (cached results are keyed by it)."""


def _scale_from_labels(
    path: Path, extraction_options: dict[str, Any], cache: CacheSetting
) -> tuple[float, tuple[str, ...]]:
    """Metres per pixel of a plan image given without a resolution, read from its room labels by
    OCR (`raster_scale`), and the note saying so; refused naming `--resolution` when the OCR is not
    installed (saying how to install it) or the labels give no scale (saying what OCR read).
    The result is kept in the plan cache (`plan_cache`), keyed by the image's bytes and the
    options, so that a drawing is read by OCR once."""
    import numpy as np

    from .drawing_text import OCR_INSTALL, ocr_available
    from .plan_cache import cache_key, cached
    from .plan_map import _cache_folder

    refusal = f"plan image {path} needs a resolution (metres per pixel, --resolution)"
    if not ocr_available():
        raise ValueError(
            f"{refusal}; with RapidOCR and ONNX Runtime installed ({OCR_INSTALL}; not installed with planicp: "
            "RapidOCR depends on Shapely, whose wheels bundle GEOS, LGPL-2.1) planicp reads it from the drawing's "
            "room labels (dimensions, areas)"
        )
    from .raster_scale import raster_label_scale

    def build() -> dict[str, Any]:
        try:
            found = raster_label_scale(path, **extraction_options)
        except ValueError as exc:  # not an image, no ink: the missing resolution named first
            raise ValueError(f"{refusal}; its room labels could not be read: {exc}") from None
        metres = found.scale.metres_per_unit if found.scale is not None else math.nan
        note = np.frombuffer(found.describe().encode(), dtype=np.uint8)
        return {"metres": np.array([metres]), "note": note}

    try:  # before its bytes are read for the cache key, as PlanMap.from_image does
        require_regular_file(path, "plan image")
        check_image_file(path, "plan image")
    except ValueError as exc:
        raise ValueError(f"{refusal}; its room labels could not be read: {exc}") from None
    params = {"format": LABEL_SCALE_FORMAT, **extraction_options}
    arrays, _ = cached(_cache_folder(cache), cache_key("label_scale", params, [path.read_bytes()]), build)
    metres, note = float(arrays["metres"][0]), bytes(arrays["note"]).decode()
    if not math.isfinite(metres):
        raise ValueError(f"{refusal}: its room labels give none ({note})")
    return metres, (f"scale: {note}",)


def _segments_plan(segments: Any, spacing: float, name: str) -> PlanMap:
    try:
        return PlanMap.from_segments(segments, spacing)
    except ValueError as exc:  # too many points, too large a raster: the drawing's size, so the file's
        raise ValueError(f"{name}: {exc}") from None


def _dxf_plan(path: Path, layers: Sequence[str] | None, spacing: float) -> LoadedPlan:
    from .dxf_plan import dxf_walls

    walls = dxf_walls(path, list(layers) if layers else None)
    plan = _segments_plan(walls.segments, spacing, f"DXF file {str(path)!r}")
    return LoadedPlan(plan, "dxf", walls.notes)


def _pdf_plan(
    path: Path,
    resolution: float | None,
    scale: str | float | None,
    page: int,
    layers: Sequence[str] | None,
    spacing: float,
    raster: bool | float,
    origin: Sequence[float],
    cache: CacheSetting,
    image_options: dict[str, Any],
) -> LoadedPlan:
    from .pdf_plan import pdf_raster, pdf_scale, pdf_walls

    name = f"PDF file {str(path)!r}"
    walls = None
    why = "raster=True"
    if not raster:
        try:
            walls = pdf_walls(
                path, scale=scale, resolution=resolution, page=page, layers=list(layers) if layers else None
            )
        except ValueError as exc:
            if "no dark line work" not in str(exc):
                raise
            why = "it has no dark line work"
    if walls is None:
        metres, source = pdf_scale(path, scale=scale, resolution=resolution, page=page)
        wanted = 0.025 if isinstance(raster, bool) else float(raster)
        gray, pixel = pdf_raster(path, metres, page=page, resolution=wanted)
        plan = PlanMap.from_image(gray, pixel, tuple(origin), cache=cache, **image_options)
        rendered = f"page {page} rendered at {pixel:.4g} m per pixel and read as an image ({why})"
        notes: tuple[str, ...] = (f"scale: {source}", rendered)
        return LoadedPlan(plan, "pdf", notes)
    plan = _segments_plan(walls.segments, spacing, name)
    kept = "; ".join(c.describe() for c in walls.wall_classes)
    dropped = [c for c in walls.classes if c not in walls.wall_classes]
    longest = "; ".join(c.describe() for c in dropped[:4]) + ("; ..." if len(dropped) > 4 else "")
    notes = (
        f"scale: {walls.scale_source}",
        f"walls: {len(walls.segments)} segments from {kept}",
        f"dropped: {len(dropped)} other stroke classes" + (f" ({longest})" if dropped else ""),
    )
    return LoadedPlan(plan, "pdf", notes)


def _svg_plan(
    path: Path, resolution: float | None, scale: str | float | None, layers: Sequence[str] | None, spacing: float
) -> LoadedPlan:
    from .svg_plan import svg_walls

    walls = svg_walls(path, resolution=resolution, scale=scale, select=list(layers) if layers else None)
    plan = _segments_plan(walls.segments, spacing, f"SVG file {str(path)!r}")
    return LoadedPlan(plan, "svg", walls.notes)


def _ifc_plan(path: Path, storey: str | int | None, cut_height: float, spacing: float) -> LoadedPlan:
    from .ifc_plan import ifc_walls

    walls = ifc_walls(path, storey=storey, cut_height=cut_height)
    plan = _segments_plan(walls.segments, spacing, f"IFC file {str(path)!r}")
    return LoadedPlan(plan, "ifc", walls.notes)


def plan_layers(source: str | Path, *, page: int = 1) -> list[str]:
    """What a drawing's walls can be chosen by, one line each (`planicp plan FILE --list-layers`):
    a DXF's layers with their state and entity counts, a PDF page's layers and stroke classes, an
    SVG's classes and layers with their shape counts, an IFC model's storeys.

    Raises:
        FileNotFoundError: no such file. ImportError: the format's extra is missing.
        ValueError: a format without layers (images, maps), or a file the reader rejects.
    """
    path = Path(source)
    if not path.exists():
        raise FileNotFoundError(f"plan {path} does not exist")
    kind = plan_format(path)
    refusal = unsupported_format(kind, path)
    if refusal is not None:
        raise ValueError(refusal)
    missing = missing_extra(kind, path)
    if missing is not None:
        raise ImportError(missing)
    if kind == "dxf":
        from .dxf_plan import dxf_layers

        return [
            f"{layer.name}: {layer.state}; {', '.join(f'{n} {t}' for t, n in layer.entities.items()) or 'empty'}"
            + ("" if layer.read_by_default else " (not read unless named with --layer)")
            for layer in dxf_layers(path)
        ]
    if kind == "pdf":
        from .pdf_plan import default_wall_class, pdf_stroke_classes

        classes, layers = pdf_stroke_classes(path, page=page)
        lines = [f"layer {layer}" for layer in layers]
        walls = default_wall_class(classes)
        return lines + [f"{c.describe()}{' <- walls by default' if c is walls else ''}" for c in classes]
    if kind == "svg":
        from .svg_plan import svg_names

        return [f"{name}: {n} shapes" for name, n in svg_names(path)]
    if kind == "ifc":
        from .ifc_plan import ifc_storeys

        return [
            f"storey {i + 1}: {s.name!r} at {s.elevation:.2f} m, {s.walls} walls"
            for i, s in enumerate(ifc_storeys(path))
        ]
    what = {"image": "an image", "ros_map": "a ROS map", "house_expo": "a HouseExpo plan"}.get(kind, kind)
    raise ValueError(f"plan {path} is {what}, which has no layers: --list-layers is for drawings (DXF, PDF, SVG, IFC)")
