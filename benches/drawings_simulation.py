"""The simulation in the real drawings' buildings: each drawing's plan furnished and driven.

For each drawing in the project's `shared/data/drawings/` (not in the repository): the plan as
`planicp plan` reads it, the simulated building (`World.from_plan`: a drawing's wall points
rasterised at 1 cm, an open outline closed), a 30 s drive, and planicp's errors against the truth.

    python benches/drawings_simulation.py ../shared/data/drawings
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path
from typing import Any

from planicp.plans.plan_loading import load_plan
from planicp.sim.experiment import ExperimentConfig, run_experiment

DRAWINGS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("AC20-FZK-Haus.ifc", {}),
    ("cubicasa_F1_model.svg", {"resolution": 0.01}),
    ("raumzeitlabor_floorplan.dxf", {"layers": ["Base", "Wand (neu)"]}),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", type=Path)
    parser.add_argument("--seconds", type=float, default=30.0)
    args = parser.parse_args()
    print("| drawing | building | furniture, people | planicp | time |")
    print("|---|---|---|---|---|")
    for name, options in DRAWINGS:
        started = time.perf_counter()
        plan = load_plan(args.folder / name, cache=False, **options)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            recording, world = run_experiment(plan, ExperimentConfig(duration_s=args.seconds, seed=0))
        m = recording.metrics()
        furniture = world.floor.clutter[3:-3, 3:-3].sum() * world.floor.resolution**2
        building = world.notes[0].split(";")[0] if world.notes else "outline closed"
        print(
            f"| {name} | {building} | {furniture:.1f} m^2, {len(world.people)} | "
            f"RMS {m['planicp_position_rms_m'] * 100:.1f} cm, max {m['planicp_position_max_m'] * 100:.1f} cm, "
            f"accepted {m['accepted_share']:.2f}, lost {m['lost_scans']:.0f} | {time.perf_counter() - started:.0f} s |",
            flush=True,
        )


if __name__ == "__main__":
    main()
