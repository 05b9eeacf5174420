#!/usr/bin/env python3
"""How long a big plan takes to prepare, and to load again from the cache.

Draws a 4000 x 4000 px office plan at 2.5 cm/px (100 x 100 m: a grid of rooms with 20 cm walls and
doors), writes it as PNG, then times `PlanMap.from_image` cold (no cache entry) and warm (cached),
each as the best of --repeats runs, and reports the stages.

    python benches/plan_preparation.py
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from planicp import PlanMap


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
            image[r + room_px // 2 - door // 2 : r + room_px // 2 + door // 2, c + room_px : c + room_px + wall_px] = 255
            image[r + room_px : r + room_px + wall_px, c + room_px // 2 - door // 2 : c + room_px // 2 + door // 2] = 255
    return image


def best(fn, repeats: int) -> tuple[float, object]:  # type: ignore[no-untyped-def]
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=4000)
    parser.add_argument("--resolution", type=float, default=0.025)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    import cv2

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "plan.png"
        cv2.imwrite(str(path), office_image(args.size, wall_px=8, room_px=400))
        cache = Path(tmp) / "cache"

        def cold() -> PlanMap:
            for entry in cache.glob("*.npz"):
                entry.unlink()
            return PlanMap.from_image(path, args.resolution, cache=cache)

        t_cold, plan = best(cold, args.repeats)
        t_warm, warm = best(lambda: PlanMap.from_image(path, args.resolution, cache=cache), args.repeats)
        assert isinstance(plan, PlanMap) and isinstance(warm, PlanMap) and warm.from_cache
        t_native, _ = best(lambda: PlanMap.from_points(warm.points, resolution=1.5 * args.resolution), args.repeats)
    print(f"{args.size} x {args.size} px at {args.resolution} m/px: {len(plan)} wall points")
    print(f"from_image, cold (decode, threshold, surfaces, cache write, map build): {t_cold:.3f} s")
    print(f"from_image, cached:                                                     {t_warm:.3f} s")
    print(f"for comparison, PlanMap.from_points on those points (fits normals):    {t_native:.3f} s")


if __name__ == "__main__":
    main()
