"""A plan as a raster of wall pixels, and the wall-surface points it yields.

Pixel geometry follows ROS map_server: `resolution` is metres per pixel, `origin` = (x, y, yaw) is
the pose of the LOWER-LEFT corner of the image in the map frame, and image row 0 is the TOP row.
Pixel (row r, col c) therefore covers, before the origin's rotation and translation,
x in [c, c + 1) * resolution and y in [H - r - 1, H - r) * resolution for an image of H rows.

Wall surfaces are the faces between wall and non-wall pixels of the thresholded image: one point
at the middle of each face. That is the boundary an edge detector such as Canny (the thesis's
choice, available as `edge_detector="canny"`) traces on a binary mask, taken completely and placed
exactly on the surface instead of half a pixel inside it; one point per pixel of wall surface. A
plan read from an image and from the ROS map of that image therefore give identical points.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose, as_points, as_pose, brief, positive, whole_number
from .image_files import MAX_IMAGE_PIXELS, check_image_file, require_regular_file


def _cv2() -> Any:
    try:
        import cv2
    except ImportError as exc:  # pragma: no cover - a declared dependency
        raise ImportError("reading plan images needs OpenCV: pip install opencv-python-headless") from exc
    return cv2


@dataclass(frozen=True, eq=False)
class PlanRaster:
    """Wall pixels of a plan with their geometry.

    Attributes:
        walls: (H, W) bool, image order (row 0 is the top of the map); True where a wall is.
        resolution: metres per pixel.
        origin: (x, y, yaw) of the lower-left image corner in the map frame, metres and radians.
    """

    walls: NDArray[np.bool_]
    resolution: float
    origin: Pose

    def __post_init__(self) -> None:
        walls = np.asarray(self.walls)
        if walls.ndim != 2 or walls.dtype != np.bool_:
            raise ValueError(f"walls must be a 2-D bool array, got shape {walls.shape} dtype {walls.dtype}")
        if walls.size == 0:
            raise ValueError("walls is empty (an image with no pixels)")
        walls = walls.copy()
        walls.setflags(write=False)
        object.__setattr__(self, "walls", walls)
        object.__setattr__(self, "resolution", positive(self.resolution, "resolution", "metres per pixel"))
        object.__setattr__(self, "origin", as_pose(self.origin, "origin"))

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the image."""
        return (int(self.walls.shape[0]), int(self.walls.shape[1]))

    def pixel_to_map(self, rows: NDArray[np.float64], cols: NDArray[np.float64]) -> NDArray[np.float64]:
        """(N, 2) map-frame metres of image positions (fractional rows/cols; pixel centres are +0.5)."""
        height = self.shape[0]
        x = cols * self.resolution
        y = (height - rows) * self.resolution
        ox, oy, yaw = self.origin
        c, s = math.cos(yaw), math.sin(yaw)
        return np.column_stack([ox + c * x - s * y, oy + s * x + c * y])

    def surface_points(self, edge_detector: str = "boundary") -> NDArray[np.float64]:
        """(N, 2) wall-surface points in metres: the middle of each face between a wall pixel and a
        non-wall pixel (outside the image is non-wall). Deterministic order.

        `edge_detector`: "boundary" (default) takes every such face: a drawing's wall pixels
        are wall material, and its surfaces are their faces. "auto" reads the raster as an
        occupancy grid, whose occupied cells are where a surface was seen, and decides wall by wall
        (see `thin_wall_pixels`): a wall at most two pixels thick does not resolve two faces, so
        its pixels are the surface and their centres are taken (SLAM maps, maps drawn from scan
        end points); a thicker wall, which does, gets its faces as with "boundary". "canny" keeps only the faces
        next to an edge OpenCV's Canny detector finds on the wall mask (the thesis's method); on a
        binary mask it finds the same boundary but thins it away at corners and one-pixel walls: it
        kept 8,015 of depot.pgm's 9,184 faces (tests/test_plans.py checks the loss). "centres" takes
        the centre of every wall pixel instead: for maps whose wall pixels are the surfaces
        themselves, one or two pixels thick (SLAM occupancy grids, maps drawn from scan end
        points), where the faces would put two surfaces half a pixel either side of the real one.
        """
        if edge_detector == "centres":
            rows_c, cols_c = np.nonzero(self.walls)
            return self.pixel_to_map(rows_c.astype(np.float64) + 0.5, cols_c.astype(np.float64) + 0.5)
        thin = thin_wall_pixels(self.walls) if edge_detector == "auto" else None
        walls = np.pad(self.walls, 1, constant_values=False)
        vertical = walls[:-1, :] != walls[1:, :]  # face between padded rows r and r+1, column c
        horizontal = walls[:, :-1] != walls[:, 1:]  # face between padded cols c and c+1, row r
        if thin is not None:
            # Faces of thick walls only: a face borders exactly one wall pixel, and it counts
            # when that pixel is not thin.
            thick = np.pad(self.walls & ~thin, 1, constant_values=False)
            vertical &= thick[:-1, :] | thick[1:, :]
            horizontal &= thick[:, :-1] | thick[:, 1:]
        if edge_detector == "canny":
            cv2 = _cv2()
            edges = cv2.Canny(walls.astype(np.uint8) * 255, 100, 200, L2gradient=True) > 0
            vertical &= edges[:-1, :] | edges[1:, :]
            horizontal &= edges[:, :-1] | edges[:, 1:]
        elif edge_detector not in ("boundary", "auto"):
            raise ValueError(f'edge_detector must be "auto", "boundary", "canny" or "centres", got {edge_detector!r}')
        vr, vc = np.nonzero(vertical)
        hr, hc = np.nonzero(horizontal)
        # Unpadded image coordinates: the boundary between padded rows vr and vr+1 is image row vr.
        rows = np.concatenate([vr.astype(np.float64), hr - 1 + 0.5])
        cols = np.concatenate([vc - 1 + 0.5, hc.astype(np.float64)])
        if thin is not None and thin.any():
            thin_rows, thin_cols = np.nonzero(thin)
            rows = np.concatenate([rows, thin_rows + 0.5])
            cols = np.concatenate([cols, thin_cols + 0.5])
        return self.pixel_to_map(rows, cols)

    def boundary_face_count(self) -> int:
        """Number of wall/non-wall pixel faces (what `surface_points` yields when Canny misses none)."""
        walls = np.pad(self.walls, 1, constant_values=False)
        return int((walls[:-1, :] != walls[1:, :]).sum() + (walls[:, :-1] != walls[:, 1:]).sum())

    @classmethod
    def from_points(cls, points: NDArray[np.float64], resolution: float, margin: int = 2) -> PlanRaster:
        """Rasterises wall points: a pixel is wall when a point falls into it. The image is
        axis-aligned (yaw 0) with `margin` free pixels around the points."""
        res = positive(resolution, "resolution", "metres per pixel")
        lo = points.min(axis=0) - margin * res
        cols_rows = np.floor((points.max(axis=0) - lo) / res).astype(np.int64) + margin + 1
        cols, rows = int(cols_rows[0]), int(cols_rows[1])
        if cols * rows > MAX_IMAGE_PIXELS:
            raise ValueError(f"a raster of {cols} x {rows} pixels at {res} m is too large; use a coarser resolution")
        c = np.floor((points[:, 0] - lo[0]) / res).astype(np.int64)
        r_up = np.floor((points[:, 1] - lo[1]) / res).astype(np.int64)
        walls = np.zeros((rows, cols), dtype=bool)
        walls[rows - 1 - r_up, c] = True
        return cls(walls, res, (float(lo[0]), float(lo[1]), 0.0))

    @classmethod
    def from_free_polygon(
        cls, vertices: Any, resolution: float, wall_thickness: float = 0.15, margin: int = 2
    ) -> PlanRaster:
        """Rasterises a floor given as the outline of its free space (a HouseExpo `verts` polygon):
        pixels inside the polygon are free; everything outside it within its bounding box grown by
        `wall_thickness` metres is wall (the outer walls, and the slits and notches an outline has
        where interior walls and shafts are). The image is axis-aligned (yaw 0) with `margin` free
        pixels around that box; vertex coordinates are map-frame metres.

        Raises:
            TypeError: vertices that are not real numbers, a non-integer margin.
            ValueError: not (N >= 3, 2) vertices, a non-finite vertex, a bad resolution, thickness
                or margin, a raster of more than `MAX_IMAGE_PIXELS`, or a polygon with no pixel inside it.
        """
        verts = _polygon(vertices)
        res = positive(resolution, "resolution", "metres per pixel")
        thickness = positive(wall_thickness, "wall_thickness", "metres")
        margin = whole_number(margin, "margin", 0, 1 << 20)
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is a too large raster, below
            span = (verts.max(axis=0) - verts.min(axis=0) + 2 * thickness) / res + 2 * margin + 2
        if not np.isfinite(span).all() or float(span[0]) * float(span[1]) > MAX_IMAGE_PIXELS:
            raise ValueError(
                f"a raster of {span[0]:.3g} x {span[1]:.3g} pixels at {res} m is too large; use a "
                "coarser resolution or a thinner wall"
            )
        band = max(1, int(math.ceil(thickness / res - 1e-9)))
        pad = band + margin
        lo = verts.min(axis=0) - pad * res
        cols_rows = np.ceil((verts.max(axis=0) - lo) / res).astype(np.int64) + pad
        cols, rows = int(cols_rows[0]), int(cols_rows[1])
        from matplotlib.path import Path as PolygonPath

        # A pixel is free when its centre lies inside the polygon (rows grow with +y until the flip),
        # tested a block of rows at a time: the centres of every pixel at once took 5.3 GB at 0.5 mm.
        polygon = PolygonPath(verts)
        inside = np.zeros((rows, cols), dtype=bool)
        xs = lo[0] + (np.arange(cols) + 0.5) * res
        block = max(1, (1 << 20) // max(1, cols))
        for r0 in range(0, rows, block):
            ys = lo[1] + (np.arange(r0, min(rows, r0 + block)) + 0.5) * res
            centres = np.column_stack([np.tile(xs, len(ys)), np.repeat(ys, cols)])
            inside[r0 : r0 + len(ys)] = polygon.contains_points(centres).reshape(len(ys), cols)
        if not inside.any():
            raise ValueError(f"the polygon covers no pixel at resolution {res} m (is it smaller than a pixel?)")
        walls = np.zeros((rows, cols), dtype=bool)
        walls[margin : rows - margin, margin : cols - margin] = True
        walls &= ~inside
        return cls(np.ascontiguousarray(walls[::-1]), res, (float(lo[0]), float(lo[1]), 0.0))


def thin_wall_pixels(walls: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """(H, W) bool: the wall pixels of walls drawn at most two pixels thick.

    A wall pixel is part of a thick wall when it is, or touches (8-neighbourhood), a pixel whose
    four neighbours are all wall: a wall three or more pixels across has such an interior, and every
    pixel of it lies within one pixel of it. A wall one or two pixels across has none: the image
    does not resolve its two faces, and the pixels mark where the surface is (a SLAM map's
    occupied cells, where beams ended), not solid material.
    """
    cv2 = _cv2()
    mask = walls.astype(np.uint8)
    cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
    interior = cv2.erode(mask, cross, borderType=cv2.BORDER_CONSTANT, borderValue=0)
    thick = cv2.dilate(interior, np.ones((3, 3), np.uint8)) > 0
    return np.asarray(walls & ~thick, dtype=np.bool_)


def _polygon(vertices: Any) -> NDArray[np.float64]:
    verts = as_points(vertices, "polygon vertices")
    if len(verts) < 3:
        raise ValueError(f"a polygon needs at least 3 vertices, got {len(verts)}")
    return verts


def _colour_to_gray(image: NDArray[Any]) -> NDArray[Any]:
    """The mean of the colour channels, transparent pixels white, in the image's own type; computed
    a block of rows at a time, so a large colour image needs no float64 copy of itself."""
    out = np.empty(image.shape[:2], dtype=image.dtype if image.dtype.kind in "ui" else np.float64)
    top = np.iinfo(image.dtype).max if image.dtype.kind in "ui" else 1.0
    rows = max(1, (1 << 22) // max(1, image.shape[1]))  # about 4 million pixels a block
    for start in range(0, image.shape[0], rows):
        block = image[start : start + rows]
        gray = block[:, :, :3].astype(np.float64).mean(axis=2)
        if image.shape[2] == 4:
            alpha = block[:, :, 3]
            a = alpha.astype(np.float64) / (np.iinfo(alpha.dtype).max if alpha.dtype.kind in "ui" else 1.0)
            gray = gray * a + top * (1.0 - a)
        out[start : start + rows] = gray  # truncated to the image's type, as astype does
    return out


def _chroma(image: NDArray[Any]) -> NDArray[np.uint8]:
    """Max minus min of the colour channels of a (H, W, 3 or 4) image, scaled to 0..255."""
    rgb = image[:, :, :3]
    top = float(np.iinfo(image.dtype).max) if image.dtype.kind in "ui" else 1.0
    spread = rgb.max(axis=2).astype(np.float64) - rgb.min(axis=2)
    with np.errstate(invalid="ignore"):
        scaled = np.nan_to_num(spread * (255.0 / top), nan=0.0)
    chroma: NDArray[np.uint8] = np.clip(np.round(scaled), 0, 255).astype(np.uint8)
    return chroma


def load_gray(source: str | Path | NDArray[Any], what: str = "plan image") -> NDArray[np.uint8]:
    """An 8-bit grey image from a path (PNG, JPG, PGM, BMP, ...) or an array.

    Colour is converted to grey, transparent pixels become white (no wall), 16-bit and float images
    are rescaled to 0..255.
    """
    return load_gray_and_chroma(source, what)[0]


def _read_image(source: str | Path | NDArray[Any], what: str) -> tuple[NDArray[Any], str]:
    """The pixels of an image file (upright by its EXIF orientation; OpenCV's channel order, BGR)
    or of an array, and the name to call it in messages."""
    cv2 = _cv2()
    if isinstance(source, (str, Path)):
        path = Path(source)
        require_regular_file(path, what)
        check_image_file(path, what)
        try:
            image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        except cv2.error as exc:
            raise ValueError(f"{what} {path} could not be read as an image: {str(exc).strip()[-200:]}") from None
        if image is None:
            raise ValueError(
                f"{what} {path} could not be read as an image (unsupported or corrupt file; plans are read "
                "from PNG, JPEG, TIFF, BMP, PGM and the drawing formats DXF, PDF, SVG and IFC)"
            )
        image = _upright(image, exif_orientation(path))
        name = str(path)
    else:
        image = np.asarray(source)
        name = f"{what} array"
        if image.dtype.kind not in "uifb":
            raise TypeError(f"{name} must hold numbers, got dtype {image.dtype}")
    return image, name


def load_rgb(source: str | Path | NDArray[Any], what: str = "plan image") -> NDArray[np.uint8]:
    """The image as it is seen, (H, W, 3) 8-bit RGB (grey repeated; transparent pixels white), for
    figures drawn on the drawing itself."""
    image, name = _read_image(source, what)
    if image.ndim == 3 and image.shape[2] in (3, 4):
        rgb = np.stack(
            [load_gray(image[:, :, [c, c, c] + ([3] if image.shape[2] == 4 else [])]) for c in (2, 1, 0)], axis=2
        )
        if isinstance(source, (str, Path)):
            return rgb  # OpenCV decoded the file as BGR
        return np.ascontiguousarray(rgb[:, :, ::-1])  # an array is taken as RGB
    gray = load_gray(image, what)
    return np.repeat(gray[:, :, None], 3, axis=2)


def load_gray_and_chroma(
    source: str | Path | NDArray[Any], what: str = "plan image"
) -> tuple[NDArray[np.uint8], NDArray[np.uint8] | None]:
    """`load_gray`'s grey image, and for a colour image its chroma: the largest minus the smallest
    of the red, green and blue values, 0..255 (0: neutral grey; None for a grey image)."""
    image, name = _read_image(source, what)
    chroma = None
    if image.ndim == 3 and image.shape[2] in (3, 4):
        chroma = _chroma(image)
        image = _colour_to_gray(image)
    if image.ndim != 2:
        raise ValueError(f"{name} must be a 2-D grey image (or colour), got shape {image.shape}")
    if image.size == 0:
        raise ValueError(f"{name} has no pixels")
    if image.dtype == np.uint8:
        return np.ascontiguousarray(image), chroma
    if image.dtype == np.bool_:
        return np.where(image, 255, 0).astype(np.uint8), chroma
    if image.dtype.kind in "ui":
        top = float(np.iinfo(image.dtype).max)
        scaled: NDArray[np.uint8] = np.clip(np.round(image.astype(np.float64) * 255.0 / top), 0, 255).astype(np.uint8)
        return scaled, chroma
    values = image.astype(np.float64)
    if not np.isfinite(values).all():
        raise ValueError(f"{name} has NaN or inf pixels")
    top = 1.0 if values.max() <= 1.0 else 255.0
    out: NDArray[np.uint8] = np.clip(np.round(values * 255.0 / top), 0, 255).astype(np.uint8)
    return out, chroma


EXIF_ORIENTATION_TAG = 0x0112
"""The EXIF tag that says how a camera held the picture: 1 upright, 3 upside down, 6 and 8 turned
a quarter, 2, 4, 5 and 7 mirrored."""


def exif_orientation(path: Path) -> int:
    """The EXIF orientation (1..8) of an image file, read with Pillow (a dependency of matplotlib);
    1 (upright) when the file has none, Pillow cannot read it, or the value is not 1..8."""
    try:
        from PIL import Image, UnidentifiedImageError
    except ImportError:  # pragma: no cover - matplotlib requires Pillow
        return 1
    try:
        with Image.open(path) as image:
            value = image.getexif().get(EXIF_ORIENTATION_TAG, 1)
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, Image.DecompressionBombError):
        return 1
    return int(value) if isinstance(value, int) and 1 <= value <= 8 else 1


def _upright(image: NDArray[Any], orientation: int) -> NDArray[Any]:
    """`image` (rows, cols[, channels]) turned as EXIF `orientation` says the picture is seen: what
    Pillow's ImageOps.exif_transpose does, on the array OpenCV decoded (which keeps 16-bit depth)."""
    if orientation == 2:
        image = image[:, ::-1]
    elif orientation == 3:
        image = image[::-1, ::-1]
    elif orientation == 4:
        image = image[::-1, :]
    elif orientation == 5:
        image = np.swapaxes(image, 0, 1)
    elif orientation == 6:
        image = np.rot90(image, k=-1)
    elif orientation == 7:
        image = np.rot90(image, k=-1)[:, ::-1]
    elif orientation == 8:
        image = np.rot90(image, k=1)
    return np.ascontiguousarray(image)


def wall_mask(
    gray: NDArray[np.uint8],
    threshold: int | None = None,
    *,
    open_px: int = 0,
    close_px: int = 0,
    what: str = "plan image",
) -> NDArray[np.bool_]:
    """Walls = dark pixels: grey < `threshold` (0..255), or Otsu's threshold when None.

    `open_px` removes dark specks smaller than that many pixels (text, dirt of a scan);
    `close_px` closes gaps up to that many pixels in walls (a scanned drawing's broken lines).
    Raises ValueError when the result has no wall or is all wall.
    """
    cv2 = _cv2()
    if threshold is None:
        if int(gray.min()) == int(gray.max()):
            raise ValueError(f"{what} is a single grey level ({int(gray.min())}): no walls to find")
        level, _ = cv2.threshold(gray, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
        mask = gray <= level
    else:
        if isinstance(threshold, bool) or not isinstance(threshold, (int, np.integer)) or not 1 <= threshold <= 255:
            raise ValueError(f"threshold must be an integer grey level in 1..255, got {threshold!r}")
        mask = gray < threshold
    largest = max(gray.shape)
    for name, size, op in (("open_px", open_px, cv2.MORPH_OPEN), ("close_px", close_px, cv2.MORPH_CLOSE)):
        if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 0:
            raise ValueError(f"{name} must be an integer number of pixels >= 0, got {brief(size)}")
        if size > largest:
            raise ValueError(
                f"{name}={size} pixels is larger than the {what} itself ({gray.shape[1]} x {gray.shape[0]} "
                f"pixels); give the size of the specks or gaps to remove, a few pixels"
            )
        if size > 0:
            kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (int(size), int(size)))
            mask = cv2.morphologyEx(mask.astype(np.uint8), op, kernel) > 0
    if not mask.any():
        raise ValueError(f"{what} has no walls (no pixel darker than the threshold)")
    if mask.all():
        raise ValueError(f"{what} is all wall (every pixel darker than the threshold)")
    return np.asarray(mask, dtype=bool)


def resolution_from_pixels(pixel_a: tuple[float, float], pixel_b: tuple[float, float], distance_m: float) -> float:
    """Metres per pixel from two image positions (col, row; e.g. the ends of a wall or of the
    drawing's scale bar) and the real distance between them in metres."""
    a = np.asarray(pixel_a, dtype=np.float64)
    b = np.asarray(pixel_b, dtype=np.float64)
    if a.shape != (2,) or b.shape != (2,) or not (np.isfinite(a).all() and np.isfinite(b).all()):
        raise ValueError(f"pixel positions must be finite (col, row) pairs, got {pixel_a!r} and {pixel_b!r}")
    pixels = float(np.hypot(*(b - a)))
    if pixels == 0.0:
        raise ValueError("the two pixel positions are the same point")
    return positive(distance_m, "distance_m", "metres") / pixels
