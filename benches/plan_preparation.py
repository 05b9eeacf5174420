#!/usr/bin/env python3
"""How long a big plan takes to prepare, and to load again from the cache; how a plan of points
scales with their number.

Draws a 4000 x 4000 px office plan at 2.5 cm/px (100 x 100 m: a grid of rooms with 20 cm walls and
doors), writes it as PNG, then times `PlanMap.from_image` cold (no cache entry) and warm (cached),
each as the best of --repeats runs, and reports the stages.

Then the dense walls of issue 19: two parallel walls --walls-length metres long, 3 m apart, drawn
with each count of --dense-points points (evenly along them, so the same geometry ever denser). For
each it times `PlanMap.from_points` and the first `localize` (which builds the nearest-wall index),
once each, reports the points kept and each time's ratio to the previous row's with the ratio of
the points given: near-linear work has ratios no larger than the points' (smaller once the plan is
thinned), super-linear work larger. --skip-office runs only this part.

    python benches/plan_preparation.py
    python benches/plan_preparation.py --skip-office --dense-points 1e5,1e6,1e7
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from planicp import PlanMap, localize


def office_image(size: int, wall_px: int, room_px: int) -> np.ndarray:
    image = np.full((size, size), 255, np.uint8)
    for k in range(0, size, room_px):
        image[k : k + wall_px, :] = 0
        image[:, k : k + wall_px] = 0
    image[-wall_px:, :] = 0
    image[:, -wall_px:] = 0
    door = room_px // 4
    for r in range(0, size - room_px, room_px):
        for c in range(0, size - room_px, room_px):
            image[r + room_px // 2 - door // 2 : r + room_px // 2 + door // 2, c + room_px : c + room_px + wall_px] = (
                255
            )
            image[r + room_px : r + room_px + wall_px, c + room_px // 2 - door // 2 : c + room_px // 2 + door // 2] = (
                255
            )
    return image


def best(fn, repeats: int) -> tuple[float, object]:  # type: ignore[no-untyped-def]
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def dense_walls(length: float, counts: list[int]) -> None:
    """Two walls `length` m long, 3 m apart, of each count of points: build and first localize."""
    print(f"two {length:g} m walls, 3 m apart: PlanMap.from_points, then the first localize")
    print("points given | kept    | spacing given | build s (ratio) | first localize s (ratio) | points ratio")
    scan = np.vstack(
        [np.c_[np.linspace(-5.0, 5.0, 200), np.full(200, -1.5)], np.c_[np.linspace(-5.0, 5.0, 200), np.full(200, 1.5)]]
    )
    previous: tuple[int, float, float] | None = None
    for n in counts:
        x = np.linspace(0.0, length, n // 2)
        points = np.vstack([np.c_[x, np.zeros_like(x)], np.c_[x, np.full_like(x, 3.0)]])
        t0 = time.perf_counter()
        plan = PlanMap.from_points(points)
        t_build = time.perf_counter() - t0
        del points
        t0 = time.perf_counter()
        localize(scan, plan, (length / 2, 1.5, 0.0))
        t_first = time.perf_counter() - t0
        ratios = ("", "", "")
        if previous is not None:
            ratios = (f" ({t_build / previous[1]:.1f}x)", f" ({t_first / previous[2]:.1f}x)", f"{n / previous[0]:.0f}x")
        print(
            f"{n:12.0e} | {len(plan):7d} | {length / (n // 2):10.2e} m | {t_build:7.2f}{ratios[0]:>8} | "
            f"{t_first:8.2f}{ratios[1]:>8}         | {ratios[2]}"
        )
        previous = (n, t_build, t_first)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=4000)
    parser.add_argument("--resolution", type=float, default=0.025)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--walls-length", type=float, default=2000.0)
    parser.add_argument("--dense-points", default="1e5,1e6,1e7", help="comma-separated point counts of the dense walls")
    parser.add_argument("--skip-office", action="store_true")
    args = parser.parse_args()
    if not args.skip_office:
        office(args)
    dense_walls(args.walls_length, [int(float(c)) for c in args.dense_points.split(",")])


def office(args: argparse.Namespace) -> None:
    import cv2

    # The drawn office is a clean wall image: every dark pixel a wall, as the published timings
    # were taken (the default reading as a drawing adds its wall extraction to the cold time).
    WALLS = "all-dark"
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "plan.png"
        cv2.imwrite(str(path), office_image(args.size, wall_px=8, room_px=400))
        cache = Path(tmp) / "cache"

        def cold() -> PlanMap:
            for entry in cache.glob("*.npz"):
                entry.unlink()
            return PlanMap.from_image(path, args.resolution, walls=WALLS, cache=cache)

        t_cold, plan = best(cold, args.repeats)
        t_warm, warm = best(lambda: PlanMap.from_image(path, args.resolution, walls=WALLS, cache=cache), args.repeats)
        assert isinstance(plan, PlanMap) and isinstance(warm, PlanMap) and warm.from_cache
        t_native, _ = best(lambda: PlanMap.from_points(warm.points, resolution=1.5 * args.resolution), args.repeats)
    print(f"{args.size} x {args.size} px at {args.resolution} m/px: {len(plan)} wall points")
    print(f"from_image, cold (decode, threshold, surfaces, cache write, map build): {t_cold:.3f} s")
    print(f"from_image, cached:                                                     {t_warm:.3f} s")
    print(f"for comparison, PlanMap.from_points on those points (fits normals):    {t_native:.3f} s")


if __name__ == "__main__":
    main()
