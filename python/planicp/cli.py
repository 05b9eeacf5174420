"""The `planicp` command line."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from . import __version__, synthetic


def _demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    run_demo(
        plan_path=args.plan,
        resolution=args.resolution,
        duration=args.duration,
        seed=args.seed,
        out=args.out,
        stream=sys.stdout,
    )
    return 0


def _plan(args: argparse.Namespace) -> int:
    import numpy as np

    from .plan_figure import plot_plan_overlay
    from .plan_map import PlanMap

    source = Path(args.image)
    suffix = source.suffix.lower()
    if suffix in (".yaml", ".yml"):
        plan = PlanMap.from_ros_map(source, cache=not args.no_cache)
    elif suffix == ".json":
        plan = PlanMap.from_house_expo(source, spacing=args.spacing)
    elif suffix == ".dxf":
        plan = PlanMap.from_dxf(source, args.layer or None, spacing=args.spacing)
    else:
        if args.resolution is None:
            raise ValueError("--resolution (metres per pixel) is required for an image plan")
        plan = PlanMap.from_image(
            source,
            args.resolution,
            tuple(args.origin),
            threshold=args.threshold,
            open_px=args.open_px,
            close_px=args.close_px,
            cache=not args.no_cache,
        )
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    points_path = out / "wall_points.csv"
    np.savetxt(points_path, plan.points, delimiter=",", header="x_m,y_m", comments="", fmt="%.6f")
    overlay_path = out / "overlay.png"
    plot_plan_overlay(plan, title=source.name).savefig(overlay_path)
    yaml_path = plan.to_ros_map(out / "plan.yaml")
    xmin, ymin, xmax, ymax = plan.extent
    print(f"{source}: {len(plan)} wall points, extent x {xmin:.2f}..{xmax:.2f} m, y {ymin:.2f}..{ymax:.2f} m "
          f"({xmax - xmin:.2f} x {ymax - ymin:.2f} m){' (from cache)' if plan.from_cache else ''}")
    print(f"wrote {points_path}, {overlay_path}, {yaml_path} (+ {yaml_path.with_suffix('.pgm').name})")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for documentation and tests)."""
    parser = argparse.ArgumentParser(
        prog="planicp",
        description="Localize a 2D-LIDAR robot against the floor plan of its building.",
    )
    parser.add_argument("--version", action="version", version=f"planicp {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser(
        "demo",
        help="the drift experiment: a simulated robot whose odometry drifts, localized against the plan",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    demo.add_argument("--plan", type=Path, default=None, help="plan image or ROS map YAML (default: shipped office)")
    demo.add_argument("--resolution", type=float, default=None, help="metres per pixel of --plan IMAGE")
    demo.add_argument("--duration", type=float, default=300.0, help="simulated seconds")
    demo.add_argument("--seed", type=int, default=0, help="seed of furniture, route, noise")
    demo.add_argument("--out", type=Path, default=Path("planicp-demo"), help="output folder")
    demo.set_defaults(func=_demo)
    plan = sub.add_parser(
        "plan",
        help="extract wall points from a plan; write the points, an overlay figure and a ROS map",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    plan.add_argument("image", help="plan image (PNG, JPG, PGM, BMP), ROS map YAML, HouseExpo JSON or DXF")
    plan.add_argument("--resolution", type=float, help="metres per pixel (images; a YAML has its own)")
    plan.add_argument("--origin", type=float, nargs=3, default=(0.0, 0.0, 0.0), metavar=("X", "Y", "YAW"),
                      help="pose of the image's lower-left corner in the map frame (m, m, rad)")
    plan.add_argument("--threshold", type=int, default=None, help="wall grey level 1..255 (default: Otsu)")
    plan.add_argument("--open-px", type=int, default=0, help="remove dark specks up to this many pixels")
    plan.add_argument("--close-px", type=int, default=0, help="close wall gaps up to this many pixels")
    plan.add_argument("--no-cache", action="store_true", help="do not read or write the plan cache")
    plan.add_argument("--layer", action="append", default=[], help="DXF layer holding walls (repeatable)")
    plan.add_argument("--spacing", type=float, default=0.02, help="point spacing for vector plans, metres")
    plan.add_argument("--out", type=Path, required=True, help="output folder")
    plan.set_defaults(func=_plan)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `planicp` command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code: int = args.func(args)
    except (ValueError, TypeError, OSError) as exc:
        print(f"planicp {args.command}: error: {exc}", file=sys.stderr)
        return 2
    return code


if __name__ == "__main__":
    sys.exit(main())
