"""Generated floors, and what the simulator derives from them, are the same bytes from release to
release: a reorganisation of the code (or a change of the library doing connected components or
distance transforms) must not move a wall, a piece of furniture, a sampled pose, a traversable cell
or a simulated range.

Each fingerprint is a SHA-256 prefix of the arrays' dtypes, shapes and bytes, recorded from the code
before `planicp.synthetic` moved into `planicp.sim` (commit 22e3a96)."""

from __future__ import annotations

import functools
import hashlib
import math
from typing import Any

import numpy as np
import pytest

from planicp import sim
from planicp.sim import route_planner

SEEDS = (0, 3, 11)
CLEARANCES = (0.0, 0.3, 0.5, 0.8)

# (layout, seed): fingerprints of (the floor, sampled poses, the enclosed region, traversable masks,
# clearance distances, simulated scans).
EXPECTED = {
    ("office", 0): ("aea907278cef4242", "20d4e18bda0e2634", "0ba9790e45657e86", "8a34691d56cdfbf2", "d2f391d7ff803cd1", "34a2d2ffbba81e64"),  # noqa: E501
    ("office", 3): ("bc92deebb5fa3574", "9734a453461b9695", "e77fc032aed394cb", "2cc240b7e07aa7da", "80c8f9c3929f5289", "975b5dba336221ba"),  # noqa: E501
    ("office", 11): ("9104a3a3e888efe9", "0f3a38e13c2e7a1f", "2ff9d25ce2f214c5", "d1b27b3eee30d587", "5a2404ebec6d7fb5", "6ac9156deca8f821"),  # noqa: E501
    ("hall", 0): ("eccd75a0ec0e5851", "80d0006cca3c60d4", "ada341e088de4470", "aba4fbc5fe5f4670", "78c98b984275c0ab", "d54ec576fe3dea14"),  # noqa: E501
    ("hall", 3): ("e82302c61712c16c", "33d6ebc7d9458dab", "cd497324797f9853", "0272b45a0ce18636", "f575db28fec634bc", "7098d504f3bb37c2"),  # noqa: E501
    ("hall", 11): ("b521dc9d9f008e7f", "d29fc39add8f2054", "cc6078ccb086d95c", "da5b1ed8496dd94e", "836b55ee54aa2750", "fdcef16deadd0a0d"),  # noqa: E501
    ("diagonal", 0): ("44d639544b8164bf", "250afd2a6134b910", "977b137e376bb930", "b140f385aa99def3", "965776164c76556b", "0b7f39cc8d58cbf5"),  # noqa: E501
    ("diagonal", 3): ("2898fd3d544368a9", "4918c62943c9cbc9", "c42e8bb3acbfab8c", "7b2ad1ca3cc74afb", "6b54eadc1cdd91f0", "b2c1fadde1b6ddd3"),  # noqa: E501
    ("diagonal", 11): ("fe25e3b17b08ea41", "e6e92749a5438800", "43800f57f398cc3d", "8fb76f0955c1e606", "6f0d71a2819b83ee", "392568a6fad2ba53"),  # noqa: E501
}  # fmt: skip

# seed: fingerprints of (the enclosed region, sampled poses, pose cells per clearance, reachable masks).
EXPECTED_BLOBS = {
    1: ("f87e641a9e40dc6e", "1e1afa11d777f8af", "41fb0fa2e4c5a80d", "88dff2212c3d2ff1"),
    2: ("b56ee0ba776af652", "75d67c486d29b251", "3194d60cb8194edf", "05bf1886004ed97a"),
    3: ("1b39cbdb6043dcd1", "c2021f9878cf2a86", "b6d9fa1668400977", "bf25da7f1c13c91f"),
}


def _digest(*arrays: Any) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


@functools.cache
def _floor(layout: str, seed: int) -> Any:
    return sim.generate_floor(seed, layout)


def _blob_floor(seed: int) -> Any:
    """Random clutter in a closed frame, two equal rooms (a tie for the largest region) and a region
    touching the raster's border: the corner cases of regions and clearances."""
    rng = np.random.default_rng(seed)
    walls = np.zeros((90, 130), dtype=bool)
    walls[2, 2:129] = walls[87, 2:129] = walls[2:88, 2] = walls[2:88, 128] = True
    walls[2:88, 65] = True  # two rooms of 62 x 84 cells each
    walls[40:50, 0:2] = True  # a pocket open to the border
    clutter = rng.random(walls.shape) < 0.02
    clutter[3:87, 3:65] = clutter[3:87, 66:128]  # the same clutter in both rooms
    return sim.Floor(walls, clutter & ~walls, 0.05, (-1.0, 2.0))


def blob_fingerprints(seed: int) -> tuple[str, ...]:
    f = _blob_floor(seed)
    rng = np.random.default_rng(seed)
    poses = np.array([f.sample_pose(rng, clearance=c) for c in (0.0, 0.05, 0.1, 0.15) for _ in range(5)])
    cells = [f._pose_cells(c) for c in (0.0, 0.05, 0.07, 0.1, 0.2, 0.3, 0.35, 0.5)]
    start = tuple(float(v) for v in poses[-1][:2])
    reach = [route_planner.reachable(f, start, c) for c in (0.0, 0.1)]
    return _digest(f._inside()), _digest(poses), _digest(*cells), _digest(*reach)


def fingerprints(layout: str, seed: int) -> tuple[str, ...]:
    f = _floor(layout, seed)
    rng = np.random.default_rng(seed)
    poses = np.array([f.sample_pose(rng, clearance=c) for c in CLEARANCES for _ in range(5)])
    inside = f._inside()  # the largest enclosed free region, where poses are drawn
    masks = [route_planner.traversable(f, c) for c in (0.25, 0.5)]
    cap = 0.5
    gaps = route_planner.clearance_distance(f.occupied(), f.resolution, cap)
    gaps = np.where(gaps <= cap, gaps, np.inf)  # exact up to the cap; above it only "more than the cap"
    rng = np.random.default_rng(seed + 100)
    scans: list[Any] = []
    for k in range(5):
        p = tuple(float(v) for v in poses[5 + k])
        discs = np.array([[p[0] + 1.0, p[1], 0.3], [p[0], p[1] - 1.5, 0.2]])
        r, a0, da = sim.simulate_ranges(f, p, rng, beams=720, range_sigma=0.01, dropout=0.05, dynamic_discs=discs)
        pts, clutter = sim.simulate_scan(f, p, rng, beams=541, fov=math.radians(270), dynamic_discs=discs)
        scans += [r, np.array([a0, da]), pts, clutter]
    return (
        _digest(f.walls, f.clutter, np.array(f.origin), np.array([f.resolution])),
        _digest(poses),
        _digest(inside),
        _digest(*masks),
        _digest(gaps),
        _digest(*scans),
    )


@pytest.mark.parametrize(("layout", "seed"), sorted(EXPECTED))
def test_generated_floors_are_unchanged(layout: str, seed: int) -> None:
    names = ("floor", "sampled poses", "enclosed region", "traversable cells", "clearance distances", "scans")
    got = fingerprints(layout, seed)
    changed = [name for name, a, b in zip(names, got, EXPECTED[layout, seed]) if a != b]
    assert not changed, f"{layout} seed {seed}: {', '.join(changed)} changed"


@pytest.mark.parametrize("seed", sorted(EXPECTED_BLOBS))
def test_regions_and_clearances_are_unchanged(seed: int) -> None:
    names = ("enclosed region", "sampled poses", "pose cells", "reachable cells")
    got = blob_fingerprints(seed)
    changed = [name for name, a, b in zip(names, got, EXPECTED_BLOBS[seed]) if a != b]
    assert not changed, f"seed {seed}: {', '.join(changed)} changed"
    inside = _blob_floor(seed)._inside()
    assert inside[:, :65].any() and not inside[:, 65:].any(), "a tie goes to the region first in row-major order"
