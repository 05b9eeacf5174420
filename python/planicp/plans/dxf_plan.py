"""Wall segments from a DXF drawing: the visible layers, blocks expanded, door swings left out.

What a CAD drawing shows is what its walls are read from (`dxf_walls`):

* layers that are frozen, switched off, not plotted, or named "Defpoints" (CAD's non-plotting
  layer) are skipped unless asked for by name; so are layers named as doors ("door", "Tür",
  "porte", ...): doors are openings, not walls;
* of the layers shown, those NAMED AS WALLS by CAD conventions (A-WALL, Walls, Wand, mur, muro,
  ISO 13567 codes, ...) are read, with the layer that is the building's shell around them, when
  one is (`dxf_wall_layers`); the others shown (furniture, beams, ...) are left out and named in
  the notes. When no layer is named as walls, every layer shown is read, and the notes say so;
* block references (INSERT, and MINSERT arrays) are expanded with their transforms, nested ones
  too (ezdxf's virtual entities), so walls drawn as blocks count; an entity of a block on layer
  "0" takes the layer of the reference, as CAD programs draw it;
* a door swing (an ARC of 60-120 degrees whose centre and one end are joined by a LINE, the door
  leaf; or a polyline of leaf and swing in one piece, the wedge of a door symbol) is left out, on
  any layer: an open door is no wall, and an arc is never closed into a wedge.

`dxf_layers` lists a drawing's layers with their state and entity counts (`planicp plan FILE
--list-layers`). The geometry (chords of arcs, bulges, units from `$INSUNITS`) is
`vector_plan`'s; see `vector_plan.dxf_segments`. Needs the optional extra `cad`
(``pip install 'planicp[cad]'``; ezdxf, MIT).
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import brief, one_line, positive

__all__ = ["DxfLayer", "DxfWalls", "dxf_layers", "dxf_walls"]

MAX_BLOCK_DEPTH = 16
"""Deepest nesting of block references expanded (a block that references itself is refused)."""

MAX_ENTITIES = 2_000_000
"""Most entities a drawing expands to (a block inserted a million times is a mistake, not a plan)."""

DOOR_LAYER = re.compile(r"door|t(?:ü|ue)r(?:en)?\b|porte|puerta|porta|deur|d[øö]rr?|\bovi", re.IGNORECASE)
"""Layer names of doors, skipped unless named in `layers`."""


@dataclass(frozen=True)
class DxfLayer:
    """One layer of a drawing: its name, its state ("on", or "frozen", "off", "not plotted",
    "door layer" joined by ", "; a layer shown then says what the default reading makes of it:
    "on, named as walls", "on, the shell around the walls", "on, not named as walls"), how many
    entities of each type are on it (blocks expanded), and whether `dxf_walls` reads it when no
    layers are named."""

    name: str
    state: str
    entities: dict[str, int]
    read_by_default: bool


@dataclass(frozen=True)
class DxfWalls:
    """The walls of a DXF drawing.

    Attributes:
        segments: (M, 2, 2) segments [[x0, y0], [x1, y1]], metres, map frame.
        layers: the layers the walls were read from.
        skipped_layers: the layers left out, with why ("Doors: frozen", "Shelves: not named as walls").
        door_swings: how many door swings (arc and leaf) were left out (door symbols drawn as one
            polyline are counted in `notes`).
        block_entities: how many wall entities came from block references.
        notes: what was read and left out, one line each (for `planicp plan`).
    """

    segments: NDArray[np.float64]
    layers: tuple[str, ...]
    skipped_layers: tuple[str, ...]
    door_swings: int
    block_entities: int
    notes: tuple[str, ...]


def _read(path: str | PathLike[str]) -> tuple[Any, str]:
    from .vector_plan import _EZDXF_MISSING

    try:
        import ezdxf.recover  # type: ignore[import-not-found,unused-ignore]
        from ezdxf.lldxf.const import DXFError  # type: ignore[import-not-found,unused-ignore]
    except ImportError as exc:
        raise ImportError(_EZDXF_MISSING) from exc
    file = Path(path)
    name = f"DXF file {str(file)!r}"
    if not file.is_file():
        raise FileNotFoundError(f"{name} does not exist" if not file.exists() else f"{name} is not a file")
    try:
        doc, _auditor = ezdxf.recover.readfile(file)
    except MemoryError:
        raise
    except Exception as exc:  # noqa: BLE001 - ezdxf's recovery raises what its parsing meets (IndexError, ...)
        known = isinstance(exc, (DXFError, OSError, UnicodeDecodeError))
        reason = str(exc) if known else f"{type(exc).__name__}: {exc}"
        raise ValueError(f"{name} could not be read as DXF: {one_line(reason)}") from None
    return doc, name


def _layer_state(doc: Any, layer: str) -> str:
    states = []
    entry = doc.layers.get(layer) if layer in doc.layers else None
    if entry is not None:
        if entry.is_frozen():
            states.append("frozen")
        if entry.is_off():
            states.append("off")
        if not int(entry.dxf.get("plot", 1)) or layer.casefold() == "defpoints":
            states.append("not plotted")
    if DOOR_LAYER.search(layer):
        states.append("door layer")
    return ", ".join(states) or "on"


def _expanded(
    entities: Iterable[Any], insert_layer: str | None, depth: int, name: str
) -> Iterator[tuple[Any, str, str, bool]]:
    """(entity, effective layer, type, from a block) for every entity, block references expanded."""
    for entity in entities:
        kind = str(entity.dxftype())
        layer = str(entity.dxf.get("layer", "0"))
        if insert_layer is not None and layer == "0":
            layer = insert_layer
        if kind == "INSERT":
            if depth >= MAX_BLOCK_DEPTH:
                raise ValueError(
                    f"{name}: block references nest deeper than {MAX_BLOCK_DEPTH} levels (a block that "
                    f"references itself?): block {one_line(str(entity.dxf.get('name')), 60)}"
                )
            try:
                inserts = list(entity.multi_insert())
                for insert in inserts:
                    yield from _expanded(list(insert.virtual_entities()), layer, depth + 1, name)
            except ValueError:
                raise
            except Exception:  # noqa: BLE001 - a reference ezdxf cannot expand (a missing block, a zero scale)
                yield entity, layer, "INSERT (not expanded)", depth > 0
        else:
            yield entity, layer, kind, depth > 0


def _entities(doc: Any, name: str) -> list[tuple[Any, str, str, bool]]:
    from .vector_plan import _DAMAGED

    out = []
    try:
        for item in _expanded(doc.modelspace(), None, 0, name):
            out.append(item)
            if len(out) > MAX_ENTITIES:
                raise ValueError(f"{name} expands to more than {MAX_ENTITIES} entities (blocks inserted too often)")
    except _DAMAGED as exc:
        if type(exc) is ValueError and str(exc).startswith(name):
            raise
        raise ValueError(
            f"{name} could not be read as DXF: its modelspace is damaged ({type(exc).__name__}: {one_line(str(exc))})"
        ) from None
    return out


def dxf_layers(path: str | PathLike[str]) -> list[DxfLayer]:
    """The layers of a DXF drawing, sorted by name, with their state, entity counts (blocks
    expanded, an entity of a block on layer "0" counted on the reference's layer) and whether the
    default reading takes them as walls.

    Raises:
        ImportError: ezdxf is not installed. FileNotFoundError, ValueError: as `dxf_walls`.
    """
    doc, name = _read(path)
    counts: dict[str, Counter[str]] = {str(layer.dxf.name): Counter() for layer in doc.layers}
    entities = _entities(doc, name)
    for _, layer, kind, _ in entities:
        counts.setdefault(layer, Counter())[kind] += 1
    states = {layer: _layer_state(doc, layer) for layer in counts}
    shown = {layer for layer, state in states.items() if state == "on"}
    try:
        scale = _units(doc, name)[1]
        choice = _default_choice(doc, _polylines(entities, shown, 0.05 / scale, name), scale)
    except ValueError:  # unknown units or a damaged entity: `dxf_walls` says which; the layers are listed
        choice = _Choice((), (), frozenset(shown), ())
    out = []
    for layer, c in sorted(counts.items()):
        state, read = states[layer], False
        if state == "on":
            read = layer in choice.read
            state = "on, " + choice.role(layer) if choice.named else state
        out.append(DxfLayer(layer, state, dict(sorted(c.items())), read))
    return out


@dataclass(frozen=True)
class _Choice:
    """The default reading's layers: `named` as walls, `shells` around them, `read` (both; every
    layer shown when none is named), `left_out` (shown, with wall entities, not read)."""

    named: tuple[str, ...]
    shells: tuple[str, ...]
    read: frozenset[str]
    left_out: tuple[str, ...]

    def role(self, layer: str) -> str:
        if layer in self.named:
            return "named as walls"
        if layer in self.shells:
            return "the shell around the walls"
        return "not named as walls"

    def note(self) -> str:
        if not self.named:
            return (
                "layers: none is named as walls (wall, A-WALL, Wand, mur, muro, ISO 13567 21/22, ...): every layer "
                "shown read; name the wall layers with --layer (layers=[...]) if some are not walls"
            )
        shells = f"; the shell around them: {', '.join(self.shells)}" if self.shells else ""
        left = (
            f"; left out, not named as walls: {', '.join(self.left_out)} (read them by naming every wall layer "
            "with --layer, layers=[...])"
            if self.left_out
            else ""
        )
        return f"layers: named as walls: {', '.join(self.named)}{shells}{left}"


def _default_choice(doc: Any, items: list[tuple[Any, NDArray[np.float64], str, str, bool]], scale: float) -> _Choice:
    """Which of the layers holding `items` (entity, chain, type, layer, from a block) the default
    reading takes (see `dxf_wall_layers`)."""
    from .dxf_wall_layers import continuous, not_shell, shell_layers, wall_layer

    by_layer: dict[str, list[NDArray[np.float64]]] = {}
    for _, chain, _, layer, _ in items:
        by_layer.setdefault(layer, []).append(chain)
    named = tuple(sorted(layer for layer in by_layer if wall_layer(layer)))
    if not named:
        return _Choice((), (), frozenset(by_layer), ())

    def linetype(layer: str) -> str:
        entry = doc.layers.get(layer) if layer in doc.layers else None
        return str(entry.dxf.get("linetype", "")) if entry is not None else ""

    candidates = {
        layer: chains
        for layer, chains in by_layer.items()
        if layer not in named and not not_shell(layer) and continuous(linetype(layer))
    }
    walls = [chain for layer in named for chain in by_layer[layer]]
    shells = tuple(shell_layers(candidates, walls, scale))
    read = frozenset(named + shells)
    return _Choice(named, shells, read, tuple(sorted(set(by_layer) - read)))


def _units(doc: Any, name: str) -> tuple[int, float]:
    """The drawing's `$INSUNITS` code and metres per drawing unit."""
    from .vector_plan import _DAMAGED, _METRES_PER_UNIT

    try:
        code = doc.header.get("$INSUNITS", 0)
    except _DAMAGED as exc:
        raise ValueError(
            f"{name} could not be read as DXF: its header is damaged ({type(exc).__name__}: {one_line(str(exc))})"
        ) from None
    if isinstance(code, bool) or not isinstance(code, int) or code not in _METRES_PER_UNIT:
        raise ValueError(f"{name} has unknown drawing units $INSUNITS = {brief(code)}")
    return code, _METRES_PER_UNIT[code]


def _polylines(
    entities: list[tuple[Any, str, str, bool]], read: set[str] | frozenset[str], tol_units: float, name: str
) -> list[tuple[Any, NDArray[np.float64], str, str, bool]]:
    """(entity, chain in drawing units, type, layer, from a block) of the wall entities on `read`."""
    from .vector_plan import _DAMAGED, _entity_polyline

    items = []
    for entity, layer, kind, in_block in entities:
        if layer not in read:
            continue
        try:
            polyline = _entity_polyline(entity, tol_units)
        except _DAMAGED as exc:  # besides the ValueErrors here: a value ezdxf's recovery left unset (a None point)
            reason = str(exc) if type(exc) is ValueError else f"damaged ({type(exc).__name__}: {exc})"
            raise ValueError(
                f"{name}: {kind} {one_line(str(entity.dxf.get('handle')), 20)} on layer "
                f"{one_line(layer, 60)}: {one_line(reason)}"
            ) from None
        if polyline is not None:
            items.append((entity, polyline, kind, layer, in_block))
    return items


def _door_swings(items: list[tuple[Any, NDArray[np.float64], str]], scale: float) -> set[int]:
    """Indices into `items` (entity, chain in drawing units, type) of door swings: an ARC of 60 to
    120 degrees and 0.4 to 2.5 m radius, and the LINE (the leaf) from its centre to one of its ends."""
    from ezdxf.entities.arc import Arc  # type: ignore[import-not-found,unused-ignore]
    from ezdxf.entities.lwpolyline import LWPolyline  # type: ignore[import-not-found,unused-ignore]

    found: set[int] = {
        i for i, (entity, _, _) in enumerate(items) if isinstance(entity, LWPolyline) and _door_symbol(entity, scale)
    }
    lines = [(i, chain) for i, (_, chain, kind) in enumerate(items) if kind == "LINE"]
    if not lines:
        return found
    ends = np.array([[c[0], c[-1]] for _, c in lines])  # (L, 2, 2)
    for i, (entity, chain, kind) in enumerate(items):
        if kind != "ARC" or not isinstance(entity, Arc):
            continue
        radius = abs(float(entity.dxf.radius))
        sweep = (float(entity.dxf.end_angle) - float(entity.dxf.start_angle)) % 360.0
        if not (60.0 <= sweep <= 120.0 and 0.4 <= radius * scale <= 2.5):
            continue
        c = entity.ocs().to_wcs(entity.dxf.center)  # the centre in world coordinates, as the chain
        centre = np.array([float(c.x), float(c.y)])
        tol = max(0.03 * radius, 0.01 / scale)
        for arc_end in (chain[0], chain[-1]):
            for a, b in ((0, 1), (1, 0)):
                hit = (np.hypot(*(ends[:, a] - centre).T) <= tol) & (np.hypot(*(ends[:, b] - arc_end).T) <= tol)
                for k in np.flatnonzero(hit):
                    found.update((i, lines[int(k)][0]))
    return found


def _door_symbol(entity: Any, scale: float) -> bool:
    """Whether a polyline is a door drawn in one piece: at most four vertices, one bulge of 60 to
    120 degrees (the swing, 0.4 to 2.5 m radius) and a straight side as long as its radius (the
    leaf). Closed, it is the wedge a door symbol draws."""
    xyb = [(float(x), float(y), float(b)) for x, y, b in entity.get_points("xyb")]
    if not 3 <= len(xyb) <= 4:
        return False
    closed = bool(entity.closed)
    pairs = list(zip(xyb, xyb[1:] + (xyb[:1] if closed else [])))
    bulged = [(p, q) for p, q in pairs if p[2] != 0.0]
    if len(bulged) != 1:
        return False
    (x0, y0, bulge), (x1, y1, _) = bulged[0]
    sweep = 4.0 * math.atan(abs(bulge))
    chord = math.hypot(x1 - x0, y1 - y0)
    if not (math.radians(60) <= sweep <= math.radians(120)) or chord == 0.0:
        return False
    radius = chord / (2.0 * math.sin(sweep / 2.0))
    if not 0.4 <= radius * scale <= 2.5:
        return False
    sides = [math.hypot(q[0] - p[0], q[1] - p[1]) for p, q in pairs if p[2] == 0.0]
    return any(abs(side - radius) <= 0.1 * radius for side in sides)


def dxf_walls(
    path: str | PathLike[str],
    layers: str | Iterable[str] | None = None,
    *,
    arc_tolerance: float = 0.01,
    keep_door_swings: bool = False,
) -> DxfWalls:
    """The walls of a DXF drawing as segments in metres (see the module's description for what is
    read, and `vector_plan.dxf_segments` for the geometry and units).

    Args:
        path: the DXF file.
        layers: the wall layers, compared case-insensitively (a str is one layer), read whatever
            their state; None: of the layers that are on, thawed, plotted and not door layers,
            those named as walls and the shell around them (`dxf_wall_layers`), or all of them
            when none is named as walls.
        arc_tolerance: largest sagitta of a chord replacing an arc, metres.
        keep_door_swings: keep door swings (arc and leaf, or a door symbol's polyline) as walls.

    Raises:
        ImportError: ezdxf is not installed.
        FileNotFoundError: the file does not exist.
        TypeError: `layers` is not None, a str or an iterable of str.
        ValueError: a named layer does not exist (the message lists those that do), no wall
            entity was found (the message lists the layers and their states), the file is not a
            readable DXF, its `$INSUNITS` is unknown, or `arc_tolerance` <= 0.
    """
    from .vector_plan import _DAMAGED, _WALL_TYPES, _layer_names

    tolerance = positive(arc_tolerance, "arc_tolerance", "metres")
    wanted = _layer_names(layers)
    doc, name = _read(path)
    code, scale = _units(doc, name)
    try:
        existing = {str(layer.dxf.name) for layer in doc.layers}
    except _DAMAGED as exc:
        raise ValueError(
            f"{name} could not be read as DXF: its layers are damaged ({type(exc).__name__}: {one_line(str(exc))})"
        ) from None
    entities = _entities(doc, name)
    existing.update(layer for _, layer, _, _ in entities)
    states = {layer: _layer_state(doc, layer) for layer in existing}
    if wanted is not None:
        folded = {layer.casefold() for layer in existing}
        missing = sorted(layer for layer in wanted if layer not in folded)
        if missing:
            raise ValueError(
                f"{name} has no layer {', '.join(map(repr, missing))}; its layers are: "
                f"{one_line(', '.join(sorted(existing)), 300)}"
            )
        read = {layer for layer in existing if layer.casefold() in wanted}
    else:
        read = {layer for layer, state in states.items() if state == "on"}
    found = _polylines(entities, read, tolerance / scale, name)
    choice = None
    if wanted is None:
        choice = _default_choice(doc, found, scale)
        found = [item for item in found if item[3] in choice.read]
        read = set(choice.read)
    skipped = tuple(f"{layer}: {states[layer]}" for layer in sorted(existing - read) if states[layer] != "on")
    if choice is not None:
        skipped += tuple(f"{layer}: not named as walls" for layer in choice.left_out)
    items = [(entity, chain, kind) for entity, chain, kind, _, _ in found]
    used = {layer for _, _, _, layer, _ in found}
    from_blocks = sum(in_block for _, _, _, _, in_block in found)
    doors = set() if keep_door_swings else _door_swings(items, scale)
    pieces = [np.stack([chain[:-1], chain[1:]], axis=1) for i, (_, chain, _) in enumerate(items) if i not in doors]
    if not pieces:
        where = "any layer (of those shown)" if wanted is None else f"layer(s) {', '.join(sorted(wanted))}"
        types = sorted({kind for _, _, kind, _ in entities})
        left_out = f" ({len(doors)} entities of door swings left out)" if doors else ""
        layer_list = "; ".join(f"{layer} ({states[layer]})" for layer in sorted(existing))
        raise ValueError(
            f"{name} has no wall entities ({', '.join(_WALL_TYPES)}) on {where} of its modelspace; "
            f"entity types there: {one_line(', '.join(types), 300) if types else 'none'}"
            f"{left_out}; its layers: {one_line(layer_list, 400)} (name wall layers with layers=[...], --layer)"
        )
    segments = np.concatenate(pieces) * scale
    if not np.isfinite(segments).all():
        raise ValueError(f"{name} has a non-finite coordinate in its wall entities")
    swings = sum(1 for i in doors if items[i][2] == "ARC")
    symbols = sum(1 for i in doors if items[i][2] == "LWPOLYLINE")
    notes = (
        f"scale: $INSUNITS = {code}: {scale:g} m per drawing unit",
        f"walls: {len(segments)} segments from layers {', '.join(sorted(used)) or 'none'}"
        + (f" ({from_blocks} entities from block references)" if from_blocks else ""),
        f"dropped: layers {'; '.join(skipped) if skipped else 'none'}; {swings} door swings (arc and leaf), "
        f"{symbols} door symbols (polyline wedges)",
    ) + ((choice.note(),) if choice is not None else ())
    return DxfWalls(np.ascontiguousarray(segments), tuple(sorted(used)), skipped, swings, from_blocks, notes)
