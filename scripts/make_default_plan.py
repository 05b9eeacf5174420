#!/usr/bin/env python3
"""Regenerates the plan `planicp demo` ships with: python/planicp/data/office_plan.{png,yaml}.

A 30 x 20 m office floor from `planicp.sim` (seed 3): a corridor, eight rooms of different
widths, doors to the corridor and between some rooms, alcoves; walls 15-25 cm thick, 5 cm per
pixel. Only the walls are drawn: furniture and people belong to the simulated world, not the plan.

    python scripts/make_default_plan.py
"""

from __future__ import annotations

from pathlib import Path

import cv2

from planicp import sim

SEED = 3
OUT = Path(__file__).resolve().parents[1] / "python" / "planicp" / "data"


def main() -> None:
    floor = sim.generate_floor(SEED, "office", width=30.0, height=20.0, rooms=8)
    OUT.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(OUT / "office_plan.png"), floor.to_image())
    ox, oy = floor.origin
    (OUT / "office_plan.yaml").write_text(
        "image: office_plan.png\n"
        f"resolution: {floor.resolution}\n"
        f"origin: [{ox!r}, {oy!r}, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n"
    )
    print(f"wrote {OUT / 'office_plan.png'} ({floor.shape[1]} x {floor.shape[0]} px) and office_plan.yaml")


if __name__ == "__main__":
    main()
