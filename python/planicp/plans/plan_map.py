"""The plan as the localizer sees it: wall-surface points in metres, in the map frame."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import as_points, as_pose, positive, whole_number
from .image_files import check_image_file, require_regular_file
from .plan_cache import cache_key, cached, default_cache_dir
from .plan_raster import PlanRaster, load_gray_and_chroma, wall_mask
from .ros_map import read_ros_map, recognised_reading, write_ros_map
from .vector_plan import as_segments, dxf_segments, house_expo_segments, sample_segments
from .wall_extraction import WallExtraction, check_walls_option, extract_walls
from .wall_index_stats import WallIndexStats

VISIBILITY_RASTER_CELLS = _core.MAX_RASTER_CELLS
"""Most cells of a plan's visibility raster: the native core's limit, checked here as well so that
wall segments spanning too wide an extent for their spacing are refused before their points are
sampled (a 4 KB HouseExpo file with one vertex 260 km away had 26 million points sampled, 2.5 GB,
before the core refused them)."""

CacheSetting = bool | str | Path
"""True: the default cache folder; False: no cache; a path: that folder."""


def _cache_folder(cache: CacheSetting) -> Path | None:
    if cache is True:
        return default_cache_dir()
    if cache is False:
        return None
    if isinstance(cache, (str, Path)):
        return Path(cache)
    raise TypeError(f"cache must be True, False or a folder path, got {cache!r}")


def _naming(exc: ValueError, name: str) -> ValueError:
    """`exc` (a ValueError or PlanicpError) again, its message starting with `name`: what a reader
    raises when the plan a file holds cannot be prepared."""
    message = f"{name}: {exc}"
    try:
        return type(exc)(message)
    except TypeError:  # a subclass with another constructor
        return ValueError(message)


class PlanMap:
    """Wall-surface points of a floor plan (metres, map frame), prepared once for alignment.

    Building one makes a KD-tree over the points, a wall normal per point and a raster of the
    points for visibility ray casting; all are read-only afterwards, so one `PlanMap` serves any
    number of alignments, from any number of threads.
    """

    __slots__ = ("_native", "_points", "_likelihood", "raster", "from_cache", "edge_detector", "metric")

    def __init__(
        self,
        native: _core.PointMap,
        raster: PlanRaster | None = None,
        from_cache: bool = False,
        edge_detector: str | None = None,
    ) -> None:
        """Wraps a native map; use a `from_*` constructor instead."""
        if not isinstance(native, _core.PointMap):
            raise TypeError("use PlanMap.from_points(...) (or another from_* constructor) to build a PlanMap")
        self._native = native
        points = native.points
        points.setflags(write=False)
        self._points = points
        self._likelihood: _core.LikelihoodGrid | None = None
        self.raster = raster
        """The wall raster the plan was extracted from (None for plans built from points)."""
        self.from_cache = from_cache
        """Whether the wall points were loaded from the on-disk cache."""
        self.edge_detector = edge_detector
        """How the points were read from `raster` (see `PlanRaster.surface_points`; None for
        plans built from points)."""
        self.metric = False
        """Whether the plan's scale is metric by construction: a map_server map, made by SLAM from
        a range sensor's metres (`from_ros_map`). A drawing's scale (an image's metres per pixel,
        a print scale) may be off, and the `Localizer` watches it (`ScaleRule`)."""

    @classmethod
    def from_points(cls, xy: Any, *, resolution: float | None = None) -> PlanMap:
        """A plan from wall points.

        Args:
            xy: (N, 2) wall-surface points, metres, map frame. N >= 1, all finite.
            resolution: cell size in metres of the raster used for visibility ray casting.
                It should be about 1.5 times the spacing of neighbouring points along a wall, so
                that rays cannot slip between them; None estimates it that way from the points.

        Points far denser than an alignment can use (more than two per 5 mm square on average,
        e.g. walls sampled every 0.4 mm) are thinned to the first point of each 5 mm square, so
        that the plan's size, and the time and memory to build and use it, follow the length of
        its walls; `len(plan)` is the number kept. Plans drawn every 1-5 cm keep every point.
        Building takes O(n log n); Ctrl-C interrupts it.

        Raises:
            TypeError: `xy` does not hold real numbers.
            ValueError: wrong shape, no points, a NaN/inf coordinate, or a bad resolution.
        """
        points = as_points(xy, "plan points")
        if resolution is not None:
            resolution = positive(resolution, "resolution", "metres")
        return cls(_core.PointMap(points, resolution))

    @classmethod
    def from_raster(cls, raster: PlanRaster, *, edge_detector: str = "boundary") -> PlanMap:
        """A plan from a wall raster: one point per pixel face of wall surface (see `PlanRaster`).
        The visibility raster uses 1.5 pixels."""
        return cls._from_raster_points(
            raster, raster.surface_points(edge_detector), from_cache=False, edge_detector=edge_detector
        )

    @classmethod
    def _from_raster_points(
        cls,
        raster: PlanRaster,
        points: NDArray[np.float64],
        from_cache: bool,
        normals: NDArray[np.float64] | None = None,
        edge_detector: str | None = None,
    ) -> PlanMap:
        pts = np.ascontiguousarray(points, dtype=np.float64)
        nrm = None if normals is None else np.ascontiguousarray(normals, dtype=np.float64)
        native = _core.PointMap(pts, 1.5 * raster.resolution, nrm)
        return cls(native, raster, from_cache, edge_detector)

    @classmethod
    def from_image(
        cls,
        source: str | Path | NDArray[Any],
        resolution: float,
        origin: Any = (0.0, 0.0, 0.0),
        *,
        threshold: int | None = None,
        open_px: int = 0,
        close_px: int = 0,
        edge_detector: str = "boundary",
        walls: str = "drawing",
        wall_extraction: WallExtraction | None = None,
        cache: CacheSetting = True,
    ) -> PlanMap:
        """A plan from an image of it (PNG, JPG, PGM, BMP, ... or an array).

        Args:
            source: image path, or a grey/colour array (row 0 is the top of the plan). A photo is
                turned upright by its EXIF orientation first.
            resolution: metres per pixel (see `resolution_from_pixels` to measure it).
            origin: (x, y, yaw) of the image's lower-left corner in the map frame, exactly as a
                ROS map YAML's `origin`, so that a plan and a ROS map of it give the same points.
            threshold: grey level (1..255) below which a pixel is wall; None: Otsu's threshold.
            open_px: morphological opening of the wall mask (removes specks up to that size), in
                pixels; 0 = none.
            close_px: morphological closing of the wall mask (bridges gaps up to that size), in
                pixels; 0 = none.
            edge_detector: "auto", "boundary", "canny" or "centres" (see `PlanRaster.surface_points`).
            walls: "drawing" (default): the walls of a drawing, its text, symbols, door swings,
                hatching and fills dropped (`planicp.plans.wall_extraction`); "all-dark": every dark
                pixel is wall (clean wall images, maps drawn as images).
            wall_extraction: how walls are told from the rest (`WallExtraction`), with "drawing".
            cache: True (default folder, see `planicp.plans.plan_cache`), False, or a folder.

        Raises:
            FileNotFoundError: the file does not exist.
            ValueError: unreadable image, no walls (all white or all black, or nothing wall-like in
                a drawing), bad resolution/origin, an unknown `walls`.
        """
        res = positive(resolution, "resolution", "metres per pixel")
        extraction = check_walls_option(walls, wall_extraction)
        pose = as_pose(origin, "origin")
        if isinstance(source, (str, Path)):
            path = Path(source)
            require_regular_file(path, "plan image")
            check_image_file(path, "plan image")  # before its bytes are read for the cache key
            contents = [path.read_bytes()]
        else:
            arr = np.ascontiguousarray(source)
            contents = [str(arr.dtype).encode(), str(arr.shape).encode(), arr.tobytes()]
        params = {
            "resolution": res,
            "origin": pose,
            "threshold": threshold,
            "open_px": open_px,
            "close_px": close_px,
            "edge_detector": edge_detector,
            "walls": walls,
            "wall_extraction": None if extraction is None else extraction.to_dict(),
            "orientation": "exif",  # photos turned upright by their EXIF orientation (entries before were not)
        }

        def build() -> dict[str, NDArray[Any]]:
            gray, chroma = load_gray_and_chroma(source)
            what = f"plan image {source}" if isinstance(source, (str, Path)) else "plan image"
            mask = wall_mask(gray, threshold, open_px=open_px, close_px=close_px, what=what)
            if extraction is not None:
                try:
                    mask = extract_walls(mask, res, extraction, chroma, gray).walls
                except ValueError as exc:
                    raise ValueError(f"{what}: {exc}") from None
            return cls._prepared(PlanRaster(mask, res, pose), edge_detector)

        arrays, hit = cached(_cache_folder(cache), cache_key("image", params, contents), build)
        return cls._from_cached(arrays, res, pose, hit, edge_detector)

    @classmethod
    def _from_cached(
        cls, arrays: dict[str, NDArray[Any]], resolution: float, origin: Any, hit: bool, edge_detector: str
    ) -> PlanMap:
        rows, cols = (int(v) for v in arrays["shape"])
        walls = np.unpackbits(arrays["walls"], count=rows * cols).reshape(rows, cols).astype(bool)
        raster = PlanRaster(walls, resolution, origin)
        return cls._from_raster_points(
            raster, arrays["points"], from_cache=hit, normals=arrays["normals"], edge_detector=edge_detector
        )

    @staticmethod
    def _prepared(raster: PlanRaster, edge_detector: str) -> dict[str, NDArray[Any]]:
        """What a cache entry holds: the map's points (thinned when far denser than useful: see
        `from_points`), their wall normals (the slow part of a map build), and the packed wall
        raster."""
        native = _core.PointMap(raster.surface_points(edge_detector), 1.5 * raster.resolution)
        return {
            "points": native.points,
            "normals": native.normals,
            "walls": np.packbits(raster.walls),
            "shape": np.array(raster.walls.shape),
        }

    @classmethod
    def from_ros_map(
        cls, yaml_path: str | Path, *, edge_detector: str | None = None, cache: CacheSetting = True
    ) -> PlanMap:
        """A plan from a ROS map_server map (YAML + image), with map_server's semantics: occupied
        cells are walls; `resolution`, `origin`, `negate`, thresholds and `mode` from the YAML.

        An occupancy grid's occupied cell is one where a surface was seen (a beam ended in it), so
        by default (`edge_detector=None`) the centre of every occupied cell is taken
        (`"centres"`), as a likelihood-field particle filter reads the grid: where a SLAM tool's
        beams ended over two or three cells of a wall, its surface is the middle of those cells,
        and faces would put it half a cell to a cell in front of where the beams ended. The ICP's
        visibility cast sees a wall's first layer (the cell a ray stops in and the one behind it),
        so cells deep inside a thick wall and its far side stay hidden. A map that says otherwise
        (its YAML's `planicp_edge_detector`, which `to_ros_map` writes for a plan drawn as walls
        of material) is read as it says; an `edge_detector` given here overrides both (see
        `PlanRaster.surface_points` for the readings). A map that says nothing but whose occupied
        cells lie mostly inside walls (`ros_map.recognised_reading`: a third or more with all four
        neighbours occupied, where a SLAM map has under a fifth) is a drawing given as a
        map_server map, and is read as one (`"auto"`)."""
        ros_map = read_ros_map(yaml_path)
        said = edge_detector or ros_map.edge_detector
        walls: PlanRaster | None = None
        if said:
            reading = said
        else:  # the raster read once: to recognise the map, then to build its plan
            walls = ros_map.wall_raster()
            reading = recognised_reading(walls.walls)
        params = {
            "resolution": ros_map.resolution,
            "origin": ros_map.origin,
            "mode": ros_map.mode,
            "negate": ros_map.negate,
            "occupied": ros_map.occupied_thresh,
            "free": ros_map.free_thresh,
            "edge_detector": reading,
        }
        contents = [ros_map.image_path.read_bytes()]

        def build() -> dict[str, NDArray[Any]]:
            return cls._prepared(walls or ros_map.wall_raster(), reading)

        arrays, hit = cached(_cache_folder(cache), cache_key("ros_map", params, contents), build)
        plan = cls._from_cached(arrays, ros_map.resolution, ros_map.origin, hit, reading)
        plan.metric = True
        return plan

    @classmethod
    def from_segments(cls, segments: Any, spacing: float = 0.02) -> PlanMap:
        """A plan from wall segments (M, 2, 2) in metres, map frame, sampled every `spacing` metres
        (both ends included). Each segment is one wall surface: give both faces of a thick wall.

        Segments spanning more than the visibility raster allows at 1.5 `spacing`
        (`VISIBILITY_RASTER_CELLS`) are refused before they are sampled."""
        segs = as_segments(segments, "segments")
        step = positive(spacing, "spacing", "metres")
        resolution = 1.5 * step
        corners = segs.reshape(-1, 2)
        span = corners.max(axis=0) - corners.min(axis=0)
        with np.errstate(over="ignore"):
            cells = float(np.prod(span / resolution + 3.0))  # the core's raster: a cell of margin either side
        if not cells <= VISIBILITY_RASTER_CELLS:
            raise ValueError(
                f"walls spanning {span[0]:.6g} x {span[1]:.6g} m need a visibility raster of {cells:.3g} "
                f"cells at {resolution:g} m (limit {VISIBILITY_RASTER_CELLS}): use a larger spacing, or "
                f"check the plan's units"
            )
        return cls.from_points(sample_segments(segs, step), resolution=resolution)

    @classmethod
    def from_house_expo(
        cls,
        source: str | Path | dict[str, Any],
        spacing: float = 0.02,
        *,
        resolution: float | None = None,
        wall_thickness: float = 0.15,
    ) -> PlanMap:
        """A plan from a HouseExpo JSON file (or its parsed dict), whose outline polygon `verts`
        (metres, map frame) bounds the free space.

        Without `resolution`: the outline sampled every `spacing` metres (a plan of points). With
        `resolution` (metres per pixel): the outline rasterised with walls `wall_thickness` metres
        thick around it (`PlanRaster.from_free_polygon`), so that the plan has a raster, as the
        simulation (`planicp.sim`, `planicp sweep`) needs; its points are the wall surfaces of that
        raster, at most half a pixel from the outline."""
        segments, _ = house_expo_segments(source)
        name = "HouseExpo data (dict)" if isinstance(source, dict) else f"HouseExpo file {str(source)!r}"
        try:
            if resolution is None:
                return cls.from_segments(segments, spacing)
            return cls.from_raster(PlanRaster.from_free_polygon(segments[:, 0, :], resolution, wall_thickness))
        except ValueError as exc:  # too many points, too large a raster: the plan's size, so the file's
            raise _naming(exc, name) from None

    @classmethod
    def from_dxf(
        cls,
        path: str | Path,
        layers: str | list[str] | None = None,
        *,
        spacing: float = 0.02,
        arc_tolerance: float = 0.01,
    ) -> PlanMap:
        """A plan from a DXF drawing: LINE, LWPOLYLINE (with bulges), POLYLINE, ARC and CIRCLE on
        `layers` (None: of the layers shown, those named as walls and the building's shell around
        them, or all of them when none is named as walls: `dxf_plan.dxf_walls`), in metres from
        `$INSUNITS`, sampled every `spacing` metres.
        Needs the optional extra: `pip install 'planicp[cad]'`."""
        segments = dxf_segments(path, layers, arc_tolerance=arc_tolerance)
        try:
            return cls.from_segments(segments, spacing)
        except ValueError as exc:  # too many points, too large a raster: the drawing's size, so the file's
            raise _naming(exc, f"DXF file {str(path)!r}") from None

    def scaled(self, factor: float) -> PlanMap:
        """This plan with every map coordinate multiplied by `factor` about the map origin (a
        raster plan: its image read at `resolution * factor`); see `plan_scaling.scaled_plan`."""
        from .plan_scaling import scaled_plan

        return scaled_plan(self, factor)

    def to_ros_map(self, yaml_path: str | Path, resolution: float | None = None) -> Path:
        """Writes the plan as a map_server map (YAML + PGM beside it): walls occupied (0), the
        rest free (254). A plan read from an image or ROS map writes its own wall raster, which
        `from_ros_map` reads back to the same points (the YAML says how its cells were read,
        `planicp_edge_detector`); a plan built from points is rasterised at `resolution` (default:
        its visibility raster's), which moves points by up to a pixel, and read back as an
        occupancy grid (cell centres)."""
        raster, reading = self.raster, self.edge_detector
        if raster is None or resolution is not None:
            raster = PlanRaster.from_points(self._points, resolution or self.raster_resolution)
            reading = None
        occupancy = np.where(raster.walls, 100, 0).astype(np.int8)
        return write_ros_map(yaml_path, occupancy, raster.resolution, raster.origin, edge_detector=reading)

    @property
    def points(self) -> NDArray[np.float64]:
        """(N, 2) wall points, metres, map frame (read-only)."""
        return self._points

    @property
    def cells_mark_returns(self) -> bool:
        """Whether the points are an occupancy grid's occupied cell centres (`edge_detector`
        "centres": a map_server map made by SLAM, as `from_ros_map` reads one). Such cells mark
        where range returns ended, seen from every pose the map was made from: trees, posts and
        parked cars are specks that beams from other poses pass, so a ray cast through the map
        does not say what a beam from one pose sees. Walls drawn as material (a drawing, an image,
        vector walls, points) stop every beam. The `Localizer`'s defaults follow this
        (`IcpConfig.for_tracking`, its posterior refinement and its score)."""
        return self.edge_detector == "centres"

    @property
    def normals(self) -> NDArray[np.float64]:
        """(N, 2) unit wall normals fitted to each point's neighbours ((0, 0) where none fits)."""
        return self._native.normals

    @property
    def raster_resolution(self) -> float:
        """Cell size of the visibility raster, metres."""
        return self._native.raster_resolution

    @property
    def spacing(self) -> float:
        """Median distance between neighbouring wall points, metres (0.05 m when it cannot be
        told): how finely the plan places its walls."""
        return self._native.spacing

    def likelihood_field(self) -> _core.LikelihoodGrid:
        """The plan as a likelihood field (built on first use, then kept): how likely a range
        return is at each point of the plane, in [0, 1], with `sigma` the plan's `spacing` (a plan
        places a wall no more finely than it samples it: a map_server map's cell, a drawing's pixel
        or sampling step), sampled every `sigma` and interpolated bilinearly. Wall surfaces (a
        drawing, vector walls, points) give `exp(-d^2 / (2 sigma^2))` of the distance `d` to the
        nearest wall point: both faces of a thin wall stay peaks of their own. An occupancy grid's
        occupied cells (`cells_mark_returns`: a map made by SLAM, whose walls are bands two or
        three cells thick where beams scattered) give the cells' summed Gaussians over the largest
        sum within `3 sigma` (at least 1): a band peaks in its middle, where its surface most
        likely is, instead of being flat on top across it, and its ridge is 1 however thick it is
        drawn (`icp_core`'s `grids::likelihood_grid`). One byte per cell: 37 MB for a 305 x 305 m
        SLAM map at 5 cm. A plan whose field would need more cells than the native limit (256 Mi:
        a square of 800 m at 5 cm) is sampled coarser, by steps of a quarter, until it fits: the
        Gaussian keeps its `sigma`, the interpolation between samples is coarser (a
        `PlanicpError` when that would take samples over a thousand `sigma`s apart: points 10^8 m
        apart). What `planicp.tracking.posterior_refinement` climbs, and what a searched place is
        weighed by (`tracking.stages.search`)."""
        if self._likelihood is None:
            profile: Literal["nearest", "density"] = "density" if self.cells_mark_returns else "nearest"
            self._likelihood = _core.LikelihoodGrid.within_budget(self._points, self.spacing, self.spacing, profile)
        return self._likelihood

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the points, metres."""
        lo, hi = self._points.min(axis=0), self._points.max(axis=0)
        return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))

    def prepare_index(self) -> WallIndexStats:
        """Builds the plan's nearest-wall index now (the first alignment builds it otherwise; it
        is kept with the plan) and returns its sizes. About 3.2 s and 90 MB for a 100 x 100 m
        floor sampled every 2 cm (docs/benchmarks.md, "Nearest-wall index: build and memory")."""
        return WallIndexStats(*self._native.wall_index_stats())

    def visible_indices(self, pose: Any, max_range: float = 30.0) -> NDArray[np.uint32]:
        """Indices (ascending) of the wall points a 360-degree LIDAR at `pose` sees.

        Rays are cast through the visibility raster from the pose's position, each stopping at
        the first wall cell; the points in those cells are visible. Only x and y of `pose`
        matter.

        Args:
            pose: (x, y, yaw) in the map frame, metres and radians.
            max_range: sensor range, metres.
        """
        x, y, _ = as_pose(pose, "pose")
        return self._native.visible_indices(x, y, positive(max_range, "max_range", "metres"))

    def visible_from(self, pose: Any, max_range: float = 30.0) -> NDArray[np.float64]:
        """(M, 2) wall points visible from `pose` within `max_range` (see `visible_indices`)."""
        return self._points[self.visible_indices(pose, max_range)]

    def view_from(
        self,
        pose: Any,
        max_range: float = 30.0,
        directions: int = 1440,
        scan: Any = None,
        ranges: bool = True,
        pair_distance: float | None = None,
    ) -> _core.WallView:
        """What a LIDAR at `pose` sees of the plan, in one ray cast: the visible wall points (as
        `visible_indices`) and, in `directions` evenly spaced directions, the range to the wall
        point nearest the ray in its first wall cell of the visibility raster. (`OcclusionRule`
        casts exactly through the plan image instead: the raster's cells lengthen walls at their
        ends; see docs/limitations.md.)

        Args:
            pose: (x, y, yaw) `T_map_base`, metres and radians; direction j looks along the
                base-frame angle -pi + j 2 pi / directions.
            max_range: how far the rays are cast, metres; beyond it a direction reads inf.
            directions: 8 to 2**20.
            scan: (N, 2) base-frame returns, metres, or None. When given, only the directions the
                returns span, widened by 10 degrees on either side, are cast: the visible points
                are those seen over that arc, and the other directions' ranges are NaN (a 270-degree
                scan casts 80 % of the circle).
            ranges: False casts only what the visible points need (no halfway directions, no
                ranges): `ranges` is then empty and `classify` refuses.
            pair_distance: metres, with `scan` and `ranges=False` only: how far from a return a
                wall point can be paired with it (`IcpConfig`'s largest stage distance,
                `planicp._core.largest_pair_distance`). Each direction is then cast only as far
                as a return could pair with a wall there: the farthest return within
                `asin(pair_distance / range)` of it, widened by the arc's 10 degrees, plus
                `pair_distance`. The visible points are those an alignment of the scan can use.

        Returns:
            A `planicp.WallView`: `visible_indices`, `ranges` (metres, to about one raster
            cell), `classify(points, margin)`. `localize(..., view=...)` reuses its visible
            points instead of casting them again.
        """
        x, y, yaw = as_pose(pose, "pose")
        points = None if scan is None else as_points(scan, "scan", allow_empty=True)
        if pair_distance is not None:
            if points is None or ranges:
                raise ValueError(
                    "pair_distance limits the visible points of a cast for a scan: pass scan= and ranges=False "
                    "(the ranges of a cast stop at the walls, however far)"
                )
            pair_distance = positive(pair_distance, "pair_distance", "metres")
        return self._native.view_from(
            (x, y, yaw),
            positive(max_range, "max_range", "metres"),
            whole_number(directions, "directions", 8, 1 << 20),
            points,
            bool(ranges),
            pair_distance,
        )

    def __len__(self) -> int:
        return len(self._native)

    def __repr__(self) -> str:
        xmin, ymin, xmax, ymax = self.extent
        return (
            f"PlanMap({len(self)} wall points, x {xmin:.2f}..{xmax:.2f} m, y {ymin:.2f}..{ymax:.2f} m, "
            f"visibility raster {self.raster_resolution:.3f} m)"
        )
