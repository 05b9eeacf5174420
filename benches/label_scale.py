#!/usr/bin/env python3
"""A raster drawing's scale read from its own room labels by OCR, against a reference.

    python benches/label_scale.py [--drawings ../shared/data/drawings]

For each raster drawing: what `raster_label_scale` (the scale `planicp plan FILE` takes when no
--resolution is given; needs RapidOCR and ONNX Runtime) finds, its error against the reference scale, how many
labels agreed and were left out, the wall extractions it took, and the time (OCR included; CPU
time of all threads, ONNX Runtime using every core). The
references, metres per pixel, worked out without planicp's measurement:

* `apartment_us_feet.png`: 0.0246, the mean of five room sides measured by hand (inner wall face
  to inner wall face along a row or column of pixels) against their dimension labels: bedroom
  10'1" x 11'1" over 125 x 137 px (0.02459, 0.02466), bedroom 11'1" x 13'6" over 137 x 168 px
  (0.02466, 0.02449), living room 15'7" over 193 px (0.02461); they agree within 0.4 %. (The
  drawings' README says "about 0.02".)
* `apartment_se.png`: 0.0151, from the bedroom's "13 m²" over its 287 x 199 px measured by hand;
  an area stated in whole square metres is known to +-0.5 m², so this reference to +-1.9 %.
* `cubicasa_F1_original.png`: 0.0056, from the CubiCasa annotation's room label 5'4" x 20'4"
  against its polygon (the README); the drawing itself states no size ("not to scale").

And the vector drawings read without a scale (`pdf_walls`, `svg_walls`: their text's room labels
against the rooms their wall segments enclose; no OCR), metres per point or per SVG pixel:

* `cubicasa_F1_model.svg`: 0.0100, the mean of its two rectangular labelled rooms' sides against
  their polygons: 5'4" x 20'4" over 162.01 x 619.84 px (0.010034, 0.009999), 13'6" x 20'4" over
  412.43 x 619.85 px (0.009977, 0.009998).
* `cmu_newell_simon_floor3.pdf`: 0.1016, its print scale 1"=24' (24 feet per 72 points).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from planicp.plans.pdf_plan import pdf_walls
from planicp.plans.raster_scale import raster_label_scale
from planicp.plans.svg_plan import svg_walls

REFERENCES = {
    "apartment_us_feet.png": 0.0246,
    "apartment_se.png": 0.0151,
    "cubicasa_F1_original.png": 0.0056,
}
"""Metres per pixel of each drawing, worked out by hand (see the module's docstring)."""

VECTOR_REFERENCES = {"cubicasa_F1_model.svg": 0.0100, "cmu_newell_simon_floor3.pdf": 0.1016}
"""Metres per SVG pixel or PDF point (see the module's docstring)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--drawings", type=Path, default=Path("../shared/data/drawings"))
    args = parser.parse_args()
    print("| drawing | reference m/px | found m/px | error | labels agreeing | left out | rounds | time | CPU time |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, reference in REFERENCES.items():
        start, cpu = time.perf_counter(), time.process_time()
        found = raster_label_scale(args.drawings / name)
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
        if found.scale is None:
            print(f"| `{name}` | {reference:.4g} | none | - | 0 | - | {found.rounds} | {seconds:.1f} s | {cpu:.1f} s |")
        else:
            s = found.scale
            left = s.source.split(", ")[-1].split(" disagreeing")[0] if "disagreeing" in s.source else "0"
            error = s.metres_per_unit / reference - 1.0
            print(
                f"| `{name}` | {reference:.4g} | {s.metres_per_unit:.5f} | {error:+.1%} | {s.labels} | {left} | "
                f"{found.rounds} | {seconds:.1f} s | {cpu:.1f} s |"
            )
        print(f"    {found.describe()}")
        print(f"    OCR read: {', '.join(repr(t.text) for t in found.text)}")
    for name, reference in VECTOR_REFERENCES.items():
        start, cpu = time.perf_counter(), time.process_time()
        try:
            if name.endswith(".svg"):
                svg = svg_walls(args.drawings / name)
                metres, source = svg.metres_per_pixel, svg.notes[0]
            else:
                pdf = pdf_walls(args.drawings / name)
                metres, source = pdf.metres_per_point, pdf.scale_source
        except ValueError as exc:
            metres, source = None, f"refused: {exc}"
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
        found = "none" if metres is None else f"{metres:.5f}"
        error = "-" if metres is None else f"{metres / reference - 1.0:+.1%}"
        print(f"| `{name}` | {reference:.4g} | {found} | {error} | | | | {seconds:.1f} s | {cpu:.1f} s |")
        print(f"    {source}")


if __name__ == "__main__":
    main()
