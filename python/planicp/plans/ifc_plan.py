"""Wall segments from an IFC building model: one storey's walls cut at a height, doors and windows open.

A LIDAR on a robot sees the walls at its own height, so the plan of a storey is its walls cut by a
horizontal plane `cut_height` metres above the storey's floor (1.0 m by default: above skirting
and furniture tops, below most window heads). `ifc_walls` reads the model (a STEP file: IFC2X3,
IFC4, IFC4X3) with planicp's own reader (`step_file`), and for the chosen storey:

* takes its walls (IfcWall, IfcWallStandardCase, IfcWallElementedCase, IfcCurtainWall is not a
  wall to a LIDAR and is left out), those the model places in the storey
  (IfcRelContainedInSpatialStructure);
* cuts each wall's body: IfcExtrudedAreaSolid of an IfcRectangleProfileDef, IfcCircleProfileDef,
  IfcArbitraryClosedProfileDef (IfcPolyline or IfcIndexedPolyCurve outline) or
  IfcArbitraryProfileDefWithVoids, extruded vertically or horizontally, placed by IfcLocalPlacement
  chains, IfcMappedItem and IfcBooleanClippingResult (its first operand: the clipping of a gable
  wall by its roof planes does not change the wall at a cut below the roof);
* takes away the wall's openings (IfcRelVoidsElement: IfcOpeningElement, the holes doors and
  windows fill) cut the same way, so that a door at the cut height is a gap;
* returns the outline of what is left (`region_outline`): the wall surfaces, in metres in the map
  frame (the model's x, y; its length unit from IfcUnitAssignment).

Bodies of other kinds (breps, CSG, swept disks) are counted and reported, not read.

No optional extra is needed. ifcopenshell would read more geometry, but its licence (LGPL-3.0)
is not permissive; docs/plans.md says why it is not a dependency.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import one_line, positive, real_number
from .region_outline import region_outline
from .step_file import Enum, Ref, StepFile

__all__ = ["IfcStorey", "IfcWalls", "ifc_storeys", "ifc_walls"]

WALL_TYPES = ("IFCWALL", "IFCWALLSTANDARDCASE", "IFCWALLELEMENTEDCASE")
"""The entity types read as walls."""

_SI_PREFIX = {
    "EXA": 1e18,
    "PETA": 1e15,
    "TERA": 1e12,
    "GIGA": 1e9,
    "MEGA": 1e6,
    "KILO": 1e3,
    "HECTO": 1e2,
    "DECA": 1e1,
    "DECI": 1e-1,
    "CENTI": 1e-2,
    "MILLI": 1e-3,
    "MICRO": 1e-6,
    "NANO": 1e-9,
}


@dataclass(frozen=True)
class IfcStorey:
    """A storey of the model: its name, floor height (metres, the model's z), and how many walls
    the model places in it."""

    name: str
    elevation: float
    walls: int


@dataclass(frozen=True)
class IfcWalls:
    """The walls of one storey of an IFC model, cut at a height.

    Attributes:
        segments: (M, 2, 2) wall-surface segments, metres, map frame (the model's x, y).
        storey: the storey read.
        cut_z: height of the cut, metres in the model's z.
        walls: how many walls the cut crosses.
        openings: how many openings were taken away at the cut.
        skipped: walls left out and why ("Wall-1: body IFCFACETEDBREP not read").
        storeys: every storey of the model.
        notes: what was read and left out, one line each (for `planicp plan`).
    """

    segments: NDArray[np.float64]
    storey: IfcStorey | None
    cut_z: float
    walls: int
    openings: int
    skipped: tuple[str, ...]
    storeys: tuple[IfcStorey, ...]
    notes: tuple[str, ...] = field(default=())


class _Model:
    """The geometry a storey's walls need, read from a `StepFile`, in metres."""

    def __init__(self, step: StepFile, name: str) -> None:
        self.step = step
        self.name = name
        self.unit = self._length_unit()
        self._placements: dict[int, NDArray[np.float64]] = {}

    def attrs(self, ref: Any) -> list[Any]:
        if not isinstance(ref, Ref) or ref.id not in self.step:
            raise ValueError(f"a reference to {ref!r}, which is not an instance of the file")
        return self.step.attributes(ref)

    def _length_unit(self) -> float:
        for number in self.step.types.get("IFCUNITASSIGNMENT", []):
            for unit in self.step.attributes(number)[0] or []:
                factor = self._unit_factor(unit)
                if factor is not None:
                    return factor
        return 1.0  # IFC's default length unit is the metre

    def _unit_factor(self, unit: Any) -> float | None:
        if not isinstance(unit, Ref):
            return None
        kind, a = self.step.type_of(unit), self.attrs(unit)
        if kind == "IFCSIUNIT" and a[1] == Enum("LENGTHUNIT") and a[3] == Enum("METRE"):
            return _SI_PREFIX.get(a[2].name, 1.0) if isinstance(a[2], Enum) else 1.0
        if kind == "IFCCONVERSIONBASEDUNIT" and a[1] == Enum("LENGTHUNIT"):
            measure = self.attrs(a[3])
            value = measure[0]
            base = self._unit_factor(measure[1])
            if isinstance(value, (int, float)) and base is not None:
                return float(value) * base
        return None

    def point(self, ref: Any) -> NDArray[np.float64]:
        coords = self.attrs(ref)[0]
        return np.array([float(c) for c in coords], dtype=np.float64)

    def direction(self, ref: Any, default: Sequence[float]) -> NDArray[np.float64]:
        if ref is None:
            return np.array(default, dtype=np.float64)
        d = np.array([float(c) for c in self.attrs(ref)[0]], dtype=np.float64)
        norm = float(np.linalg.norm(d))
        if norm == 0.0:
            raise ValueError(f"direction #{ref.id} has length 0")
        return d / norm

    def axis3(self, ref: Any) -> NDArray[np.float64]:
        """4x4 transform of an IfcAxis2Placement3D (or 2D, in the XY plane), lengths in metres."""
        out = np.eye(4)
        if ref is None:
            return out
        kind, a = self.step.type_of(ref), self.attrs(ref)
        if kind == "IFCAXIS2PLACEMENT2D":
            loc = self.point(a[0]) * self.unit
            x = self.direction(a[1], (1.0, 0.0))[:2]
            out[:2, 0], out[:2, 1], out[:2, 3] = x, (-x[1], x[0]), loc[:2]
            return out
        if kind != "IFCAXIS2PLACEMENT3D":
            raise ValueError(f"placement #{ref.id} is an {kind}, not read")
        loc = self.point(a[0]) * self.unit
        z = self.direction(a[1], (0.0, 0.0, 1.0))
        x = self.direction(a[2], (1.0, 0.0, 0.0))
        x = x - z * float(x @ z)
        if float(np.linalg.norm(x)) < 1e-9:
            x = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
            x = x - z * float(x @ z)
        x = x / np.linalg.norm(x)
        out[:3, 0], out[:3, 1], out[:3, 2], out[: len(loc), 3] = x, np.cross(z, x), z, loc
        return out

    def placement(self, ref: Any) -> NDArray[np.float64]:
        """World transform of an IfcLocalPlacement chain."""
        if ref is None:
            return np.eye(4)
        cached = self._placements.get(ref.id)
        if cached is not None:
            return cached
        kind = self.step.type_of(ref)
        if not kind:
            raise ValueError(f"its placement #{ref.id} is not in the file")
        if kind != "IFCLOCALPLACEMENT":
            raise ValueError(f"placement #{ref.id} is an {kind}, not read")
        self._placements[ref.id] = np.eye(4)  # a cycle reads as the identity instead of recursing
        a = self.attrs(ref)
        world = self.placement(a[0]) @ self.axis3(a[1])
        self._placements[ref.id] = world
        return world

    def curve(self, ref: Any) -> NDArray[np.float64]:
        kind, a = self.step.type_of(ref), self.attrs(ref)
        if kind == "IFCPOLYLINE":
            pts = np.array([self.point(p)[:2] for p in a[0]])
        elif kind == "IFCINDEXEDPOLYCURVE":
            coords = np.array(self.attrs(a[0])[0], dtype=np.float64)[:, :2]
            if a[1]:
                order: list[int] = []
                for seg in a[1]:
                    idx = [int(i) - 1 for i in (seg if isinstance(seg, list) else [seg])]
                    order.extend(idx if not order or order[-1] != idx[0] else idx[1:])
                pts = coords[order]
            else:
                pts = coords
        else:
            raise ValueError(f"profile curve {kind} not read")
        return pts * self.unit

    def profile(self, ref: Any) -> tuple[list[NDArray[np.float64]], list[NDArray[np.float64]]]:
        """(outer polygons, voids) of a profile, metres, in its own 2D frame."""
        kind, a = self.step.type_of(ref), self.attrs(ref)
        if kind == "IFCRECTANGLEPROFILEDEF":
            hx, hy = float(a[3]) * self.unit / 2, float(a[4]) * self.unit / 2
            rect = np.array([[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]])
            return [_apply2(self.axis3(a[2]), rect)], []
        if kind == "IFCCIRCLEPROFILEDEF":
            r = float(a[3]) * self.unit
            ang = np.linspace(0, 2 * math.pi, 33)[:-1]
            return [_apply2(self.axis3(a[2]), np.column_stack([r * np.cos(ang), r * np.sin(ang)]))], []
        if kind == "IFCARBITRARYCLOSEDPROFILEDEF":
            return [self.curve(a[2])], []
        if kind == "IFCARBITRARYPROFILEDEFWITHVOIDS":
            return [self.curve(a[2])], [self.curve(c) for c in a[3] or []]
        raise ValueError(f"profile {kind} not read")

    def sections(
        self, item: Any, world: NDArray[np.float64], z: float
    ) -> tuple[list[NDArray[np.float64]], list[NDArray[np.float64]]]:
        """(polygons, voids) where representation item `item`, placed by `world`, meets the plane
        at height `z`, metres."""
        kind, a = self.step.type_of(item), self.attrs(item)
        if kind in ("IFCBOOLEANCLIPPINGRESULT", "IFCBOOLEANRESULT") and a[0] == Enum("DIFFERENCE"):
            return self.sections(a[1], world, z)
        if kind == "IFCMAPPEDITEM":
            source, target = self.attrs(a[0]), a[1]
            mapped = world @ self._operator(target) @ self.axis3(source[0])
            polys: list[NDArray[np.float64]] = []
            voids: list[NDArray[np.float64]] = []
            for sub in self.attrs(source[1])[3]:
                p, v = self.sections(sub, mapped, z)
                polys += p
                voids += v
            return polys, voids
        if kind != "IFCEXTRUDEDAREASOLID":
            raise ValueError(f"body {kind} not read")
        outers, holes = self.profile(a[0])
        frame = world @ self.axis3(a[1])
        extrusion = frame[:3, :3] @ (self.direction(a[2], (0, 0, 1)) * float(a[3]) * self.unit)
        return (
            [s for o in outers for s in _prism_section(frame, o, extrusion, z)],
            [s for h in holes for s in _prism_section(frame, h, extrusion, z)],
        )

    def _operator(self, ref: Any) -> NDArray[np.float64]:
        out = np.eye(4)
        if ref is None:
            return out
        a = self.attrs(ref)
        x = self.direction(a[0], (1, 0, 0)) if a[0] is not None else np.array([1.0, 0, 0])
        y = self.direction(a[1], (0, 1, 0)) if a[1] is not None else np.array([0, 1.0, 0])
        origin = self.point(a[2]) * self.unit
        scale = float(a[3]) if len(a) > 3 and isinstance(a[3], (int, float)) else 1.0
        zaxis = self.direction(a[4], (0, 0, 1)) if len(a) > 4 and a[4] is not None else np.cross(x, y)
        out[:3, 0], out[:3, 1], out[:3, 2] = x * scale, y * scale, zaxis * scale
        out[: len(origin), 3] = origin
        return out

    def body_items(self, product: list[Any]) -> list[Any]:
        """The items of a product's body representation ('Body', else any 3D model one)."""
        if product[6] is None:
            return []
        reps = self.attrs(product[6])[2] or []
        chosen = None
        for rep in reps:
            ra = self.attrs(rep)
            if ra[1] == "Body":
                chosen = ra
                break
            if chosen is None and ra[1] not in ("Axis", "Box", "FootPrint", "Annotation"):
                chosen = ra
        return list(chosen[3]) if chosen else []


def _apply2(transform: NDArray[np.float64], pts: NDArray[np.float64]) -> NDArray[np.float64]:
    return pts @ transform[:2, :2].T + transform[:2, 3]


def _prism_section(
    frame: NDArray[np.float64], profile: NDArray[np.float64], extrusion: NDArray[np.float64], z: float
) -> list[NDArray[np.float64]]:
    """Polygons (XY, metres) where the prism of `profile` (in `frame`'s XY plane) swept along
    `extrusion` meets the plane at height `z`; [] when it does not, or when the extrusion is
    neither vertical nor horizontal."""
    pts = np.column_stack([profile, np.zeros(len(profile)), np.ones(len(profile))]) @ frame.T
    world = pts[:, :3]
    if len(world) >= 2 and np.allclose(world[0], world[-1]):
        world = world[:-1]
    length = float(np.linalg.norm(extrusion))
    if length == 0.0 or len(world) < 3:
        return []
    zs = world[:, 2]
    if abs(extrusion[2]) > 0.999 * length and float(np.ptp(zs)) < 1e-6:  # vertical: the profile moved
        t = (z - float(zs[0])) / float(extrusion[2])
        if not 0.0 <= t <= 1.0:
            return []
        return [world[:, :2] + t * extrusion[:2]]
    if abs(extrusion[2]) < 1e-6 * length:  # horizontal: the profile's chords at z, swept
        crossings = []
        for p, q in zip(world, np.roll(world, -1, axis=0)):
            if (p[2] - z) * (q[2] - z) < 0 or (p[2] == z and q[2] != z):
                s = (z - p[2]) / (q[2] - p[2])
                crossings.append(p[:2] + s * (q[:2] - p[:2]))
        if len(crossings) < 2:
            return []
        pts2 = np.array(crossings)
        direction = pts2[-1] - pts2[0]
        order = np.argsort(pts2 @ direction)
        pts2 = pts2[order]
        out = []
        for a, b in zip(pts2[0::2], pts2[1::2]):
            out.append(np.array([a, b, b + extrusion[:2], a + extrusion[:2]]))
        return out
    return []


def _storeys(model: _Model) -> tuple[list[tuple[IfcStorey, int]], dict[int, list[int]]]:
    step = model.step
    contained: dict[int, list[int]] = {}
    for number in step.types.get("IFCRELCONTAINEDINSPATIALSTRUCTURE", []):
        a = step.attributes(number)
        if isinstance(a[5], Ref):
            contained.setdefault(a[5].id, []).extend(r.id for r in a[4] or [] if isinstance(r, Ref))
    out = []
    for number in step.types.get("IFCBUILDINGSTOREY", []):
        a = step.attributes(number)
        try:
            elevation = float(model.placement(a[5])[2, 3])
        except (ValueError, KeyError, TypeError, IndexError):
            elevation = float(a[9]) * model.unit if len(a) > 9 and isinstance(a[9], (int, float)) else 0.0
        walls = sum(1 for e in contained.get(number, []) if step.type_of(e) in WALL_TYPES)
        name = a[2] if isinstance(a[2], str) else f"#{number}"
        out.append((IfcStorey(name, elevation, walls), number))
    out.sort(key=lambda s: s[0].elevation)
    return out, contained


def _open(path: str | PathLike[str]) -> tuple[_Model, str]:
    file = Path(path)
    name = f"IFC file {str(file)!r}"
    if not file.is_file():
        raise FileNotFoundError(f"{name} does not exist" if not file.exists() else f"{name} is not a file")
    step = StepFile(file)
    if not step.schema.startswith("IFC"):
        raise ValueError(f"{name} is a STEP file of schema {step.schema or 'unknown'!r}, not an IFC model")
    try:
        return _Model(step, name), name
    except (ValueError, KeyError, TypeError, IndexError, AttributeError) as exc:
        raise ValueError(f"{name}: its units could not be read ({type(exc).__name__}: {one_line(str(exc))})") from None


_DAMAGED = (KeyError, IndexError, TypeError, AttributeError, ValueError, ZeroDivisionError, OverflowError)
"""What reading a damaged model raises (a reference to nothing, an attribute missing or of the wrong kind)."""


def ifc_storeys(path: str | PathLike[str]) -> list[IfcStorey]:
    """The storeys of an IFC model, lowest first (`planicp plan FILE --list-layers`).

    Raises:
        FileNotFoundError: no such file. ValueError: not an IFC model, or a damaged one.
    """
    model, name = _open(path)
    try:
        return [s for s, _ in _storeys(model)[0]]
    except _DAMAGED as exc:
        raise ValueError(f"{name} is damaged: {type(exc).__name__}: {one_line(str(exc))}") from None


def ifc_walls(path: str | PathLike[str], *, storey: str | int | None = None, cut_height: float = 1.0) -> IfcWalls:
    """The walls of one storey of an IFC model cut `cut_height` metres above its floor, doors and
    windows taken away (see the module's description).

    Args:
        path: the IFC file (STEP text, `.ifc`).
        storey: the storey's name (case-insensitive) or number from 1, lowest first; None: the
            lowest storey that holds walls.
        cut_height: height of the cut above the storey's elevation, metres (> 0).

    Returns:
        `IfcWalls`: segments (metres, map frame), the storey, counts of walls, openings and what
        was skipped.

    Raises:
        FileNotFoundError: no such file.
        ValueError: not an IFC (STEP) file, no such storey (the message lists them), or no wall
            crosses the cut (the message says what was skipped and why).
    """
    height = positive(real_number(cut_height, "cut_height"), "cut_height", "metres")
    model, name = _open(path)
    try:
        return _cut(model, name, storey, height)
    except _DAMAGED as exc:
        if type(exc) is ValueError and str(exc).startswith(name):
            raise
        raise ValueError(f"{name} is damaged: {type(exc).__name__}: {one_line(str(exc))}") from None


def _cut(model: _Model, name: str, storey: str | int | None, height: float) -> IfcWalls:
    """`ifc_walls` once the file is open."""
    step = model.step
    storeys, contained = _storeys(model)
    listing = ", ".join(
        f"{i + 1}: {s.name!r} at {s.elevation:.2f} m ({s.walls} walls)" for i, (s, _) in enumerate(storeys)
    )
    chosen: tuple[IfcStorey, int] | None = None
    if storey is not None:
        if isinstance(storey, int) and not isinstance(storey, bool):
            if not 1 <= storey <= len(storeys):
                raise ValueError(f"{name} has {len(storeys)} storeys, no storey {storey}: {listing or 'none'}")
            chosen = storeys[storey - 1]
        else:
            matches = [s for s in storeys if s[0].name.casefold() == str(storey).casefold()]
            if not matches:
                raise ValueError(f"{name} has no storey {storey!r}; its storeys: {listing or 'none'}")
            chosen = matches[0]
    else:
        chosen = next((s for s in storeys if s[0].walls > 0), None)
    wall_ids = [n for t in WALL_TYPES for n in step.types.get(t, [])]
    if chosen is not None and contained.get(chosen[1]):
        wall_ids = [n for n in contained[chosen[1]] if step.type_of(n) in WALL_TYPES]
    floor = chosen[0].elevation if chosen is not None else 0.0
    cut_z = floor + height
    voids: dict[int, list[int]] = {}
    for number in step.types.get("IFCRELVOIDSELEMENT", []):
        a = step.attributes(number)
        if isinstance(a[4], Ref) and isinstance(a[5], Ref):
            voids.setdefault(a[4].id, []).append(a[5].id)

    solids: list[NDArray[np.float64]] = []
    holes: list[NDArray[np.float64]] = []
    skipped: list[str] = []
    crossed = openings = 0
    for number in wall_ids:
        a = step.attributes(number)
        label = a[2] if isinstance(a[2], str) else f"#{number}"
        try:
            world = model.placement(a[5])
            polys: list[NDArray[np.float64]] = []
            for item in model.body_items(a):
                p, v = model.sections(item, world, cut_z)
                polys += p
                holes += v
        except (ValueError, KeyError, TypeError, IndexError, AttributeError) as exc:
            skipped.append(f"{label}: {one_line(str(exc), 80)}")
            continue
        if not polys:
            continue
        crossed += 1
        solids += polys
        for opening in voids.get(number, []):
            oa = step.attributes(opening)
            try:
                oworld = model.placement(oa[5])
                cut = [p for item in model.body_items(oa) for p in model.sections(item, oworld, cut_z)[0]]
            except (ValueError, KeyError, TypeError, IndexError, AttributeError) as exc:
                skipped.append(f"opening #{opening}: {one_line(str(exc), 80)}")
                continue
            openings += bool(cut)
            holes += cut
    where = f"storey {chosen[0].name!r} (floor at {floor:.2f} m)" if chosen else "the model (no storeys)"
    if not solids:
        why = f"; skipped: {one_line('; '.join(skipped), 300)}" if skipped else ""
        raise ValueError(
            f"{name}: no wall of {where} crosses the cut {height:g} m above its floor ({len(wall_ids)} walls "
            f"there{why}); its storeys: {listing or 'none'}. Choose another storey (storey=, --storey) or "
            "cut height (cut_height=, --cut-height)"
        )
    segments = region_outline(solids, holes)
    if len(segments) == 0:
        raise ValueError(f"{name}: the walls of {where} cut at {height:g} m leave no wall surface")
    notes = (
        f"scale: the model's length unit, {model.unit:g} m",
        f"walls: {crossed} walls of {where} cut at {height:g} m above the floor: {len(segments)} segments; "
        f"{openings} door and window openings taken away",
        f"dropped: {len(wall_ids) - crossed} walls not crossing the cut or not read"
        + (f" ({one_line('; '.join(skipped), 200)})" if skipped else "")
        + f"; storeys: {listing}",
    )
    return IfcWalls(
        segments,
        chosen[0] if chosen else None,
        cut_z,
        crossed,
        openings,
        tuple(skipped),
        tuple(s for s, _ in storeys),
        notes,
    )
