#!/usr/bin/env python3
"""Tracking in simulation inside each real drawing's building: the robot in the true walls, planicp
on the plan read from the drawing by default.

For each drawing in the project's `shared/data/drawings/` (not in the repository), the drift
experiment (`planicp.sim.run_experiment`: furniture and walking people, odometry drift, a 10 Hz
LIDAR) drives the robot and casts its scans in the building's TRUE walls (`building=`), while a
`Localizer` tracks it on the plan planicp reads from the drawing:

* `cubicasa`: the raster `cubicasa_F1_original.png` (0.0056 m per pixel) read by default; truth:
  its CubiCasa5K annotation (wall polygons less doors, registered to the pixels, outside the
  footprint solid: `drawing_walls.py`'s `true_building`).
* `apartment_se`, `apartment_us_feet`: the rasters read by default; they have no annotation, so
  the extraction is the truth too (the robot drives in the extracted walls): these rows measure
  tracking in a drawing's building, not the extraction.
* `fzk_ifc`: the IFC read by planicp (wall solids cut at 1 m, doors and windows open) is both: no
  independent truth exists for it.
* `dxf_default`, `dxf_layers`: truth: the DXF's wall layers `Base` and `Wand (neu)`; planicp on
  the file's default reading and on `layers=["Base", "Wand (neu)"]`.
* `cmu_pdf`: the vector PDF at its print scale 1"=24' (68 x 63 m) is both (no independent truth).

A drawing's walls are rasterised at 1 cm for the simulated building (`World.from_plan`), an open
outline closed with shut doors. Per building and seed: position RMS, max, heading RMS, scans,
scans after which the localizer was lost, and the closest a walking person came to the robot's
footprint (metres; negative would be an overlap).

    python benches/drawings_simulation.py ../shared/data/drawings --seconds 300 --seeds 0 1 2 [--only NAME ...]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

from planicp import PlanMap
from planicp.plans.plan_loading import load_plan
from planicp.plans.plan_raster import PlanRaster
from planicp.sim.experiment import ExperimentConfig, run_experiment
from planicp.sim.world import drawing_raster

sys.path.insert(0, str(Path(__file__).resolve().parent))
from drawing_walls import DRAWINGS, true_building  # noqa: E402

DXF = "raumzeitlabor_floorplan.dxf"
DXF_WALLS = ["Base", "Wand (neu)"]

Setup = Callable[[Path], tuple[PlanMap, PlanRaster | None]]


def _raster(name: str) -> Setup:
    def setup(folder: Path) -> tuple[PlanMap, PlanRaster | None]:
        return PlanMap.from_image(folder / name, DRAWINGS[name], cache=False), None

    return setup


def _cubicasa(folder: Path) -> tuple[PlanMap, PlanRaster | None]:
    plan = PlanMap.from_image(folder / "cubicasa_F1_original.png", DRAWINGS["cubicasa_F1_original.png"], cache=False)
    return plan, true_building(folder)


def _dxf(layers: list[str] | None) -> Setup:
    def setup(folder: Path) -> tuple[PlanMap, PlanRaster | None]:
        truth = drawing_raster(load_plan(folder / DXF, cache=False, layers=DXF_WALLS))
        options = {} if layers is None else {"layers": layers}
        return load_plan(folder / DXF, cache=False, **options), truth

    return setup


def _own(name: str, **options: str) -> Setup:
    def setup(folder: Path) -> tuple[PlanMap, PlanRaster | None]:
        return load_plan(folder / name, cache=False, **options), None

    return setup


BUILDINGS: dict[str, tuple[str, Setup]] = {
    "cubicasa": ("annotation (SVG walls less doors)", _cubicasa),
    "apartment_se": ("none: the extraction", _raster("apartment_se.png")),
    "apartment_us_feet": ("none: the extraction", _raster("apartment_us_feet.png")),
    "fzk_ifc": ("the IFC as read", _own("AC20-FZK-Haus.ifc")),
    "dxf_default": ("layers Base, Wand (neu)", _dxf(None)),
    "dxf_layers": ("layers Base, Wand (neu)", _dxf(DXF_WALLS)),
    "cmu_pdf": ("the PDF as read", _own("cmu_newell_simon_floor3.pdf", scale="1\"=24'")),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", type=Path)
    parser.add_argument("--seconds", type=float, default=300.0)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--only", nargs="+", choices=sorted(BUILDINGS), default=list(BUILDINGS))
    args = parser.parse_args()
    print(
        "| building | truth | seed | position RMS | position max | heading RMS | scans | lost | closest person | time |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in args.only:
        truth, setup = BUILDINGS[name]
        plan, building = setup(args.folder)
        for seed in args.seeds:
            started = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # an open outline closed: the building's note
                recording, world = run_experiment(
                    plan, ExperimentConfig(duration_s=args.seconds, seed=seed), building=building
                )
            m = recording.metrics()
            print(
                f"| {name} | {truth} | {seed} | {m['planicp_position_rms_m'] * 100:.1f} cm | "
                f"{m['planicp_position_max_m'] * 100:.1f} cm | {m['planicp_heading_rms_deg']:.2f} deg | "
                f"{m['scans']:.0f} | {m['lost_scans']:.0f} | {m.get('closest_person_m', float('inf')):.2f} m "
                f"({len(world.people)}) | {time.perf_counter() - started:.0f} s |",
                flush=True,
            )


if __name__ == "__main__":
    main()
