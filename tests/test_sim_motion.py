"""Tests of planicp.sim: differential-drive kinematics, routes, the waypoint follower, odometry and drives."""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

from planicp import se2
from planicp import sim as synthetic
from planicp.sim import (
    DiffDriveLimits,
    DiffDriveState,
    ErrorGenerator,
    Odometry,
    OdometryNoise,
    Trajectory,
    WaypointFollower,
    arc_increment,
    clearance_distance,
    plan_route,
    reachable,
    simulate_drive,
    step,
    tour,
    traversable,
)

LIMITS = DiffDriveLimits()
EXACT = 1e-9


@functools.cache
def office() -> synthetic.Floor:
    return synthetic.generate_floor(0, "office")


@functools.cache
def office_drive() -> Trajectory:
    return simulate_drive(office(), np.random.default_rng(0), 60.0, LIMITS)


def distance_to_occupied(floor: synthetic.Floor, xy: NDArray[np.float64], reach: float = 1.0) -> NDArray[np.float64]:
    """Exact Euclidean distance (metres) from each point to the nearest wall/clutter cell SQUARE, capped at
    about ``reach`` (inf when nothing occupied is within the window)."""
    occ = floor.occupied()
    res = floor.resolution
    ox, oy = floor.origin
    xy = np.asarray(xy, dtype=np.float64)
    col = np.floor((xy[:, 0] - ox) / res).astype(np.int64)
    row = np.floor((xy[:, 1] - oy) / res).astype(np.int64)
    k = math.ceil(reach / res) + 1
    out = np.full(len(xy), np.inf)
    for dr in range(-k, k + 1):
        for dc in range(-k, k + 1):
            r, c = row + dr, col + dc
            inside = (r >= 0) & (r < occ.shape[0]) & (c >= 0) & (c < occ.shape[1])
            hit = np.zeros(len(xy), dtype=np.bool_)
            hit[inside] = occ[r[inside], c[inside]]
            x0, y0 = ox + c * res, oy + r * res
            gx = np.maximum(np.maximum(x0 - xy[:, 0], xy[:, 0] - (x0 + res)), 0.0)
            gy = np.maximum(np.maximum(y0 - xy[:, 1], xy[:, 1] - (y0 + res)), 0.0)
            out = np.where(hit, np.minimum(out, np.hypot(gx, gy)), out)
    return out


def densify(route: list[tuple[float, float]], spacing: float = 0.005) -> NDArray[np.float64]:
    """Points every ``spacing`` metres along the polyline (both ends of every segment included)."""
    pts = [np.array(route[0], dtype=np.float64)[None, :]]
    for a, b in zip(route[:-1], route[1:]):
        n = max(2, math.ceil(math.dist(a, b) / spacing) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        pts.append(np.asarray(a) + t * (np.asarray(b) - np.asarray(a)))
    return np.vstack(pts)


def room_floor(door: tuple[float, float] | None) -> synthetic.Floor:
    """Hand-made 8 x 4 m building ([0, 8] x [0, 4], 0.2 m walls) split at x = 4 by a 0.2 m wall; ``door`` =
    (ylo, yhi) cuts a doorway into it. 5 cm cells, origin (-0.5, -0.5)."""
    res = 0.05
    cols, rows = 180, 100
    x = -0.5 + (np.arange(cols) + 0.5) * res
    y = -0.5 + (np.arange(rows) + 0.5) * res
    xx, yy = np.meshgrid(x, y)  # rows grow with y
    shell = (xx > -0.2) & (xx < 8.2) & (yy > -0.2) & (yy < 4.2)
    inner = (xx > 0.0) & (xx < 8.0) & (yy > 0.0) & (yy < 4.0)
    walls = shell & ~inner
    divider = (xx > 3.9) & (xx < 4.1) & inner
    if door is not None:
        divider &= ~((yy > door[0]) & (yy < door[1]))
    walls |= divider
    return synthetic.Floor(walls=walls, clutter=np.zeros_like(walls), resolution=res, origin=(-0.5, -0.5))


def lateral_deviation(points: NDArray[np.float64], route: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (metres) of each point to the polyline ``route``."""
    a, b = route[:-1][None], route[1:][None]
    ab = b - a
    ap = points[:, None, :] - a
    t = np.clip((ap * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0.0, 1.0)
    closest = a + t[..., None] * ab
    out: NDArray[np.float64] = np.linalg.norm(points[:, None, :] - closest, axis=-1).min(axis=1)
    return out


# --------------------------------------------------------------------------------------------------------
# differential drive
# --------------------------------------------------------------------------------------------------------


def test_step_is_the_exact_arc() -> None:
    x, y, yaw, v, w = 1.0, 2.0, 0.3, 0.4, 0.8
    state = DiffDriveState(x, y, yaw, v, w)  # already at the commanded speeds: no acceleration clamping
    out = step(state, v, w, 0.5, LIMITS)
    yaw1 = yaw + w * 0.5
    assert out.x == pytest.approx(x + v / w * (math.sin(yaw1) - math.sin(yaw)), abs=1e-12)
    assert out.y == pytest.approx(y - v / w * (math.cos(yaw1) - math.cos(yaw)), abs=1e-12)
    assert out.yaw == pytest.approx(yaw1, abs=1e-12)
    assert (out.v, out.w) == (v, w)

    # 100 steps of 10 ms on the same circle land exactly where one closed-form second does
    s = state
    for _ in range(100):
        s = step(s, v, w, 0.01, LIMITS)
    yaw1 = yaw + w
    assert s.x == pytest.approx(x + v / w * (math.sin(yaw1) - math.sin(yaw)), abs=1e-12)
    assert s.y == pytest.approx(y - v / w * (math.cos(yaw1) - math.cos(yaw)), abs=1e-12)
    assert s.yaw == pytest.approx(yaw1, abs=1e-12)

    # straight line, and the small-angle series joins the exact formula continuously
    straight = step(DiffDriveState(0.0, 0.0, 1.0, 0.5, 0.0), 0.5, 0.0, 0.2, LIMITS)
    assert (straight.x, straight.y) == pytest.approx((0.1 * math.cos(1.0), 0.1 * math.sin(1.0)), abs=1e-15)
    for angle in (1e-4 * (1 - 1e-9), 1e-4 * (1 + 1e-9), 1e-6):
        fx, fy, _ = arc_increment(2.0, angle)
        assert fx == pytest.approx(2.0 * math.sin(angle) / angle, rel=1e-14)
        assert fy == pytest.approx(2.0 * 2.0 * math.sin(0.5 * angle) ** 2 / angle, rel=1e-14)  # (1-cos a)/a
    # wraps the yaw to (-pi, pi]
    assert step(DiffDriveState(0.0, 0.0, 3.1, 0.0, 1.0), 0.0, 1.0, 0.1, LIMITS).yaw == pytest.approx(3.2 - 2 * math.pi)


def test_step_clamps_speed_and_acceleration() -> None:
    dt = 0.1
    s = DiffDriveState(0.0, 0.0, 0.0)
    s = step(s, 10.0, -10.0, dt, LIMITS)
    assert s.v == pytest.approx(LIMITS.max_linear_accel * dt)  # 0.05 m/s after 0.1 s from rest
    assert s.w == pytest.approx(-LIMITS.max_angular_accel * dt)  # -0.2 rad/s
    for _ in range(30):
        s = step(s, 10.0, -10.0, dt, LIMITS)
    assert (s.v, s.w) == (LIMITS.max_linear_speed, -LIMITS.max_angular_speed)
    s = step(s, 0.0, 0.0, dt, LIMITS)  # braking is limited too
    assert s.v == pytest.approx(0.45) and s.w == pytest.approx(-0.8)
    assert LIMITS.wheel_speeds(0.5, 1.0) == pytest.approx((0.3, 0.7))


@pytest.mark.parametrize(
    "field", ["max_linear_speed", "max_angular_speed", "max_linear_accel", "max_angular_accel", "wheel_base", "radius"]
)
def test_limits_are_validated(field: str) -> None:
    with pytest.raises(ValueError, match=field):
        DiffDriveLimits(**{field: -0.1})
    with pytest.raises(ValueError, match=field):
        DiffDriveLimits(**{field: math.inf})


def test_step_rejects_bad_input() -> None:
    s = DiffDriveState(0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="dt"):
        step(s, 0.1, 0.0, 0.0, LIMITS)
    with pytest.raises(ValueError, match="cmd_v"):
        step(s, math.nan, 0.0, 0.1, LIMITS)
    with pytest.raises(ValueError, match="yaw"):
        DiffDriveState(0.0, 0.0, math.inf)


# --------------------------------------------------------------------------------------------------------
# route planner
# --------------------------------------------------------------------------------------------------------


def test_clearance_distance_matches_brute_force() -> None:
    rng = np.random.default_rng(3)
    occ = rng.random((30, 40)) < 0.03
    res, cap = 0.05, 0.5
    got = clearance_distance(occ, res, cap)
    rr, cc = np.nonzero(occ)
    r = np.arange(30)[:, None, None]
    c = np.arange(40)[None, :, None]
    gap_r = np.maximum(np.abs(r - rr) - 1, 0)
    gap_c = np.maximum(np.abs(c - cc) - 1, 0)
    brute = res * np.sqrt(gap_r**2 + gap_c**2).min(axis=2)
    near = brute <= cap
    np.testing.assert_allclose(got[near], brute[near], rtol=0, atol=1e-12)
    assert (got[~near] > cap).all()


def test_route_goes_through_the_doorway_and_keeps_clearance() -> None:
    floor = room_floor(door=(2.5, 3.5))
    clearance = 0.3
    route = plan_route(floor, (2.0, 1.0), (6.0, 1.0), clearance)
    assert route[0] == (2.0, 1.0) and route[-1] == (6.0, 1.0)
    assert len(route) <= 6  # line-of-sight shortening: a handful of waypoints, not a chain of ~100 cells
    pts = np.asarray(route)
    crossings = []
    for a, b in zip(pts[:-1], pts[1:]):
        if (a[0] - 4.0) * (b[0] - 4.0) < 0.0:
            crossings.append(a[1] + (4.0 - a[0]) / (b[0] - a[0]) * (b[1] - a[1]))
    assert len(crossings) == 1
    assert 2.5 + clearance - 1e-9 <= crossings[0] <= 3.5 - clearance + 1e-9  # through the doorway
    samples = densify(route)
    assert distance_to_occupied(floor, samples).min() >= clearance - EXACT
    length = float(np.hypot(*np.diff(pts, axis=0).T).sum())
    # at least the taut string over the inflated jamb corners: (2, 1) -> (3.9, 2.8) -> (4.1, 2.8) -> (6, 1)
    taut = 2 * math.hypot(1.9, 1.8) + 0.2
    assert taut <= length <= taut + 0.25


def test_office_routes_and_tours_keep_clearance() -> None:
    floor = office()
    rng = np.random.default_rng(7)
    clearance = 0.45
    waypoints = tour(floor, rng, 4, clearance, 6.0)
    assert len(waypoints) >= 5
    samples = densify(waypoints)
    assert distance_to_occupied(floor, samples, reach=clearance + 0.1).min() >= clearance - EXACT
    # every waypoint lies in the start's reachable, traversable space
    free = reachable(floor, waypoints[0], clearance)
    assert free.sum() <= traversable(floor, clearance).sum()
    res, (ox, oy) = floor.resolution, floor.origin
    for x, y in waypoints:
        assert free[int((y - oy) // res), int((x - ox) // res)]


def test_route_errors() -> None:
    floor = room_floor(door=(2.5, 3.5))
    with pytest.raises(ValueError, match="start_xy .* inside a wall"):
        plan_route(floor, (4.0, 1.0), (6.0, 1.0), 0.3)  # start in the dividing wall
    with pytest.raises(ValueError, match="goal_xy .* inside a wall"):
        plan_route(floor, (2.0, 1.0), (6.0, 0.1), 0.3)  # goal 0.1 m from the outer wall
    with pytest.raises(ValueError, match="outside the floor"):
        plan_route(floor, (2.0, 1.0), (60.0, 1.0), 0.3)
    with pytest.raises(ValueError, match="clearance"):
        plan_route(floor, (2.0, 1.0), (6.0, 1.0), -0.1)
    with pytest.raises(ValueError, match="no route"):
        plan_route(room_floor(door=None), (2.0, 1.0), (6.0, 1.0), 0.3)  # the goal room has no door
    with pytest.raises(ValueError, match="no route"):
        plan_route(floor, (2.0, 1.0), (6.0, 1.0), 0.55)  # the 1 m doorway is too narrow for 0.55 m
    with pytest.raises(ValueError, match="legs"):
        tour(floor, np.random.default_rng(0), 0, 0.3, 1.0, start_xy=(2.0, 1.0))


# --------------------------------------------------------------------------------------------------------
# waypoint follower
# --------------------------------------------------------------------------------------------------------


def drive_follower(follower: WaypointFollower, state: DiffDriveState, seconds: float) -> NDArray[np.float64]:
    """Closed loop at 100 Hz; rows (x, y, yaw, v, w) until done or ``seconds``."""
    rows = [(*state.pose, state.v, state.w)]
    for _ in range(int(seconds * 100)):
        if follower.done:
            break
        v, w = follower.command(state)
        state = step(state, v, w, 0.01, LIMITS)
        rows.append((*state.pose, state.v, state.w))
    return np.array(rows)


def test_follower_turns_in_place_stops_for_sharp_corners_and_tracks_the_path() -> None:
    route = np.array([(0.0, 0.0), (3.0, 0.0), (3.0, 3.0)])
    follower = WaypointFollower(route, LIMITS)
    start = DiffDriveState(0.0, 0.0, math.pi)  # facing away from the path
    v, w = follower.command(start)
    assert v == 0.0 and w != 0.0  # heading error 180 deg: turn in place
    log = drive_follower(follower, start, 60.0)
    assert follower.done
    assert math.dist(log[-1, :2], (3.0, 3.0)) <= 0.15
    assert lateral_deviation(log[:, :2], route).max() < 0.06
    # slows down for the 90 deg corner (cruising 0.5 m/s until ~0.7 m before it), stops and turns in place
    reach = int(np.argmax(np.hypot(log[:, 0] - 3.0, log[:, 1]) < 0.1))
    approach = log[:reach][log[:reach, 0] > 0.5]  # x increasing along the first leg
    assert np.interp(1.5, approach[:, 0], approach[:, 3]) == pytest.approx(LIMITS.max_linear_speed, abs=0.005)
    assert np.interp(2.8, approach[:, 0], approach[:, 3]) < 0.3
    at_corner = np.hypot(log[:, 0] - 3.0, log[:, 1]) < 0.1
    assert (log[at_corner, 3] == 0.0).sum() > 50  # > 0.5 s turning in place
    assert np.abs(log[:, 3]).max() <= LIMITS.max_linear_speed and np.abs(log[:, 4]).max() <= LIMITS.max_angular_speed
    assert follower.command(DiffDriveState(*log[-1, :3])) == (0.0, 0.0)


def test_follower_keeps_speed_through_gentle_bends() -> None:
    route = np.array([(0.0, 0.0), (4.0, 0.0), (8.0, 4.0 * math.tan(math.radians(10.0)))])
    follower = WaypointFollower(route, LIMITS)
    log = drive_follower(follower, DiffDriveState(0.0, 0.0, 0.0), 60.0)
    assert follower.done
    cruising = (log[:, 0] > 2.0) & (log[:, 0] < 6.0)
    assert log[cruising, 3].min() > 0.4  # a 10 deg bend costs little speed
    assert lateral_deviation(log[:, :2], route).max() < 0.05


def test_follower_validation() -> None:
    with pytest.raises(ValueError, match="lookahead"):
        WaypointFollower([(0.0, 0.0)], LIMITS, lookahead=-1.0)
    with pytest.raises(ValueError, match="goal_tolerance"):
        WaypointFollower([(0.0, 0.0)], LIMITS, goal_tolerance=0.0)
    with pytest.raises(ValueError, match="waypoints"):
        WaypointFollower(np.zeros((0, 2)), LIMITS)


# --------------------------------------------------------------------------------------------------------
# odometry
# --------------------------------------------------------------------------------------------------------


def curvy_truth(seconds: float = 10.0, rate: float = 100.0) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    times = np.arange(round(seconds * rate) + 1) / rate
    s = DiffDriveState(3.0, -2.0, 2.5)
    poses = [s.pose]
    for t in times[1:]:
        s = step(s, 0.3 + 0.2 * math.sin(t), 0.9 * math.sin(0.7 * t), 1.0 / rate, LIMITS)
        poses.append(s.pose)
    return times, np.array(poses)


def straight_truth(n: int, step_m: float, yaw: float = 0.7) -> NDArray[np.float64]:
    k = np.arange(n + 1)[:, None]
    return np.column_stack([1.0 + k * step_m * math.cos(yaw), 2.0 + k * step_m * math.sin(yaw), np.full(n + 1, yaw)])


def test_noiseless_odometry_is_the_truth_in_the_odom_frame() -> None:
    times, poses = curvy_truth()
    odom = Odometry(rate_hz=100.0)
    stamps, out = odom.run(times, poses)
    assert len(stamps) == 1000 and odom.messages == 1000
    for k in range(1000):
        expected = se2.between(tuple(poses[0]), tuple(poses[k + 1]))
        assert out[k, :2] == pytest.approx(expected[:2], abs=EXACT)
        assert abs(se2.wrap_angle(out[k, 2] - expected[2])) < EXACT
    # update() with the same poses gives the same stream; the first call anchors the odom frame
    odom2 = Odometry()
    assert odom2.update(poses[0]) == (0.0, 0.0, 0.0)
    last = (0.0, 0.0, 0.0)
    for p in poses[1:]:
        last = odom2.update(p)
    assert last == pytest.approx(tuple(out[-1]), abs=1e-12)


def test_error_generator_accumulates_as_documented() -> None:
    gen = ErrorGenerator()
    assert (gen.translation_per_message, gen.rotation_per_message) == (5e-5, 5e-5)
    c, eps, d, n = 5e-5, 5e-5, 0.005, 1000  # 0.5 m/s at 100 Hz for 10 s
    odom = Odometry(rate_hz=100.0, error_generator=gen)
    truth = straight_truth(n, d)
    pose = (0.0, 0.0, 0.0)
    for p in truth:
        pose = odom.update(p)
    j = np.arange(n)
    assert pose[2] == pytest.approx(n * eps, abs=EXACT)  # heading error: exactly N * 5e-5 rad
    assert pose[0] == pytest.approx((d + c) * np.cos(j * eps).sum(), abs=EXACT)
    assert pose[1] == pytest.approx((d + c) * np.sin(j * eps).sum(), abs=EXACT)
    along, cross = pose[0] - n * d, pose[1]  # the truth in the odom frame is (N d, 0, 0)
    assert along == pytest.approx(n * c, rel=0.06)  # ~ N c, less the arc's curling
    assert cross == pytest.approx((d + c) * eps * n * (n - 1) / 2, rel=0.01)  # ~ 12.6 cm to the left

    # standing still: the generator still adds its constants to every message
    still = Odometry(error_generator=gen)
    for _ in range(101):
        pose = still.update((1.0, 2.0, 0.3))
    assert pose[2] == pytest.approx(100 * eps, abs=EXACT)
    assert pose[0] == pytest.approx(c * np.cos(np.arange(100) * eps).sum(), abs=EXACT)


def test_odometry_message_rate() -> None:
    times, poses = curvy_truth(10.0, 100.0)
    stamps, out = Odometry(rate_hz=100.0).run(times, poses)
    assert out.shape == (1000, 3)
    np.testing.assert_allclose(stamps, np.arange(1, 1001) / 100.0, rtol=0, atol=1e-12)
    # truth sampled at 250 Hz still gives 1000 messages at 100 Hz; a straight drive interpolates exactly
    t250 = np.arange(2501) / 250.0
    p250 = np.column_stack([0.5 * t250, np.zeros_like(t250), np.zeros_like(t250)])
    stamps, out = Odometry(rate_hz=100.0).run(t250, p250)
    assert len(stamps) == 1000
    np.testing.assert_allclose(out[:, 0], 0.5 * stamps, rtol=0, atol=EXACT)
    assert len(Odometry(rate_hz=20.0).run(t250, p250)[0]) == 200


def test_odometry_noise_statistics() -> None:
    n, d = 20000, 0.005
    noise = OdometryNoise()
    assert (noise.translation_fraction, noise.rotation_fraction, noise.rotation_sigma_min) == (0.01, 0.01, 1e-5)
    odom = Odometry(noise=noise, rng=np.random.default_rng(11))
    poses = [odom.update(p) for p in straight_truth(n, d)]
    inc = np.array([se2.between(a, b) for a, b in zip(poses[:-1], poses[1:])])
    assert inc.shape == (n, 3)
    err = inc - np.array([d, 0.0, 0.0])
    assert err[:, 0].std() == pytest.approx(0.01 * d, rel=0.05)
    assert err[:, 1].std() == pytest.approx(0.01 * d, rel=0.05)
    assert err[:, 2].std() == pytest.approx(1e-5, rel=0.05)
    assert abs(err[:, 0].mean()) < 4 * 0.01 * d / math.sqrt(n)

    # turning 0.01 rad per message: rotation sigma 1 % of it plus 1e-5 rad
    dyaw = 0.01
    k = np.arange(n + 1)
    arc = np.column_stack([np.zeros(n + 1), np.zeros(n + 1), k * dyaw])  # turning in place
    odom = Odometry(noise=noise, rng=np.random.default_rng(12))
    poses = [odom.update(p) for p in arc]
    inc = np.array([se2.between(a, b) for a, b in zip(poses[:-1], poses[1:])])
    assert (inc[:, 2] - dyaw).std() == pytest.approx(0.01 * dyaw + 1e-5, rel=0.05)
    assert np.abs(inc[:, :2]).max() < 1e-12  # no translation, so no translation noise


def test_odometry_validation() -> None:
    with pytest.raises(ValueError, match="rate_hz"):
        Odometry(rate_hz=-100.0)
    with pytest.raises(ValueError, match="rate_hz"):
        Odometry(rate_hz=0.0)
    for field in ("translation_fraction", "rotation_fraction", "rotation_sigma_min"):
        with pytest.raises(ValueError, match=field):
            OdometryNoise(**{field: -0.01})
    with pytest.raises(ValueError, match="rotation_per_message"):
        ErrorGenerator(rotation_per_message=math.nan)
    with pytest.raises(ValueError, match="rng"):
        Odometry(noise=OdometryNoise())
    Odometry(noise=OdometryNoise.none())  # no noise, no rng needed
    with pytest.raises(ValueError, match="strictly increasing"):
        Odometry().run([0.0, 0.0], np.zeros((2, 3)))


# --------------------------------------------------------------------------------------------------------
# drives
# --------------------------------------------------------------------------------------------------------


def test_office_drive_tours_rooms_without_touching_anything() -> None:
    floor = office()
    traj = office_drive()
    assert len(traj) == 6001 and traj.duration == pytest.approx(60.0)
    np.testing.assert_allclose(traj.times, np.arange(6001) / 100.0, rtol=0, atol=1e-12)
    assert traj.path_length > 15.0

    # the footprint never overlaps a wall or furniture cell (exact distance to the cell squares)
    assert distance_to_occupied(floor, traj.poses[:, :2], reach=LIMITS.radius + 0.1).min() >= LIMITS.radius

    # speeds and accelerations within the limits
    v, w = traj.velocities[:, 0], traj.velocities[:, 1]
    assert np.abs(v).max() <= LIMITS.max_linear_speed + 1e-12
    assert np.abs(w).max() <= LIMITS.max_angular_speed + 1e-12
    assert np.abs(np.diff(v)).max() <= LIMITS.max_linear_accel * 0.01 + 1e-12
    assert np.abs(np.diff(w)).max() <= LIMITS.max_angular_accel * 0.01 + 1e-12

    # kinematically exact: each pose is the arc of the velocities applied during the step that ends there
    for k in range(0, 6000, 7):
        inc = arc_increment(v[k + 1] * 0.01, w[k + 1] * 0.01)
        expected = se2.compose(tuple(traj.poses[k]), inc)
        assert traj.poses[k + 1, :2] == pytest.approx(expected[:2], abs=1e-12)
        assert abs(se2.wrap_angle(traj.poses[k + 1, 2] - expected[2])) < 1e-12

    # rooms: free space split by the walls grown by 0.7 m (closes doorways <= 1.4 m, keeps the corridor)
    grow = round(0.7 / floor.resolution)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * grow + 1, 2 * grow + 1))
    grown = cv2.dilate(floor.walls.astype(np.uint8), kernel) > 0
    _, labels = cv2.connectedComponents((~grown).astype(np.uint8), connectivity=4)
    res, (ox, oy) = floor.resolution, floor.origin
    rows = np.floor((traj.poses[:, 1] - oy) / res).astype(np.int64)
    cols = np.floor((traj.poses[:, 0] - ox) / res).astype(np.int64)
    visited = set(labels[rows, cols].tolist()) - {0, int(labels[0, 0])}  # not walls, not outside
    assert len(visited) >= 2


def test_drive_is_deterministic_and_starts_at_rest() -> None:
    a = simulate_drive(office(), np.random.default_rng(5), 5.0)
    b = simulate_drive(office(), np.random.default_rng(5), 5.0)
    np.testing.assert_array_equal(a.poses, b.poses)
    assert len(a) == 501 and tuple(a.velocities[0]) == (0.0, 0.0)
    assert not a.poses.flags.writeable


def test_drive_errors() -> None:
    solid = synthetic.Floor(walls=np.ones((40, 40), dtype=np.bool_), clutter=np.zeros((40, 40), dtype=np.bool_),
                            resolution=0.05, origin=(0.0, 0.0))  # fmt: skip
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="no free cell"):
        simulate_drive(solid, rng, 10.0)
    cramped = room_floor(door=None)
    with pytest.raises(ValueError, match="no free cell"):
        simulate_drive(cramped, rng, 10.0, clearance=2.5)  # rooms are 4 m wide: nothing has 2.5 m clearance
    with pytest.raises(ValueError, match="duration_s"):
        simulate_drive(cramped, rng, -1.0)
    with pytest.raises(ValueError, match="control_rate_hz"):
        simulate_drive(cramped, rng, 10.0, control_rate_hz=-100.0)
    with pytest.raises(ValueError, match="control_rate_hz"):
        simulate_drive(cramped, rng, 10.0, control_rate_hz=0.0)
    with pytest.raises(ValueError, match="clearance"):
        simulate_drive(cramped, rng, 10.0, clearance=0.2)  # below the robot radius
