"""ROS map_server maps: a YAML file describing an occupancy image.

Keys (map_server / nav2_map_server): `image` (path, relative to the YAML), `resolution` (metres per
pixel), `origin` ([x, y, yaw] of the lower-left pixel corner), `negate` (0/1), `occupied_thresh`,
`free_thresh`, optional `mode` (trinary (default), scale, raw), and planicp's optional
`planicp_edge_detector`: how `PlanMap.from_ros_map` reads the occupied cells by default (a plan
drawn as walls of material and saved as a map says "boundary"; see `PlanRaster.surface_points`).
A pixel value v in 0..255 becomes p = (255 - v) / 255 (v / 255 when negate); trinary:
p > occupied_thresh -> 100, p < free_thresh -> 0, else -1 (unknown); scale: as trinary but between
the thresholds 99 * (p - free) / (occ - free); raw: the value v itself (0..100, anything else
unknown). Image row 0 is the top of the map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import MAX_COORDINATE, Pose, brief, one_line
from ..io.atomic_files import write_atomically
from ..io.yaml_documents import read_yaml_file
from .image_files import require_regular_file
from .plan_raster import PlanRaster, load_gray

MODES = ("trinary", "scale", "raw")
EDGE_DETECTOR_KEY = "planicp_edge_detector"
EDGE_DETECTORS = ("centres", "auto", "boundary", "canny")
REQUIRED_KEYS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")


@dataclass(frozen=True, eq=False)
class RosMap:
    """A map_server map read from its YAML.

    Attributes:
        yaml_path: the YAML file.
        image_path: the image it names, resolved against the YAML's folder.
        occupancy: (H, W) int8 in image order (row 0 = top): -1 unknown, 0..100 occupancy.
        resolution: metres per pixel.
        origin: (x, y, yaw) of the lower-left image corner in the map frame.
        mode, negate, occupied_thresh, free_thresh: as in the YAML.
        edge_detector: the YAML's `planicp_edge_detector`, None when it has none.
    """

    yaml_path: Path
    image_path: Path
    occupancy: NDArray[np.int8]
    resolution: float
    origin: Pose
    mode: str
    negate: bool
    occupied_thresh: float
    free_thresh: float
    edge_detector: str | None = None

    def wall_raster(self) -> PlanRaster:
        """The occupied cells (100, or above `occupied_thresh` in raw mode) as plan walls."""
        if self.mode == "raw":
            walls = self.occupancy > self.occupied_thresh * 100.0
        else:
            walls = self.occupancy == 100
        if not walls.any():
            raise ValueError(f"ROS map {self.yaml_path} has no occupied cells: no walls to extract")
        return PlanRaster(walls, self.resolution, self.origin)


MATERIAL_SHARE = 1.0 / 3.0
"""Share of a map's occupied cells inside walls (all four neighbours occupied) from which
`recognised_reading` takes the map for a drawing. A SLAM tool marks the cells where beams ended,
surfaces two or three cells deep at most, so nearly every occupied cell borders free or unknown
space: 4-6 % inside on nav2's maps, 1-10 % on the real logs' maps drawn from end points. A
drawing's walls are material several pixels thick: 55 % inside on the shipped office plan, 63-91 %
on three real raster drawings (`docs/plans.md`, `benches/plan_reading.py --shares`)."""


def inside_share(walls: NDArray[np.bool_]) -> float:
    """The share of the occupied cells of `walls` ((H, W) bool) whose four neighbours are occupied
    too (0 for no occupied cell)."""
    occupied = int(np.count_nonzero(walls))
    if occupied == 0:
        return 0.0
    padded = np.pad(walls, 1)
    inside = walls & padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & padded[1:-1, 2:]
    return int(np.count_nonzero(inside)) / occupied


def recognised_reading(walls: NDArray[np.bool_]) -> str:
    """How a map's occupied cells (`walls`, (H, W) bool) are read when nothing says: "centres"
    (a SLAM map: every occupied cell is where a surface was seen) unless at least
    `MATERIAL_SHARE` of them lie inside walls (`inside_share`), which makes the map a drawing of
    walls of material: "auto" (the centres of walls one or two cells thick, the faces of thicker
    ones; `PlanRaster.surface_points`)."""
    return "auto" if inside_share(walls) >= MATERIAL_SHARE else "centres"


def _yaml() -> Any:
    try:
        import yaml
    except ImportError as exc:  # pragma: no cover - a declared dependency
        raise ImportError("reading ROS maps needs PyYAML: pip install pyyaml") from exc
    return yaml


def _number(meta: dict[str, Any], key: str, path: Path) -> float:
    value = meta[key]
    if isinstance(value, str):
        # YAML 1.1 (PyYAML) reads 5e-2 as text; map_server reads it as the number it is.
        try:
            value = float(value.strip())
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"ROS map {path}: {key} must be a finite number, got {brief(value)}")
    return float(value)


def read_ros_map(yaml_path: str | Path) -> RosMap:
    """Reads a map_server YAML and its image with map_server's semantics (see the module doc)."""
    path = Path(yaml_path)
    if not path.is_file():
        raise FileNotFoundError(f"ROS map YAML {path} does not exist")
    _yaml()  # PyYAML is there, or a message says how to get it
    meta = read_yaml_file(path, f"ROS map {path}")
    if not isinstance(meta, dict):
        raise ValueError(f"ROS map {path} must be a YAML mapping, got {type(meta).__name__}")
    missing = [k for k in REQUIRED_KEYS if k not in meta]
    if missing:
        raise ValueError(f"ROS map {path} is missing keys {missing} (needs {list(REQUIRED_KEYS)})")
    resolution = _number(meta, "resolution", path)
    if resolution <= 0:
        raise ValueError(f"ROS map {path}: resolution must be positive, got {resolution}")
    origin = meta["origin"]
    if not isinstance(origin, (list, tuple)) or len(origin) != 3:
        raise ValueError(f"ROS map {path}: origin must be [x, y, yaw], got {brief(origin)}")
    try:
        if any(isinstance(v, (bool, list, dict)) for v in origin):
            raise TypeError
        origin_pose = tuple(float(v) for v in origin)
    except (TypeError, ValueError):
        raise ValueError(f"ROS map {path}: origin must be three numbers, got {brief(origin)}") from None
    if not all(math.isfinite(v) for v in origin_pose):
        raise ValueError(f"ROS map {path}: origin must be finite, got {brief(origin)}")
    if max(abs(origin_pose[0]), abs(origin_pose[1])) > MAX_COORDINATE:
        raise ValueError(
            f"ROS map {path}: origin {brief(origin)} is beyond +-{MAX_COORDINATE:.0e} m; planicp works "
            f"in metres: give the map's origin in a local frame"
        )
    occ = _number(meta, "occupied_thresh", path)
    free = _number(meta, "free_thresh", path)
    if not 0.0 <= free <= occ <= 1.0:
        raise ValueError(f"ROS map {path}: need 0 <= free_thresh <= occupied_thresh <= 1, got {free}, {occ}")
    mode = meta.get("mode", "trinary")
    if not isinstance(mode, str) or mode not in MODES:
        raise ValueError(f"ROS map {path}: mode must be one of {MODES}, got {brief(mode)}")
    negate = meta["negate"]
    if isinstance(negate, (list, dict)) or negate not in (0, 1, True, False):
        raise ValueError(f"ROS map {path}: negate must be 0 or 1, got {brief(negate)}")
    image = meta["image"]
    if not isinstance(image, str) or not image:
        raise ValueError(f"ROS map {path}: image must be the image file's name, got {brief(image)}")
    if "\0" in image:
        raise ValueError(f"ROS map {path}: image {brief(image)} is no file name: it holds a NUL character")
    image_path = path.parent / image
    try:
        image_path = image_path.resolve()
    except (OSError, RuntimeError):  # a symlink loop: require_regular_file says so
        pass
    try:
        absent = not image_path.exists() and not image_path.is_symlink()
    except OSError as exc:  # a name too long for the file system
        raise ValueError(f"ROS map {path}: image {brief(image)} cannot be opened: {exc.strerror or exc}") from None
    if absent:
        raise FileNotFoundError(
            f"ROS map {path} names image {brief(image)}, which does not exist ({one_line(str(image_path), 300)})"
        )
    require_regular_file(image_path, f"ROS map image (from {path})")
    gray = load_gray(image_path, what=f"ROS map image (from {path})")
    reach = math.hypot(*gray.shape) * resolution  # farthest a pixel corner lies from the origin, metres
    if max(abs(origin_pose[0]), abs(origin_pose[1])) + reach > MAX_COORDINATE:
        raise ValueError(
            f"ROS map {path}: its {gray.shape[1]} x {gray.shape[0]} pixels at {resolution:g} m from "
            f"origin {brief(origin)} reach beyond +-{MAX_COORDINATE:.0e} m; check resolution (metres per "
            f"pixel) and origin"
        )
    occupancy = occupancy_from_gray(gray, mode, bool(negate), occ, free)
    edge_detector = meta.get(EDGE_DETECTOR_KEY)
    if edge_detector is not None and (not isinstance(edge_detector, str) or edge_detector not in EDGE_DETECTORS):
        raise ValueError(
            f"ROS map {path}: {EDGE_DETECTOR_KEY} must be one of {EDGE_DETECTORS}, got {brief(edge_detector)} "
            f"(or leave it out: occupied cells are then read as an occupancy grid's)"
        )
    return RosMap(
        path,
        image_path,
        occupancy,
        resolution,
        origin_pose,  # type: ignore[arg-type]
        mode,
        bool(negate),
        occ,
        free,
        edge_detector,
    )


def occupancy_from_gray(
    gray: NDArray[np.uint8], mode: str, negate: bool, occupied_thresh: float, free_thresh: float
) -> NDArray[np.int8]:
    """map_server's pixel -> occupancy rule (image order kept)."""
    if mode == "raw":
        raw = gray.astype(np.int16)
        raw[raw > 100] = -1
        as_int8: NDArray[np.int8] = raw.astype(np.int8)
        return as_int8
    v = gray.astype(np.float64)
    p = v / 255.0 if negate else (255.0 - v) / 255.0
    out = np.full(gray.shape, -1, dtype=np.int8)
    out[p > occupied_thresh] = 100
    out[p < free_thresh] = 0
    if mode == "scale":
        between = (p >= free_thresh) & (p <= occupied_thresh)
        span = max(occupied_thresh - free_thresh, 1e-12)
        out[between] = np.round(99.0 * (p[between] - free_thresh) / span).astype(np.int8)
    return out


def write_ros_map(
    yaml_path: str | Path,
    occupancy: NDArray[np.int8],
    resolution: float,
    origin: Pose,
    *,
    occupied_thresh: float = 0.65,
    free_thresh: float = 0.196,
    edge_detector: str | None = None,
) -> Path:
    """Writes a trinary map the way map_saver does: PGM beside the YAML (same stem), occupied
    (> occupied_thresh*100) 0, free (0..free_thresh*100) 254, unknown 205. `occupancy` is in image
    order (row 0 = top). `edge_detector` (one of `EDGE_DETECTORS`) is written as
    `planicp_edge_detector`, how `PlanMap.from_ros_map` reads the occupied cells back (map_server
    ignores the key). Both files are written to temporary names first and then renamed, so a
    failure leaves no half-written map. Returns the YAML path."""
    path = Path(yaml_path)
    if path.suffix.lower() not in (".yaml", ".yml"):
        raise ValueError(f"ROS map path {path} must end in .yaml or .yml")
    if edge_detector is not None and edge_detector not in EDGE_DETECTORS:
        raise ValueError(f"edge_detector must be one of {EDGE_DETECTORS} or None, got {edge_detector!r}")
    occ = np.asarray(occupancy)
    if occ.ndim != 2 or occ.size == 0:
        raise ValueError(f"occupancy must be a non-empty 2-D array, got shape {occ.shape}")
    path.parent.mkdir(parents=True, exist_ok=True)
    image = np.full(occ.shape, 205, dtype=np.uint8)
    image[(occ >= 0) & (occ < free_thresh * 100.0)] = 254
    image[occ > occupied_thresh * 100.0] = 0
    pgm_path = path.with_suffix(".pgm")
    header = f"P5\n# CREATOR: planicp {resolution:.6f} m/pix\n{occ.shape[1]} {occ.shape[0]}\n255\n".encode()
    meta = (
        f"image: {pgm_path.name}\n"
        f"mode: trinary\n"
        f"resolution: {resolution!r}\n"
        f"origin: [{float(origin[0])!r}, {float(origin[1])!r}, {float(origin[2])!r}]\n"
        f"negate: 0\n"
        f"occupied_thresh: {occupied_thresh!r}\n"
        f"free_thresh: {free_thresh!r}\n"
    )
    if edge_detector is not None:
        meta += f"{EDGE_DETECTOR_KEY}: {edge_detector}\n"
    write_atomically(pgm_path, header + image.tobytes())
    write_atomically(path, meta.encode())
    return path
