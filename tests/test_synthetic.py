"""Tests of the synthetic floors and LIDAR of planicp.sim: floor generation, wall points, pose sampling and
ray casting."""

from __future__ import annotations

import functools
import math
import pickle
import statistics
import time
from typing import Any

import numpy as np
import pytest

from planicp import sim as syn

Floor = syn.Floor
FloorT = Any  # planicp.sim.Floor

LAYOUTS = ("office", "hall", "diagonal")
EXACT = 1e-9  # metres


@functools.cache
def floor_of(layout: str, seed: int = 0) -> FloorT:
    return syn.generate_floor(seed, layout)


# --------------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------------

RES = 0.05
BOX_ORIGIN = (-0.5, -0.5)
BOX_N = 100  # 5 m raster: a 4 x 4 m room [0, 4]^2 with 0.2 m walls, 0.3 m free margin


def box_floor(gap: tuple[float, float] | None = None) -> FloorT:
    """Hand-built 4 x 4 m box room; ``gap`` = (ylo, yhi) cuts a doorway into the wall at x = 4."""
    centres = BOX_ORIGIN[0] + (np.arange(BOX_N) + 0.5) * RES
    x = centres[None, :]
    y = centres[:, None]
    inside_outer = (x > -0.2) & (x < 4.2) & (y > -0.2) & (y < 4.2)
    inside_room = (x > 0.0) & (x < 4.0) & (y > 0.0) & (y < 4.0)
    walls = inside_outer & ~inside_room
    if gap is not None:
        walls &= ~((x > 4.0) & (y > gap[0]) & (y < gap[1]))
    return Floor(walls=walls, clutter=np.zeros_like(walls), resolution=RES, origin=BOX_ORIGIN)


def box_distance(x: float, y: float, angle: float) -> float:
    """Analytic distance from (x, y) inside [0, 4]^2 to the room boundary along ``angle``."""
    dx, dy = math.cos(angle), math.sin(angle)
    ts = []
    for p, d in ((x, dx), (y, dy)):
        if d > 0:
            ts.append((4.0 - p) / d)
        elif d < 0:
            ts.append((0.0 - p) / d)
    return min(ts)


def exact_ranges(floor: FloorT, pose, **kw):
    kw.setdefault("range_sigma", 0.0)
    kw.setdefault("min_range", 0.0)
    return syn.simulate_ranges(floor, pose, np.random.default_rng(0), **kw)


def beam_world_angles(pose, angle_min: float, inc: float, n: int) -> np.ndarray:
    return pose[2] + angle_min + inc * np.arange(n)


def brute_force_ranges(
    floor: FloorT, x: float, y: float, angles: np.ndarray, max_range: float, min_overlap: float = 1e-9
) -> np.ndarray:
    """Reference: slab intersection of each ray with every occupied cell square; a cell counts as hit when
    the ray overlaps it over more than ``min_overlap`` cells (the caster's corner-grazing rule)."""
    rows, cols = np.nonzero(floor.occupied())
    res = floor.resolution
    x0 = floor.origin[0] + cols * res
    y0 = floor.origin[1] + rows * res
    out = np.full(angles.size, np.inf)
    for k, a in enumerate(angles):
        dx, dy = math.cos(a), math.sin(a)
        tx1, tx2 = (x0 - x) / dx, (x0 + res - x) / dx
        ty1, ty2 = (y0 - y) / dy, (y0 + res - y) / dy
        t_in = np.maximum(np.minimum(tx1, tx2), np.minimum(ty1, ty2))
        t_out = np.minimum(np.maximum(tx1, tx2), np.maximum(ty1, ty2))
        t_in = np.maximum(t_in, 0.0)
        t = np.where(t_out - t_in > min_overlap * res, t_in, np.inf).min()
        out[k] = t if t <= max_range else np.inf
    return out


def distance_to_cells(floor: FloorT, mask: np.ndarray, x: float, y: float) -> float:
    """Euclidean distance from (x, y) to the nearest cell square of ``mask``."""
    rows, cols = np.nonzero(mask)
    res = floor.resolution
    cx = floor.origin[0] + (cols + 0.5) * res
    cy = floor.origin[1] + (rows + 0.5) * res
    gx = np.maximum(np.abs(x - cx) - res / 2, 0.0)
    gy = np.maximum(np.abs(y - cy) - res / 2, 0.0)
    return float(np.sqrt(gx * gx + gy * gy).min())


def cell_of(floor: FloorT, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    c = np.floor((x - floor.origin[0]) / floor.resolution).astype(int)
    r = np.floor((y - floor.origin[1]) / floor.resolution).astype(int)
    return r, c


def to_map(points: np.ndarray, pose) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return points @ np.array([[c, s], [-s, c]]) + np.array(pose[:2])


def dominant_wall_angle(points: np.ndarray, res: float) -> float:
    """Orientation (deg, [0, 90)) of the rectilinear wall family that concentrates the wall points most."""
    best, best_score = 0.0, -1.0
    for phi in np.arange(0.0, 90.0, 0.25):
        score = 0.0
        for a in (math.radians(phi), math.radians(phi + 90.0)):
            proj = points @ np.array([math.cos(a), math.sin(a)])
            counts = np.bincount(np.floor((proj - proj.min()) / (2 * res)).astype(int))
            score += float((counts.astype(np.float64) ** 2).sum())
        if score > best_score:
            best, best_score = float(phi), score
    return best


# --------------------------------------------------------------------------------------------------------
# determinism and structure of generated floors
# --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("layout", LAYOUTS)
def test_generation_and_scans_are_deterministic(layout: str) -> None:
    a = syn.generate_floor(11, layout)
    b = syn.generate_floor(11, layout)
    c = syn.generate_floor(12, layout)
    assert np.array_equal(a.walls, b.walls) and np.array_equal(a.clutter, b.clutter)
    assert a.origin == b.origin and a.resolution == b.resolution
    assert not np.array_equal(a.walls, c.walls)
    assert not np.array_equal(a.clutter, c.clutter)

    pose_a = a.sample_pose(np.random.default_rng(5))
    pose_b = b.sample_pose(np.random.default_rng(5))
    assert pose_a == pose_b
    ra = syn.simulate_ranges(a, pose_a, np.random.default_rng(6), dropout=0.1)
    rb = syn.simulate_ranges(b, pose_b, np.random.default_rng(6), dropout=0.1)
    rc = syn.simulate_ranges(a, pose_a, np.random.default_rng(7), dropout=0.1)
    assert np.array_equal(ra[0], rb[0]) and ra[1:] == rb[1:]
    assert not np.array_equal(ra[0], rc[0])
    pa, ca = syn.simulate_scan(a, pose_a, np.random.default_rng(6))
    pb, cb = syn.simulate_scan(b, pose_b, np.random.default_rng(6))
    assert np.array_equal(pa, pb) and np.array_equal(ca, cb)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_generated_floor_structure(layout: str) -> None:
    f = floor_of(layout)
    rows, cols = f.shape
    assert f.walls.dtype == np.bool_ and f.clutter.dtype == np.bool_
    assert f.resolution == 0.05
    # the building occupies [0, 40] x [0, 25] m plus a free margin of >= 1 m
    xmin, ymin, xmax, ymax = f.extent
    assert xmin <= -1.0 and ymin <= -1.0 and xmax >= 41.0 and ymax >= 26.0
    assert math.isclose(xmax - xmin, cols * f.resolution) and math.isclose(ymax - ymin, rows * f.resolution)
    occ = f.occupied()
    r, c = np.nonzero(occ)
    x = f.origin[0] + (c + 0.5) * f.resolution
    y = f.origin[1] + (r + 0.5) * f.resolution
    assert x.min() > 0.0 and y.min() > 0.0 and x.max() < 40.0 and y.max() < 25.0
    assert x.min() - f.resolution / 2 - xmin >= 1.0 - 1e-9
    assert not (f.walls & f.clutter).any()
    assert 0.01 < f.walls.mean() < 0.15
    assert 0.005 < f.clutter.mean() < 0.15
    assert not f.walls.flags.writeable and not f.clutter.flags.writeable
    with pytest.raises(ValueError):
        f.walls[0, 0] = True
    g = pickle.loads(pickle.dumps(f))
    assert np.array_equal(g.walls, f.walls) and np.array_equal(g.clutter, f.clutter)
    assert (g.resolution, g.origin) == (f.resolution, f.origin) and not g.walls.flags.writeable


@pytest.mark.parametrize(
    ("layout", "kwargs"),
    [
        ("office", {}),
        ("hall", {}),
        ("diagonal", {}),
        ("office", {"rooms": 1, "width": 5.0, "height": 7.0, "resolution": 0.1}),
        ("office", {"rooms": 3, "width": 14.0, "height": 10.0, "resolution": 0.25}),
        ("hall", {"rooms": 2, "width": 8.0, "height": 7.0, "resolution": 0.1}),
        ("diagonal", {"rooms": 4, "width": 22.0, "height": 20.0, "resolution": 0.2, "furniture_per_room": 0}),
    ],
)
def test_building_is_closed(layout: str, kwargs: dict) -> None:
    """From inside, every beam hits something: no exterior doors and no leaks through rasterised walls."""
    f = syn.generate_floor(3, layout, **kwargs)
    rng = np.random.default_rng(1)
    for _ in range(4):
        pose = f.sample_pose(rng, clearance=0.3)
        ranges, _, _ = syn.simulate_ranges(f, pose, rng, beams=1500, max_range=200.0, range_sigma=0.0)
        assert np.isfinite(ranges).all()
    if kwargs.get("furniture_per_room") == 0:
        assert not f.clutter.any()


def test_office_minimum_size_and_too_small() -> None:
    floor = syn.generate_floor(0, "office", rooms=1, width=4.5, height=6.15)
    assert floor.walls.any()
    with pytest.raises(ValueError, match="needs width"):
        syn.generate_floor(0, "office", rooms=1, width=4.4, height=6.15)


# --------------------------------------------------------------------------------------------------------
# wall points and image
# --------------------------------------------------------------------------------------------------------


def test_wall_points_tiny_example() -> None:
    walls = np.zeros((3, 4), dtype=bool)
    walls[1, 2] = True
    walls[1, 3] = True  # touches the raster border on its +x side
    clutter = np.zeros_like(walls)
    clutter[1, 1] = True  # clutter next to a wall does not hide the face (it is not in the plan)
    f = Floor(walls=walls, clutter=clutter, resolution=0.5, origin=(10.0, -2.0))
    got = {tuple(p) for p in f.wall_points().tolist()}
    # cells (1, 2) and (1, 3) cover x in [11, 11.5) and [11.5, 12), y in [-1.5, -1); x = 12 is the border
    expected = {
        (12.0, -1.25), (11.0, -1.25),  # +x face of (1, 3), -x face of (1, 2)
        (11.25, -1.0), (11.75, -1.0), (11.25, -1.5), (11.75, -1.5),  # +y / -y faces
    }  # fmt: skip
    assert got == expected
    assert f.wall_points().shape == (6, 2) and f.wall_points().dtype == np.float64


@pytest.mark.parametrize("layout", ["office", "diagonal"])
def test_wall_points_lie_between_wall_and_free_cells(layout: str) -> None:
    f = floor_of(layout)
    pts = f.wall_points()
    assert np.array_equal(pts, f.wall_points())  # deterministic
    u = (pts[:, 0] - f.origin[0]) / f.resolution
    v = (pts[:, 1] - f.origin[1]) / f.resolution
    on_vertical = np.abs(u - np.round(u)) * f.resolution < EXACT
    on_horizontal = np.abs(v - np.round(v)) * f.resolution < EXACT
    assert (on_vertical ^ on_horizontal).all()  # on exactly one kind of grid line ...
    half_u = np.abs(u - np.floor(u) - 0.5) * f.resolution < EXACT
    half_v = np.abs(v - np.floor(v) - 0.5) * f.resolution < EXACT
    assert (on_vertical <= half_v).all() and (on_horizontal <= half_u).all()  # ... at a face midpoint
    # cells on both sides: exactly one is a wall, the other free
    r1 = np.where(on_vertical, np.floor(v), np.round(v) - 1).astype(int)
    c1 = np.where(on_vertical, np.round(u) - 1, np.floor(u)).astype(int)
    r2 = np.where(on_vertical, r1, r1 + 1)
    c2 = np.where(on_vertical, c1 + 1, c1)
    w1, w2 = f.walls[r1, c1], f.walls[r2, c2]
    assert (w1 ^ w2).all()
    # one point per wall/free face: count faces independently
    w = f.walls.astype(np.int8)
    faces = np.abs(np.diff(w, axis=0)).sum() + np.abs(np.diff(w, axis=1)).sum()
    assert len(pts) == faces == len(np.unique(pts, axis=0))
    # clutter never produces points
    all_clutter = Floor(walls=f.walls, clutter=~f.walls, resolution=f.resolution, origin=f.origin)
    assert np.array_equal(all_clutter.wall_points(), pts)
    no_walls = Floor(walls=np.zeros_like(f.walls), clutter=f.clutter, resolution=f.resolution, origin=f.origin)
    assert no_walls.wall_points().shape == (0, 2)


def test_to_image_orientation() -> None:
    walls = np.zeros((4, 5), dtype=bool)
    walls[0, 1] = True  # lowest y
    walls[3, 4] = True  # highest y
    clutter = np.zeros_like(walls)
    clutter[2, 2] = True
    img = Floor(walls=walls, clutter=clutter, resolution=0.1, origin=(0.0, 0.0)).to_image()
    assert img.dtype == np.uint8 and img.shape == (4, 5)
    assert img[-1, 1] == 0 and img[0, 4] == 0  # row 0 (lowest y) is the image's LAST row
    assert (img == 0).sum() == 2 and (img == 255).sum() == 18  # clutter not drawn
    office = floor_of("office").to_image()
    assert np.array_equal(office == 0, floor_of("office").walls[::-1])


# --------------------------------------------------------------------------------------------------------
# exact ray casting on a hand-built floor
# --------------------------------------------------------------------------------------------------------


def test_box_ranges_match_analytic_distances() -> None:
    f = box_floor()
    pose = (1.31, 1.72, 0.0)
    ranges, amin, inc = exact_ranges(f, pose, beams=8)
    assert amin == -math.pi and inc == 2 * math.pi / 8
    # beam 4 is exactly along +x; beams 1, 3, 5, 7 are diagonal; 2 and 6 are (numerically) along -y / +y
    assert ranges[4] == pytest.approx(4.0 - 1.31, abs=EXACT)
    assert ranges[0] == pytest.approx(1.31, abs=EXACT)
    assert ranges[2] == pytest.approx(1.72, abs=EXACT)
    assert ranges[6] == pytest.approx(4.0 - 1.72, abs=EXACT)
    assert ranges[5] == pytest.approx(math.sqrt(2) * (4.0 - 1.72), abs=EXACT)
    assert ranges[3] == pytest.approx(math.sqrt(2) * 1.72, abs=EXACT)
    for i in range(8):
        expected = box_distance(pose[0], pose[1], beam_world_angles(pose, amin, inc, 8)[i])
        assert abs(ranges[i] - expected) < EXACT


def test_box_diagonal_through_grid_corners() -> None:
    """From a cell centre at 45 deg the ray passes exactly through cell corners at every step."""
    f = box_floor()
    pose = (1.025, 0.525, math.pi / 4)
    ranges, amin, inc = exact_ranges(f, pose, beams=3, fov=0.2)
    assert amin == pytest.approx(-0.1) and inc == pytest.approx(0.1)
    angles = beam_world_angles(pose, amin, inc, 3)
    assert angles[1] == math.pi / 4
    for i in range(3):
        assert abs(ranges[i] - box_distance(pose[0], pose[1], angles[i])) < EXACT
    assert ranges[1] == pytest.approx(math.sqrt(2) * (4.0 - 1.025), abs=EXACT)


def test_box_ranges_random_poses_property() -> None:
    f = box_floor()
    rng = np.random.default_rng(42)
    worst = 0.0
    for _ in range(40):
        pose = (rng.uniform(0.05, 3.95), rng.uniform(0.05, 3.95), rng.uniform(-math.pi, math.pi))
        ranges, amin, inc = exact_ranges(f, pose, beams=360)
        angles = beam_world_angles(pose, amin, inc, 360)
        expected = np.array([box_distance(pose[0], pose[1], a) for a in angles])
        worst = max(worst, float(np.abs(ranges - expected).max()))
    assert worst < EXACT


def test_gap_gives_inf_and_dynamic_disc_occludes() -> None:
    f = box_floor(gap=(1.5, 2.5))
    pose = (1.3, 2.0, 0.0)
    ranges, _, _ = exact_ranges(f, pose, beams=4)  # beams at -pi, -pi/2, 0, pi/2
    assert ranges[2] == np.inf  # leaves through the doorway and the raster
    assert ranges[0] == pytest.approx(1.3, abs=EXACT)
    # a beam aimed just above the gap hits the wall face at x = 4
    up = math.atan2(2.6 - 2.0, 4.0 - 1.3)
    r_up, _, _ = exact_ranges(f, (1.3, 2.0, up), beams=4)
    assert r_up[2] == pytest.approx(math.hypot(2.7, 0.6), abs=EXACT)

    disc = np.array([[3.0, 2.1, 0.3]])
    r_disc, _, _ = exact_ranges(f, pose, beams=4, dynamic_discs=disc)
    assert r_disc[2] == pytest.approx(1.7 - math.sqrt(0.3**2 - 0.1**2), abs=EXACT)
    assert r_disc[0] == ranges[0]  # other beams unaffected
    # a disc behind the wall does not matter; an empty (0, 3) array is accepted
    r_far, _, _ = exact_ranges(box_floor(), pose, beams=4, dynamic_discs=np.array([[4.6, 2.0, 0.2]]))
    assert r_far[2] == pytest.approx(2.7, abs=EXACT)
    r_none, _, _ = exact_ranges(f, pose, beams=4, dynamic_discs=np.zeros((0, 3)))
    assert np.array_equal(r_none, ranges)
    # sensor inside a disc: range 0, reported as "too close" (-inf) per REP-117
    r_in, _, _ = exact_ranges(f, pose, beams=4, min_range=0.1, dynamic_discs=np.array([[1.3, 2.0, 0.5]]))
    assert (r_in == -np.inf).all()
    points, is_clutter = syn.simulate_scan(
        f, pose, np.random.default_rng(0), beams=4, range_sigma=0.0, dynamic_discs=disc
    )
    assert points.shape == (4, 2) and is_clutter.tolist() == [False, False, True, False]


def test_range_limits_noise_and_dropout() -> None:
    f = box_floor()
    pose = (0.06, 2.0, 0.0)
    r, _, _ = exact_ranges(f, pose, beams=4, min_range=0.1, max_range=3.0)
    assert r[0] == -np.inf  # 0.06 m to the wall at x = 0: too close
    assert r[2] == np.inf  # 3.94 m > max_range
    assert r[1] == pytest.approx(2.0, abs=EXACT) and r[3] == pytest.approx(2.0, abs=EXACT)

    pose = (2.0, 2.0, 0.3)
    clean, _, _ = exact_ranges(f, pose, beams=2000)
    noisy, _, _ = syn.simulate_ranges(f, pose, np.random.default_rng(3), beams=2000, range_sigma=0.02)
    err = noisy - clean
    assert abs(err.mean()) < 0.002 and 0.018 < err.std() < 0.022
    dropped, _, _ = syn.simulate_ranges(f, pose, np.random.default_rng(3), beams=2000, dropout=0.3)
    assert 0.25 < np.isinf(dropped).mean() < 0.35
    all_dropped, _, _ = syn.simulate_ranges(f, pose, np.random.default_rng(3), beams=50, dropout=1.0)
    assert np.isposinf(all_dropped).all()


def test_beam_geometry() -> None:
    f = box_floor()
    r, amin, inc = exact_ranges(f, (2.0, 2.0, 0.0), beams=1080)
    assert r.shape == (1080,) and r.dtype == np.float64
    assert amin == -math.pi and inc == pytest.approx(2 * math.pi / 1080)
    assert amin + 1079 * inc < math.pi - inc / 2  # last beam does not duplicate the first
    r, amin, inc = exact_ranges(f, (2.0, 2.0, 0.0), beams=5, fov=math.pi)
    assert amin == -math.pi / 2 and inc == math.pi / 4
    assert amin + 4 * inc == pytest.approx(math.pi / 2)
    assert r == pytest.approx([2.0, 2.0 * math.sqrt(2), 2.0, 2.0 * math.sqrt(2), 2.0], abs=EXACT)


@pytest.mark.parametrize("layout", LAYOUTS)
def test_generated_floor_ranges_match_brute_force(layout: str) -> None:
    f = floor_of(layout)
    rng = np.random.default_rng(9)
    for _ in range(2):
        pose = f.sample_pose(rng, clearance=0.2)
        ranges, amin, inc = exact_ranges(f, pose, beams=61)
        ref = brute_force_ranges(f, pose[0], pose[1], beam_world_angles(pose, amin, inc, 61), 30.0)
        assert np.array_equal(np.isinf(ranges), np.isinf(ref))
        finite = np.isfinite(ref)
        assert finite.sum() > 50
        assert np.abs(ranges[finite] - ref[finite]).max() < EXACT


def test_grid_aligned_rays_match_brute_force() -> None:
    """Adversarial geometry: sensors on cell centres, edges and corners, rational slopes (exact or near
    corner crossings at every few cells) through random single-cell clutter."""
    rng = np.random.default_rng(0)
    walls = np.zeros((120, 120), dtype=bool)
    walls[:3] = walls[-3:] = True
    walls[:, :3] = walls[:, -3:] = True
    clutter = (rng.random(walls.shape) < 0.04) & ~walls
    clutter[55:65, 55:65] = False
    f = Floor(walls=walls, clutter=clutter, resolution=RES, origin=(-1.0, -2.0))
    angles = sorted({math.atan2(p, q) for p in range(-4, 5) for q in range(-4, 5) if p and q})
    for cx, cy in [(60.5, 60.5), (60.0, 60.0), (60.5, 60.0), (60.25, 60.75)]:
        x, y = -1.0 + cx * RES, -2.0 + cy * RES
        # beams=2 over the full circle: beam 1 is at yaw + (-pi + pi) = yaw exactly
        got = np.array([exact_ranges(f, (x, y, a), beams=2)[0][1] for a in angles])
        ref = brute_force_ranges(f, x, y, np.array(angles), 30.0)
        assert np.isfinite(ref).all()
        assert np.abs(got - ref).max() < EXACT


# --------------------------------------------------------------------------------------------------------
# clutter
# --------------------------------------------------------------------------------------------------------


def test_clutter_fraction_and_labels_in_default_office() -> None:
    f = floor_of("office")
    rng = np.random.default_rng(2024)
    total = clutter = 0
    for _ in range(20):
        pose = f.sample_pose(rng)
        points, is_clutter = syn.simulate_scan(f, pose, rng, range_sigma=0.0)
        assert points.shape == (is_clutter.size, 2) and is_clutter.dtype == np.bool_
        total += is_clutter.size
        clutter += int(is_clutter.sum())
        # step 1 um beyond each return along its beam: that cell is what the ray hit
        world = to_map(points, pose)
        direction = world - np.array(pose[:2])
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        inner = world + 1e-6 * direction
        r, c = cell_of(f, inner[:, 0], inner[:, 1])
        assert f.occupied()[r, c].all()
        assert np.array_equal(is_clutter, ~f.walls[r, c])
    fraction = clutter / total
    print(f"\nclutter fraction of returns in the default office floor: {fraction:.3f} ({clutter}/{total})")
    assert 0.10 <= fraction <= 0.40


def test_clutter_is_invisible_to_plan_but_occludes() -> None:
    f = box_floor()
    clutter = np.zeros_like(f.walls)
    clutter[48:52, 60:64] = True  # x in [2.5, 2.7), y in [1.9, 2.1)
    g = Floor(walls=f.walls, clutter=clutter, resolution=f.resolution, origin=f.origin)
    assert np.array_equal(g.wall_points(), f.wall_points())
    assert np.array_equal(g.to_image(), f.to_image())
    r, _, _ = exact_ranges(g, (1.31, 2.0, 0.0), beams=4)
    assert r[2] == pytest.approx(2.5 - 1.31, abs=EXACT)
    _, is_clutter = syn.simulate_scan(g, (1.31, 2.0, 0.0), np.random.default_rng(0), beams=4, range_sigma=0.0)
    assert is_clutter.tolist() == [False, False, True, False]


# --------------------------------------------------------------------------------------------------------
# pose sampling
# --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(("layout", "clearance"), [("office", 0.5), ("hall", 0.3), ("diagonal", 0.8)])
def test_sample_pose_respects_clearance(layout: str, clearance: float) -> None:
    f = floor_of(layout)
    rng = np.random.default_rng(17)
    occ = f.occupied()
    for _ in range(15):
        x, y, yaw = f.sample_pose(rng, clearance=clearance)
        assert -math.pi <= yaw < math.pi
        assert 0.0 < x < 40.0 and 0.0 < y < 25.0
        assert distance_to_cells(f, occ, x, y) >= clearance - 1e-9


def test_sample_pose_picks_largest_enclosed_region() -> None:
    walls = np.zeros((40, 60), dtype=bool)
    walls[5, 5:56] = walls[35, 5:56] = True
    walls[5:36, 5] = walls[5:36, 55] = walls[5:36, 20] = True  # rooms: cols 6-19 (small), 21-54 (large)
    f = Floor(walls=walls, clutter=np.zeros_like(walls), resolution=0.1, origin=(0.0, 0.0))
    rng = np.random.default_rng(0)
    xs = [f.sample_pose(rng, clearance=0.0)[0] for _ in range(200)]
    assert min(xs) >= 2.1 and max(xs) <= 5.5


def test_sample_pose_errors() -> None:
    rng = np.random.default_rng(0)
    full = np.ones((20, 20), dtype=bool)
    with pytest.raises(ValueError, match="no free cell"):
        Floor(walls=full, clutter=np.zeros_like(full), resolution=0.1, origin=(0.0, 0.0)).sample_pose(rng)
    with pytest.raises(ValueError, match="no free cell"):  # free space exists but only outside (no building)
        Floor(walls=~full, clutter=~full, resolution=0.1, origin=(0.0, 0.0)).sample_pose(rng)
    with pytest.raises(ValueError, match="no free cell"):
        box_floor().sample_pose(rng, clearance=2.5)  # the 4 m room has at most 2 m clearance
    assert box_floor().sample_pose(rng, clearance=1.9)[0] == pytest.approx(2.0, abs=0.11)
    with pytest.raises(ValueError, match="clearance"):
        box_floor().sample_pose(rng, clearance=-0.1)


# --------------------------------------------------------------------------------------------------------
# diagonal layout
# --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_diagonal_layout_has_non_axis_aligned_walls(seed: int) -> None:
    diag = floor_of("diagonal", seed)
    angle = dominant_wall_angle(diag.wall_points(), diag.resolution)
    assert min(angle, 90.0 - angle) >= 10.0  # building rotated by 15-40 deg
    # the literal check: local principal directions of wall points are mostly far from 0/90 deg
    pts = diag.wall_points()
    sample = pts[np.random.default_rng(seed).choice(len(pts), 150, replace=False)]
    off_axis = 0
    for p in sample:
        nb = pts[np.linalg.norm(pts - p, axis=1) < 0.6]
        _, vecs = np.linalg.eigh(np.cov((nb - nb.mean(axis=0)).T))
        a = math.degrees(math.atan2(vecs[1, 1], vecs[0, 1])) % 90.0
        off_axis += min(a, 90.0 - a) > 2.0
    assert off_axis / len(sample) > 0.6
    if seed == 0:
        office = floor_of("office")
        assert dominant_wall_angle(office.wall_points(), office.resolution) == 0.0


# --------------------------------------------------------------------------------------------------------
# helpers: ranges_to_points, perturb_pose
# --------------------------------------------------------------------------------------------------------


def test_ranges_to_points() -> None:
    ranges = np.array([1.0, np.inf, 2.0, -np.inf, np.nan, 0.05, 1.5])
    pts = syn.ranges_to_points(ranges, 0.0, math.pi / 2, range_min=0.1, range_max=1.5)
    assert pts.shape == (2, 2) and pts.dtype == np.float64
    assert pts[0] == pytest.approx([1.0, 0.0])
    assert pts[1] == pytest.approx([1.5 * math.cos(3 * math.pi), 1.5 * math.sin(3 * math.pi)])
    assert syn.ranges_to_points(np.full(4, np.inf), 0.0, 0.1).shape == (0, 2)
    with pytest.raises(ValueError, match="one-dimensional"):
        syn.ranges_to_points(np.ones((2, 2)), 0.0, 0.1)
    with pytest.raises(ValueError, match="range_min < range_max"):
        syn.ranges_to_points(np.ones(3), 0.0, 0.1, range_min=2.0, range_max=1.0)


def test_scan_points_roundtrip_to_ranges() -> None:
    f = floor_of("office")
    pose = f.sample_pose(np.random.default_rng(4))
    ranges, amin, inc = syn.simulate_ranges(f, pose, np.random.default_rng(8), min_range=0.0)
    points, _ = syn.simulate_scan(f, pose, np.random.default_rng(8), min_range=0.0)
    finite = np.isfinite(ranges)
    assert np.allclose(np.linalg.norm(points, axis=1), ranges[finite], atol=1e-12)
    angles = amin + inc * np.flatnonzero(finite)
    assert np.allclose(np.arctan2(points[:, 1], points[:, 0]), np.arctan2(np.sin(angles), np.cos(angles)))


def test_perturb_pose() -> None:
    rng = np.random.default_rng(0)
    signs, directions = set(), []
    for _ in range(60):
        pose = (rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-math.pi, math.pi))
        x, y, yaw = syn.perturb_pose(pose, rng, 0.2, math.radians(3.0))
        assert math.hypot(x - pose[0], y - pose[1]) == pytest.approx(0.2, abs=1e-12)
        dyaw = (yaw - pose[2] + math.pi) % (2 * math.pi) - math.pi
        assert abs(dyaw) == pytest.approx(math.radians(3.0), abs=1e-12)
        assert -math.pi <= yaw < math.pi
        signs.add(dyaw > 0)
        directions.append(math.atan2(y - pose[1], x - pose[0]))
    assert signs == {True, False}
    assert np.ptp(directions) > math.pi
    assert syn.perturb_pose((1.0, 2.0, 0.5), rng, 0.0, 0.0) == (1.0, 2.0, 0.5)
    with pytest.raises(ValueError, match="translation and rotation"):
        syn.perturb_pose((0.0, 0.0, 0.0), rng, -0.1, 0.0)


# --------------------------------------------------------------------------------------------------------
# argument validation
# --------------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"layout": "castle"}, "unknown layout"),
        ({"width": 0.0}, "width and height must be > 0"),
        ({"height": -3.0}, "width and height must be > 0"),
        ({"width": float("nan")}, "width must be finite"),
        ({"resolution": 0.0}, "resolution must be > 0"),
        ({"resolution": -0.05}, "resolution must be > 0"),
        ({"resolution": 0.5}, "too coarse"),
        ({"rooms": 0}, "rooms must be >= 1"),
        ({"rooms": 2.5}, "rooms must be an integer"),
        ({"furniture_per_room": -1}, "furniture_per_room must be >= 0"),
        ({"seed": -1}, "seed must be a non-negative integer"),
        ({"seed": 1.5}, "seed must be a non-negative integer"),
        ({"rooms": 10, "width": 15.0}, "office floor with 10 rooms needs width"),
        ({"rooms": 10, "height": 8.0}, "office floor with 10 rooms needs width"),
        ({"layout": "hall", "rooms": 100}, "hall with 100 rooms"),
        ({"layout": "hall", "width": 6.0}, "hall with 10 rooms"),
        ({"layout": "diagonal", "width": 20.0, "height": 15.0}, "diagonal floor with 10 rooms"),
        ({"resolution": 0.001}, "too large"),
    ],
)
def test_generate_floor_errors(kwargs: dict, message: str) -> None:
    kwargs = {"seed": 0, **kwargs}
    seed = kwargs.pop("seed")
    with pytest.raises(ValueError, match=message):
        syn.generate_floor(seed, **kwargs)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"beams": 1}, "beams must be >= 2"),
        ({"beams": 0}, "beams must be >= 2"),
        ({"beams": 10.5}, "beams must be an integer"),
        ({"fov": 0.0}, "fov must be in"),
        ({"fov": -1.0}, "fov must be in"),
        ({"fov": 7.0}, "fov must be in"),
        ({"fov": float("inf")}, "fov must be finite"),
        ({"max_range": 0.1, "min_range": 0.1}, "max_range .* must be > min_range"),
        ({"max_range": 0.05}, "max_range .* must be > min_range"),
        ({"min_range": -0.1}, "min_range must be >= 0"),
        ({"max_range": float("inf")}, "max_range must be finite"),
        ({"range_sigma": -0.01}, "range_sigma must be >= 0"),
        ({"dropout": -0.1}, "dropout must be a probability"),
        ({"dropout": 1.1}, "dropout must be a probability"),
        ({"dynamic_discs": np.array([1.0, 2.0, 0.3])}, r"dynamic_discs must have shape \(K, 3\)"),
        ({"dynamic_discs": np.ones((2, 2))}, r"dynamic_discs must have shape \(K, 3\)"),
        ({"dynamic_discs": np.array([[1.0, 2.0, 0.0]])}, "radius > 0"),
        ({"dynamic_discs": np.array([[1.0, np.nan, 0.2]])}, "finite"),
    ],
)
def test_simulate_ranges_errors(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        syn.simulate_ranges(box_floor(), (2.0, 2.0, 0.0), np.random.default_rng(0), **kwargs)
    with pytest.raises(ValueError, match=message):
        syn.simulate_scan(box_floor(), (2.0, 2.0, 0.0), np.random.default_rng(0), **kwargs)


def test_pose_and_floor_errors() -> None:
    f = box_floor()
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="outside the floor extent"):
        syn.simulate_ranges(f, (4.6, 2.0, 0.0), rng)
    with pytest.raises(ValueError, match="three finite floats"):
        syn.simulate_ranges(f, (2.0, float("nan"), 0.0), rng)
    with pytest.raises(ValueError, match="three finite floats"):
        syn.simulate_ranges(f, (2.0, 2.0), rng)
    walls = np.zeros((3, 3), dtype=bool)
    with pytest.raises(ValueError, match="same shape"):
        Floor(walls=walls, clutter=np.zeros((3, 4), dtype=bool), resolution=0.1, origin=(0.0, 0.0))
    with pytest.raises(ValueError, match="boolean"):
        Floor(walls=walls.astype(np.uint8), clutter=walls, resolution=0.1, origin=(0.0, 0.0))
    with pytest.raises(ValueError, match="2-D"):
        Floor(walls=np.zeros(3, dtype=bool), clutter=np.zeros(3, dtype=bool), resolution=0.1, origin=(0.0, 0.0))
    with pytest.raises(ValueError, match="resolution must be > 0"):
        Floor(walls=walls, clutter=walls, resolution=0.0, origin=(0.0, 0.0))
    with pytest.raises(ValueError, match="origin"):
        Floor(walls=walls, clutter=walls, resolution=0.1, origin=(0.0,))


# --------------------------------------------------------------------------------------------------------
# speed
# --------------------------------------------------------------------------------------------------------


def test_simulate_ranges_speed() -> None:
    """1080 beams, 30 m, default 40 x 25 m office at 5 cm: the median must stay well under 30 ms."""
    f = floor_of("office")
    rng = np.random.default_rng(1)
    poses = [f.sample_pose(rng) for _ in range(25)]
    syn.simulate_ranges(f, poses[0], rng)  # warm the per-floor caches
    times = []
    for pose in poses:
        t0 = time.perf_counter()
        syn.simulate_ranges(f, pose, rng, beams=1080, max_range=30.0)
        times.append(time.perf_counter() - t0)
    median_ms = statistics.median(times) * 1e3
    print(f"\nsimulate_ranges office 1080 beams: median {median_ms:.1f} ms, max {max(times) * 1e3:.1f} ms")
    assert median_ms < 30.0


def test_beam_along_an_axis_from_the_raster_edge() -> None:
    """A sensor exactly on the raster's bottom edge with a beam along +-x must still hit the wall
    (0 * inf in the exit time once turned such beams into misses)."""
    walls = np.zeros((20, 20), dtype=bool)
    walls[:, 10] = True
    floor = syn.Floor(walls, np.zeros_like(walls), 0.1, (0.0, 0.0))
    ranges, _, _ = syn.simulate_ranges(
        floor, (0.25, 0.0, math.pi), np.random.default_rng(0), beams=2, fov=2 * math.pi, range_sigma=0.0, min_range=0.0
    )
    assert ranges[0] == pytest.approx(0.75, abs=1e-12)
