"""Plans from images and ROS maps: geometry, map_server semantics, round trips, cache, CLI, errors."""

from __future__ import annotations

import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

import planicp
from planicp import PlanMap, PlanRaster, read_ros_map, resolution_from_pixels
from planicp import sim as synthetic
from planicp.cli import main as cli_main
from planicp.plans.plan_raster import wall_mask
from planicp.plans.ros_map import write_ros_map

DATA = Path(__file__).parent / "data"


def sorted_rows(points: np.ndarray) -> np.ndarray:
    return points[np.lexsort((points[:, 1], points[:, 0]))]


@pytest.fixture(autouse=True)
def cache_dir(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "cache"
    monkeypatch.setenv("PLANICP_CACHE_DIR", str(folder))
    return folder


@pytest.mark.skipif(sys.platform != "linux", reason="the XDG layout is Linux's")
def test_the_cache_folder_is_the_environments_then_the_users_cache(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`$PLANICP_CACHE_DIR` wins; without it the user cache folder (`$XDG_CACHE_HOME/planicp`)."""
    from planicp.plans.plan_cache import default_cache_dir

    assert default_cache_dir() == tmp_path / "cache"
    monkeypatch.delenv("PLANICP_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "xdg" / "planicp"


@pytest.fixture(scope="module")
def floor() -> synthetic.Floor:
    return synthetic.generate_floor(3, "office", width=20.0, height=12.0, rooms=4)


def test_image_points_are_the_wall_surfaces(floor: synthetic.Floor) -> None:
    """A plan image of a known floor gives exactly the faces between wall and free cells."""
    ox, oy = floor.origin
    plan = PlanMap.from_image(floor.to_image(), floor.resolution, (ox, oy, 0.0))
    expected = floor.wall_points()
    assert len(plan) == len(expected)
    np.testing.assert_allclose(sorted_rows(plan.points), sorted_rows(expected), atol=1e-9)


def test_origin_yaw_rotates_the_plan(floor: synthetic.Floor) -> None:
    flat = PlanMap.from_image(floor.to_image(), floor.resolution, (1.0, -2.0, 0.0))
    yaw = math.radians(30.0)
    turned = PlanMap.from_image(floor.to_image(), floor.resolution, (1.0, -2.0, yaw))
    rel = flat.points - [1.0, -2.0]
    c, s = math.cos(yaw), math.sin(yaw)
    expected = rel @ np.array([[c, s], [-s, c]]) + [1.0, -2.0]
    np.testing.assert_allclose(turned.points, expected, atol=1e-9)


def test_image_ros_map_round_trip(floor: synthetic.Floor, tmp_path: Path) -> None:
    plan = PlanMap.from_image(floor.to_image(), floor.resolution, (floor.origin[0], floor.origin[1], 0.0))
    yaml_path = plan.to_ros_map(tmp_path / "out" / "floor.yaml")
    back = PlanMap.from_ros_map(yaml_path, cache=False)
    np.testing.assert_array_equal(back.points, plan.points)
    # The map says its cells are wall material (a drawing): read as an occupancy grid instead, its
    # cells' centres would stand half a pixel inside every wall.
    assert read_ros_map(yaml_path).edge_detector == "boundary" == back.edge_detector
    assert len(PlanMap.from_ros_map(yaml_path, edge_detector="centres", cache=False)) != len(plan)
    meta = read_ros_map(yaml_path)
    assert meta.resolution == floor.resolution
    assert meta.origin == (floor.origin[0], floor.origin[1], 0.0)
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["floor.pgm", "floor.yaml"]
    text = yaml_path.read_text()
    yaml_path.write_text(text.replace("planicp_edge_detector: boundary", "planicp_edge_detector: faces"))
    with pytest.raises(ValueError, match="planicp_edge_detector must be one of"):
        PlanMap.from_ros_map(yaml_path, cache=False)
    with pytest.raises(ValueError, match="edge_detector must be one of"):
        write_ros_map(
            tmp_path / "bad.yaml", np.zeros((4, 4), dtype=np.int8), 0.05, (0.0, 0.0, 0.0), edge_detector="faces"
        )
    assert not (tmp_path / "bad.yaml").exists()  # refused before anything is written


@pytest.mark.parametrize("name", ["tb3_sandbox", "depot"])
def test_ros_map_and_image_of_it_agree(name: str) -> None:
    """nav2 maps (negative origins, trinary): the ROS map and the same PGM read as an image with the
    equivalent threshold and the same reading of its pixels give identical points, inside the map's
    extent. By default the map is read as an occupancy grid (every occupied cell's centre) and the
    image as a drawing (every face)."""
    ros = read_ros_map(DATA / f"{name}.yaml")
    # trinary occupied: (255 - v) / 255 > occupied_thresh  <=>  v < 255 * (1 - occupied_thresh)
    threshold = math.ceil(255 * (1 - ros.occupied_thresh))
    for ros_reading, image_reading in (("centres", "centres"), ("auto", "auto"), ("boundary", "boundary")):
        plan = PlanMap.from_ros_map(DATA / f"{name}.yaml", edge_detector=ros_reading)
        image_plan = PlanMap.from_image(
            DATA / f"{name}.pgm",
            ros.resolution,
            ros.origin,
            threshold=threshold,
            edge_detector=image_reading,
            walls="all-dark",  # a map, not a drawing: every occupied pixel is wall
        )
        np.testing.assert_array_equal(plan.points, image_plan.points)
    by_default = PlanMap.from_ros_map(DATA / f"{name}.yaml")
    occupied = int(np.count_nonzero(ros.wall_raster().walls))
    assert len(by_default) == occupied < len(plan)  # one point per occupied cell, not one per face
    rows, cols = ros.occupancy.shape
    xmin, ymin, xmax, ymax = plan.extent
    assert ros.origin[0] <= xmin and xmax <= ros.origin[0] + cols * ros.resolution
    assert ros.origin[1] <= ymin and ymax <= ros.origin[1] + rows * ros.resolution
    assert len(plan) == plan.raster.boundary_face_count()  # type: ignore[union-attr]


def test_a_map_that_says_nothing_is_read_as_a_slam_map_or_a_drawing_by_its_cells(tmp_path: Path) -> None:
    """Without `planicp_edge_detector` a map_server map is read by what its occupied cells are:
    nav2's maps (SLAM output: nearly every occupied cell borders free or unknown space) as a SLAM
    map's cells, the shipped office drawing (walls of material, most of their cells inside) as a
    drawing; `MATERIAL_SHARE` lies between the two."""
    from planicp.plans.default_plan import default_plan_path
    from planicp.plans.ros_map import MATERIAL_SHARE, recognised_reading

    for name in ("tb3_sandbox", "depot"):
        plan = PlanMap.from_ros_map(DATA / f"{name}.yaml", cache=False)
        assert read_ros_map(DATA / f"{name}.yaml").edge_detector is None
        assert plan.edge_detector == "centres" and plan.cells_mark_returns
    drawing = default_plan_path()
    shutil.copy(drawing.with_suffix(".png"), tmp_path / "office_plan.png")
    text = drawing.read_text()
    assert "planicp_edge_detector: auto" in text
    (tmp_path / "office.yaml").write_text(text.replace("planicp_edge_detector: auto\n", ""))
    assert read_ros_map(tmp_path / "office.yaml").edge_detector is None
    office = PlanMap.from_ros_map(tmp_path / "office.yaml", cache=False)
    assert office.edge_detector == "auto" and not office.cells_mark_returns
    np.testing.assert_array_equal(office.points, PlanMap.from_ros_map(drawing, cache=False).points)
    # The rule itself: a band three cells thick has a third of its cells inside, one two cells thick none.
    band = np.zeros((7, 40), dtype=bool)
    band[2:4, 1:39] = True
    assert recognised_reading(band) == "centres"
    band[4, 1:39] = True
    inside = 36 / (3 * 38)
    assert inside < MATERIAL_SHARE and recognised_reading(band) == "centres"
    band[5, 1:39] = True  # four cells thick: half inside
    assert recognised_reading(band) == "auto"
    assert recognised_reading(np.zeros((3, 3), dtype=bool)) == "centres"


def test_willow_at_ten_centimetres() -> None:
    plan = PlanMap.from_image(DATA / "willow-full.pgm", 0.1, walls="all-dark")  # a SLAM map, not a drawing
    xmin, ymin, xmax, ymax = plan.extent
    # 540 x 587 px at 0.1 m: the building fills most of the 54.0 x 58.7 m image.
    assert 50.0 < xmax - xmin <= 54.0 and 55.0 < ymax - ymin <= 58.7
    assert 20_000 < len(plan) < 30_000


def write_map(folder: Path, pixels: np.ndarray, **meta: object) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    h, w = pixels.shape
    (folder / "m.pgm").write_bytes(f"P5\n{w} {h}\n255\n".encode() + pixels.astype(np.uint8).tobytes())
    fields = {
        "image": "m.pgm",
        "resolution": 0.1,
        "origin": [0.0, 0.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
        **meta,
    }
    text = "".join(f"{k}: {v}\n" for k, v in fields.items())
    (folder / "m.yaml").write_text(text)
    return folder / "m.yaml"


def test_map_server_modes(tmp_path: Path) -> None:
    # p = (255 - v) / 255 = 1.0, 0.608, 0.196078, 0.0039, 0.0 (thresholds 0.65 / 0.196)
    pixels = np.array([[0, 100, 205, 254, 255]])
    assert read_ros_map(write_map(tmp_path / "t", pixels)).occupancy.tolist() == [[100, -1, -1, 0, 0]]
    # scale: 99 * (0.6078 - 0.196) / (0.65 - 0.196) = 89.8 -> 90; 0.196078 -> 0
    assert read_ros_map(write_map(tmp_path / "s", pixels, mode="scale")).occupancy.tolist() == [[100, 90, 0, 0, 0]]
    # negate: p = v / 255
    assert read_ros_map(write_map(tmp_path / "n", pixels, negate=1)).occupancy.tolist() == [[0, -1, 100, 100, 100]]
    raw = read_ros_map(write_map(tmp_path / "r", np.array([[0, 50, 100, 101, 255]]), mode="raw")).occupancy
    assert raw.tolist() == [[0, 50, 100, -1, -1]]


def test_ros_map_errors(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="does not exist"):
        PlanMap.from_ros_map(tmp_path / "nope.yaml")
    good = write_map(tmp_path / "g", np.array([[0, 254], [254, 254]]))
    text = good.read_text()
    (tmp_path / "g" / "missing.yaml").write_text(text.replace("resolution: 0.1\n", ""))
    with pytest.raises(ValueError, match=r"missing\.yaml is missing keys \['resolution'\]"):
        PlanMap.from_ros_map(tmp_path / "g" / "missing.yaml")
    (tmp_path / "g" / "noimg.yaml").write_text(text.replace("m.pgm", "gone.pgm"))
    with pytest.raises(FileNotFoundError, match="names image 'gone.pgm', which does not exist"):
        PlanMap.from_ros_map(tmp_path / "g" / "noimg.yaml")
    (tmp_path / "g" / "res.yaml").write_text(text.replace("resolution: 0.1", "resolution: -0.1"))
    with pytest.raises(ValueError, match="resolution must be positive"):
        PlanMap.from_ros_map(tmp_path / "g" / "res.yaml")
    (tmp_path / "g" / "mode.yaml").write_text(text + "mode: fancy\n")
    with pytest.raises(ValueError, match="mode must be one of"):
        PlanMap.from_ros_map(tmp_path / "g" / "mode.yaml")
    (tmp_path / "g" / "bad.yaml").write_text("image: [unclosed\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        PlanMap.from_ros_map(tmp_path / "g" / "bad.yaml")
    empty = write_map(tmp_path / "e", np.full((3, 3), 254))
    with pytest.raises(ValueError, match="has no occupied cells"):
        PlanMap.from_ros_map(empty)


def test_image_errors(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"plan image .*missing\.png does not exist"):
        PlanMap.from_image(tmp_path / "missing.png", 0.05)
    junk = tmp_path / "junk.png"
    junk.write_bytes(b"not an image at all")
    with pytest.raises(ValueError, match=r"junk\.png could not be read as an image"):
        PlanMap.from_image(junk, 0.05)
    with pytest.raises(ValueError, match="single grey level"):
        PlanMap.from_image(np.full((20, 20), 255, np.uint8), 0.05)
    with pytest.raises(ValueError, match="single grey level"):
        PlanMap.from_image(np.zeros((20, 20), np.uint8), 0.05)
    with pytest.raises(ValueError, match="has no walls"):
        PlanMap.from_image(np.full((20, 20), 255, np.uint8), 0.05, threshold=100)
    with pytest.raises(ValueError, match="is all wall"):
        PlanMap.from_image(np.zeros((20, 20), np.uint8), 0.05, threshold=100)
    image = np.full((20, 20), 255, np.uint8)
    image[5:8, 2:18] = 0
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(ValueError, match="resolution must be a positive"):
            PlanMap.from_image(image, bad)
    with pytest.raises(ValueError, match="threshold must be an integer grey level"):
        PlanMap.from_image(image, 0.05, threshold=300)
    with pytest.raises(ValueError, match="edge_detector must be"):
        PlanMap.from_image(image, 0.05, edge_detector="sobel", cache=False)
    assert list((tmp_path / "cache").glob("*.tmp")) == [] if (tmp_path / "cache").exists() else True


def test_colour_alpha_and_morphology() -> None:
    rgba = np.full((30, 30, 4), 255, np.uint8)
    rgba[10:13, 3:27, :3] = 0  # a black wall
    rgba[20, 20, :3] = 0  # a speck of dirt
    rgba[0:5, 0:5, 3] = 0  # transparent black corner counts as background
    rgba[0:5, 0:5, :3] = 0
    plan = PlanMap.from_image(rgba, 0.05, threshold=128, walls="all-dark")  # the mask itself, speck included
    cleaned = PlanMap.from_image(rgba, 0.05, threshold=128, open_px=2, walls="all-dark")
    assert len(plan) == 2 * 24 + 2 * 3 + 4  # the wall's perimeter faces plus the speck's 4
    assert len(cleaned) == 2 * 24 + 2 * 3


def test_canny_option_loses_faces_on_a_real_map() -> None:
    ros = read_ros_map(DATA / "depot.yaml")
    raster = ros.wall_raster()
    boundary = raster.surface_points("boundary")
    canny = raster.surface_points("canny")
    assert len(boundary) == raster.boundary_face_count()
    assert 0.8 * len(boundary) < len(canny) < len(boundary)


def test_an_image_finer_than_useful_is_thinned_and_cached_as_thinned(cache_dir: Path) -> None:
    """An image at 1 mm per pixel has more than two wall-surface points per 5 mm square: its plan
    keeps one per square, and the cache stores that plan (its points with their normals), so that
    a second load gives the same plan."""
    image = np.full((1500, 2500), 255, np.uint8)  # 2.5 x 1.5 m
    image[:40, :] = image[-40:, :] = 0  # 4 cm walls all round
    image[:, :40] = image[:, -40:] = 0
    image[600:900, 1200:1240] = 0  # a pillar
    surfaces = PlanRaster(wall_mask(image, None), 0.001, (0.0, 0.0, 0.0)).surface_points("boundary")
    first = PlanMap.from_image(image, 0.001)
    second = PlanMap.from_image(image, 0.001)
    assert not first.from_cache and second.from_cache
    assert len(first) < len(surfaces) / 4  # about one of the 5 points per 5 mm of surface
    np.testing.assert_array_equal(first.points, second.points)
    np.testing.assert_array_equal(first.normals, second.normals)
    pose = (1.0, 0.75, 0.2)
    scan = planicp.se2.transform_points(planicp.se2.inverse(pose), first.visible_from(pose)[::3])
    assert math.dist(planicp.localize(scan, second, (1.03, 0.73, 0.21)).pose[:2], pose[:2]) < 0.005


def test_cache_hits_misses_and_corruption(floor: synthetic.Floor, tmp_path: Path, cache_dir: Path) -> None:
    path = tmp_path / "plan.png"
    WALLS = "all-dark"  # a clean wall image: one dark pixel more is 4 faces more
    import cv2

    cv2.imwrite(str(path), floor.to_image())
    first = PlanMap.from_image(path, 0.05, walls=WALLS)
    assert not first.from_cache
    second = PlanMap.from_image(path, 0.05, walls=WALLS)
    assert second.from_cache
    np.testing.assert_array_equal(first.points, second.points)
    assert not PlanMap.from_image(path, 0.05, (1.0, 0.0, 0.0), walls=WALLS).from_cache  # another parameter
    assert not PlanMap.from_image(path, 0.05, close_px=1, walls=WALLS).from_cache
    image = floor.to_image().copy()
    image[image.shape[0] // 2, image.shape[1] // 2] = 0  # the file changes
    cv2.imwrite(str(path), image)
    changed = PlanMap.from_image(path, 0.05, walls=WALLS)
    assert not changed.from_cache and len(changed) == len(first) + 4
    entries = sorted(cache_dir.glob("*.npz"))
    assert len(entries) == 4
    for entry in entries:
        entry.write_bytes(b"corrupt")
    np.testing.assert_array_equal(second.normals, first.normals)  # stored with the entry
    rebuilt = PlanMap.from_image(path, 0.05, walls=WALLS)
    assert not rebuilt.from_cache and len(rebuilt) == len(changed)
    assert PlanMap.from_image(path, 0.05, walls=WALLS).from_cache
    assert list(cache_dir.glob("*.tmp")) == []
    assert not PlanMap.from_image(path, 0.05, cache=False).from_cache
    assert PlanMap.from_image(path, 0.05, cache=tmp_path / "other").from_cache is False
    with pytest.raises(TypeError, match="cache must be"):
        PlanMap.from_image(path, 0.05, cache=3)  # type: ignore[arg-type]


def test_resolution_from_pixels() -> None:
    assert resolution_from_pixels((10, 10), (110, 10), 5.0) == pytest.approx(0.05)
    assert resolution_from_pixels((0, 0), (30, 40), 2.5) == pytest.approx(0.05)
    with pytest.raises(ValueError, match="same point"):
        resolution_from_pixels((3, 3), (3, 3), 1.0)
    with pytest.raises(ValueError, match="distance_m must be a positive"):
        resolution_from_pixels((0, 0), (1, 0), 0.0)
    with pytest.raises(ValueError, match="finite"):
        resolution_from_pixels((0, math.nan), (1, 0), 1.0)


def test_points_plan_to_ros_map_is_within_a_pixel(tmp_path: Path) -> None:
    t = np.linspace(0.0, 4.0, 161)
    pts = np.concatenate([np.column_stack([t, np.zeros_like(t)]), np.column_stack([np.zeros_like(t), t])])
    plan = PlanMap.from_points(pts)
    back = PlanMap.from_ros_map(plan.to_ros_map(tmp_path / "p.yaml", resolution=0.05), cache=False)
    d = np.min(np.hypot(*(back.points[:, None, :] - pts[None, :, :]).transpose(2, 0, 1)), axis=1)
    assert d.max() <= 0.05 * math.sqrt(2) + 1e-9


def test_localize_on_a_real_map_with_visibility() -> None:
    """Scans simulated in the depot map (its own occupied cells), aligned from 0.2 m / 3 deg off."""
    ros = read_ros_map(DATA / "depot.yaml")
    # synthetic.Floor rows grow with y; a frame of unknown cells closes the map's open edges.
    up = np.pad(ros.occupancy[::-1], 3, constant_values=-1)
    corner = (ros.origin[0] - 3 * ros.resolution, ros.origin[1] - 3 * ros.resolution)
    # Unknown cells (outside the mapped area) block beams like walls but are not in the plan.
    floor = synthetic.Floor(up == 100, up == -1, ros.resolution, corner)
    plan = PlanMap.from_ros_map(DATA / "depot.yaml")
    rng = np.random.default_rng(5)
    ok = []
    for _ in range(12):
        truth = floor.sample_pose(rng, clearance=0.6)
        scan, _ = synthetic.simulate_scan(floor, truth, rng)
        guess = synthetic.perturb_pose(truth, rng, 0.2, math.radians(3.0))
        result = planicp.localize(scan, plan, guess)
        dx, dy, dyaw = planicp.se2.between(truth, result.pose)
        ok.append(math.hypot(dx, dy) < 0.05 and abs(dyaw) < math.radians(0.5))
    assert np.mean(ok) >= 11 / 12


def test_cli_plan(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    willow = ["plan", str(DATA / "willow-full.pgm"), "--resolution", "0.1", "--walls", "all-dark"]  # a SLAM map
    assert cli_main([*willow, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "wall points, extent x" in text and "(53.20 x 57.10 m)" in text
    assert sorted(p.name for p in out.iterdir()) == ["overlay.png", "plan.pgm", "plan.yaml", "wall_points.csv"]
    points = np.loadtxt(out / "wall_points.csv", delimiter=",", skiprows=1)
    assert points.shape[1] == 2 and len(points) > 20_000
    shutil.copy(DATA / "depot.yaml", tmp_path / "depot.yaml")
    shutil.copy(DATA / "depot.pgm", tmp_path / "depot.pgm")
    assert cli_main(["plan", str(tmp_path / "depot.yaml"), "--out", str(tmp_path / "d")]) == 0
    assert cli_main(["plan", str(tmp_path / "nothing.png"), "--resolution", "0.1", "--out", str(out)]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert cli_main(["plan", str(DATA / "willow-full.pgm"), "--out", str(out)]) == 2
    assert "--resolution" in capsys.readouterr().err


def test_plan_raster_validation() -> None:
    with pytest.raises(ValueError, match="2-D bool"):
        PlanRaster(np.zeros((3, 3), np.uint8), 0.1, (0.0, 0.0, 0.0))  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="resolution must be a positive"):
        PlanRaster(np.zeros((3, 3), bool), 0.0, (0.0, 0.0, 0.0))


def test_vector_constructors_and_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import ezdxf

    segments = np.array([[[0.0, 0.0], [4.0, 0.0]], [[4.0, 0.0], [4.0, 3.0]], [[4.0, 3.0], [0.0, 0.0]]])
    plan = PlanMap.from_segments(segments, spacing=0.05)
    assert plan.raster_resolution == pytest.approx(0.075)
    assert len(plan) == 80 + 60 + 100  # 4 m, 3 m, 5 m at 5 cm, shared corners once
    house = PlanMap.from_house_expo(DATA / "house_expo_room_0000.json")
    xmin, ymin, xmax, ymax = house.extent
    assert (xmin, ymin, xmax, ymax) == pytest.approx((0.1, 0.1, 10.17, 8.16))
    doc = ezdxf.new()
    doc.header["$INSUNITS"] = 4  # millimetres
    doc.modelspace().add_line((0, 0), (4000, 0), dxfattribs={"layer": "WALLS"})
    doc.modelspace().add_line((0, 500), (1000, 500), dxfattribs={"layer": "FURNITURE"})
    doc.saveas(tmp_path / "room.dxf")
    walls_only = PlanMap.from_dxf(tmp_path / "room.dxf", layers=["walls"], spacing=0.1)
    assert len(walls_only) == 41 and walls_only.extent == pytest.approx((0.0, 0.0, 4.0, 0.0))
    assert cli_main(["plan", str(tmp_path / "room.dxf"), "--layer", "WALLS", "--out", str(tmp_path / "o")]) == 0
    assert "201 wall points" in capsys.readouterr().out
    assert cli_main(["plan", str(DATA / "house_expo_room_0000.json"), "--out", str(tmp_path / "h")]) == 0
    assert cli_main(["plan", str(tmp_path / "room.dxf"), "--layer", "DOORS", "--out", str(tmp_path / "x")]) == 2
    assert "no layer 'doors'" in capsys.readouterr().err.lower()


def test_free_polygon_raster_walls_the_outline_and_fills_notches() -> None:
    """A U-shaped free space (a 4 x 3 m room with a 1 m deep, 0.6 m wide notch in its top wall):
    the outline becomes the wall surface, the notch is filled with wall, the inside stays free."""
    verts = [(0, 0), (4, 0), (4, 3), (2.3, 3), (2.3, 2), (1.7, 2), (1.7, 3), (0, 3)]
    raster = PlanRaster.from_free_polygon(verts, 0.05, wall_thickness=0.15)
    plan = PlanMap.from_raster(raster)
    outline = np.array(verts, float)
    segments = np.stack([outline, np.roll(outline, -1, axis=0)], axis=1)
    sampled = planicp.plans.vector_plan.sample_segments(segments, 0.01)
    from scipy.spatial import cKDTree

    # every inner wall surface point lies on the outline (within a pixel), and the outline is covered
    inner = plan.points[
        (plan.points[:, 0] > -0.01)
        & (plan.points[:, 0] < 4.01)
        & (plan.points[:, 1] > -0.01)
        & (plan.points[:, 1] < 3.01)
    ]
    assert cKDTree(sampled).query(inner)[0].max() <= 0.05
    assert cKDTree(plan.points).query(sampled)[0].max() <= 0.05
    # the notch (between x 1.7 and 2.3 above y 2) is wall all the way up through the band
    to_map = raster.pixel_to_map
    rows, cols = np.nonzero(raster.walls)
    wall_xy = to_map(rows + 0.5, cols + 0.5)
    notch = (np.abs(wall_xy[:, 0] - 2.0) < 0.25) & (wall_xy[:, 1] > 2.05) & (wall_xy[:, 1] < 3.1)
    assert notch.sum() == pytest.approx(0.5 / 0.05 * 1.0 / 0.05, rel=0.25)
    rows, cols = np.nonzero(~raster.walls)
    free_xy = to_map(rows + 0.5, cols + 0.5)
    assert not ((np.abs(free_xy[:, 0] - 2.0) < 0.25) & (free_xy[:, 1] > 2.05) & (free_xy[:, 1] < 3.1)).any()
    with pytest.raises(ValueError, match="needs at least 3 vertices"):
        PlanRaster.from_free_polygon([(0, 0), (1, 1)], 0.05)
    with pytest.raises(ValueError, match="too large"):
        PlanRaster.from_free_polygon(verts, 1e-6)
    with pytest.raises(ValueError, match="finite"):
        PlanRaster.from_free_polygon([(0, 0), (1, 0), (0, math.nan)], 0.05)
    with pytest.raises(ValueError, match="wall_thickness"):
        PlanRaster.from_free_polygon(verts, 0.05, wall_thickness=0.0)
    with pytest.raises(ValueError, match="covers no pixel"):
        PlanRaster.from_free_polygon([(0, 0), (0.01, 0), (0, 0.01)], 0.05)


def test_house_expo_raster_route_and_folder(tmp_path: Path) -> None:
    """`load_plan(house.json, resolution=r)` gives a plan with a raster (what the simulation needs)
    whose wall surfaces follow the outline; a folder lists its HouseExpo files."""
    from planicp.plans.plan_loading import house_expo_files, load_plan

    source = DATA / "house_expo_room_0000.json"
    points_only = load_plan(source)
    rastered = load_plan(source, resolution=0.05)
    assert points_only.raster is None and rastered.raster is not None
    from scipy.spatial import cKDTree

    assert cKDTree(rastered.points).query(points_only.points)[0].max() <= 0.05
    folder = tmp_path / "plans"
    folder.mkdir()
    with pytest.raises(ValueError, match="holds no HouseExpo .json file"):
        house_expo_files(folder)
    shutil.copy(source, folder / "b.json")
    shutil.copy(source, folder / "a.JSON")
    (folder / "notes.txt").write_text("not a plan")
    assert [p.name for p in house_expo_files(folder)] == ["a.JSON", "b.json"]
    with pytest.raises(FileNotFoundError, match="does not exist"):
        house_expo_files(tmp_path / "none")
    with pytest.raises(NotADirectoryError, match="is not a folder"):
        house_expo_files(source)


@pytest.mark.parametrize("suffix", [".bmp", ".jpg"])
def test_other_image_formats(floor: synthetic.Floor, tmp_path: Path, suffix: str) -> None:
    import cv2

    reference = PlanMap.from_image(floor.to_image(), floor.resolution, cache=False)
    path = tmp_path / f"plan{suffix}"
    assert cv2.imwrite(str(path), floor.to_image())
    plan = PlanMap.from_image(path, floor.resolution, cache=False)
    if suffix == ".bmp":  # lossless
        np.testing.assert_array_equal(plan.points, reference.points)
    else:  # JPEG ringing moves a few boundary pixels; Otsu still separates walls from floor
        assert abs(len(plan) - len(reference)) < 0.02 * len(reference)
        d = np.min(np.hypot(*(plan.points[:, None, :] - reference.points[None, ::7, :]).transpose(2, 0, 1)), axis=1)
        assert np.percentile(d, 99) < 0.35


def test_overlay_figure(floor: synthetic.Floor) -> None:
    from matplotlib.figure import Figure

    from planicp.plans.plan_figure import plot_plan_overlay

    plan = PlanMap.from_image(floor.to_image(), floor.resolution, cache=False)
    fig = plot_plan_overlay(plan, title="office")
    assert isinstance(fig, Figure)
    ax = fig.axes[0]
    assert len(ax.images) == 1 and ax.collections[0].get_offsets().shape == (len(plan), 2)
    bare = plot_plan_overlay(PlanMap.from_points(plan.points))
    assert len(bare.axes[0].images) == 0


def test_pixel_centres_for_maps_whose_pixels_are_the_surfaces() -> None:
    # A one-pixel line in image row 2 of a 4-row, 0.1 m image (y in [0.1, 0.2) above the origin), columns 1..3.
    walls = np.zeros((4, 5), dtype=bool)
    walls[2, 1:4] = True
    raster = PlanRaster(walls, 0.1, (1.0, 2.0, 0.0))
    centres = raster.surface_points("centres")
    np.testing.assert_allclose(centres, [[1.15, 2.15], [1.25, 2.15], [1.35, 2.15]])
    faces = raster.surface_points("boundary")
    assert len(faces) == 8  # two long sides of 3 faces and two ends
    assert set(np.round(faces[:, 1], 9)) == {2.1, 2.15, 2.2}
    plan = PlanMap.from_raster(raster, edge_detector="centres")
    np.testing.assert_allclose(plan.points, centres)


def test_auto_reads_walls_one_or_two_cells_thick_as_surfaces() -> None:
    from planicp.plans.plan_raster import thin_wall_pixels

    walls = np.zeros((12, 12), dtype=bool)
    walls[1, 1:11] = True  # one pixel thick
    walls[4:6, 1:11] = True  # two pixels thick
    walls[8:11, 1:11] = True  # three pixels thick: an interior row, two faces
    thin = thin_wall_pixels(walls)
    assert thin[1].sum() == 10 and thin[4:6].sum() == 20 and not thin[8:11].any()
    raster = PlanRaster(walls, 0.1, (0.0, 0.0, 0.0))
    auto = raster.surface_points("auto")
    # The thin walls give their 30 pixel centres; the thick one its 2 x 10 + 2 x 3 faces.
    assert len(auto) == 30 + 26
    ys = np.round(auto[:, 1], 9)
    assert set(ys[(ys > 0.5)]) == {1.05, 0.75, 0.65}  # centres of image rows 1, 4 and 5 (12 rows of 0.1 m)
    assert {0.1, 0.4} <= set(ys)  # the thick wall's faces, at its top and bottom edges
    # A drawing (`from_image`, `from_raster`) keeps every face; a map_server map reads as surfaces.
    assert len(PlanMap.from_raster(raster)) == raster.boundary_face_count()


def test_a_map_server_map_defaults_to_the_surface_reading(tmp_path: Path) -> None:
    walls = np.zeros((20, 30), dtype=np.uint8) + 254
    walls[5, 2:28] = 0  # a one-cell wall, as SLAM leaves it
    import cv2

    cv2.imwrite(str(tmp_path / "m.pgm"), walls)
    (tmp_path / "m.yaml").write_text(
        "image: m.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    walls[12:15, 2:28] = 0  # a wall three cells thick: every cell a surface point, as beams ended there
    cv2.imwrite(str(tmp_path / "m.pgm"), walls)
    plan = PlanMap.from_ros_map(tmp_path / "m.yaml", cache=False)
    assert len(plan) == 4 * 26
    ys = np.round(plan.points[:, 1], 9)
    assert set(ys) == {0.725, 0.375, 0.325, 0.275}  # on the cells' centre lines
    faces = PlanMap.from_ros_map(tmp_path / "m.yaml", edge_detector="boundary", cache=False)
    assert {0.7, 0.75, 0.25, 0.4} <= set(np.round(faces.points[:, 1], 9))
