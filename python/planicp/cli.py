"""The `planicp` command line."""

from __future__ import annotations

import argparse
import io
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from . import __version__
from .io.atomic_files import write_atomically


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

    from .plans.plan_figure import plot_drawing_overlay, plot_plan_overlay
    from .plans.plan_loading import plan_layers, read_plan_file
    from .plans.plan_raster import load_rgb

    source = Path(args.image)
    if args.list_layers:
        for line in plan_layers(source, page=args.page):
            print(line)
        return 0
    if args.out is None:
        raise ValueError("planicp plan needs --out FOLDER (or --list-layers to list a drawing's layers)")
    loaded = read_plan_file(
        source,
        resolution=args.resolution,
        origin=args.origin,
        cache=not args.no_cache,
        spacing=args.spacing,
        layers=args.layer,
        scale=args.scale,
        page=args.page,
        storey=_storey(args.storey),
        cut_height=args.cut_height,
        raster=args.raster,
        explain=True,
        threshold=args.threshold,
        open_px=args.open_px,
        close_px=args.close_px,
        walls=args.walls,
    )
    plan = loaded.plan
    for note in loaded.notes:
        print(f"{source.name}: {note}")
    out: Path = args.out
    points_path, overlay_path = out / "wall_points.csv", out / "overlay.png"
    _refuse_to_overwrite(_input_files(source), [points_path, overlay_path, out / "plan.yaml", out / "plan.pgm"])
    out.mkdir(parents=True, exist_ok=True)
    points_csv, overlay_png = io.BytesIO(), io.BytesIO()
    np.savetxt(points_csv, plan.points, delimiter=",", header="x_m,y_m", comments="", fmt="%.6f")
    if loaded.drawing is not None:  # an image: the decisions drawn on the drawing itself
        figure = plot_drawing_overlay(load_rgb(source), loaded.drawing, plan.raster, title=source.name)
    else:
        figure = plot_plan_overlay(plan, title=source.name)
    figure.savefig(overlay_png, format="png")
    write_atomically(points_path, points_csv.getvalue())
    write_atomically(overlay_path, overlay_png.getvalue())
    yaml_path = plan.to_ros_map(out / "plan.yaml")
    xmin, ymin, xmax, ymax = plan.extent
    print(
        f"{source}: {len(plan)} wall points, extent x {xmin:.2f}..{xmax:.2f} m, y {ymin:.2f}..{ymax:.2f} m "
        f"({xmax - xmin:.2f} x {ymax - ymin:.2f} m){' (from cache)' if plan.from_cache else ''}"
    )
    print(f"wrote {points_path}, {overlay_path}, {yaml_path} (+ {yaml_path.with_suffix('.pgm').name})")
    return 0


def _storey(value: str | None) -> str | int | None:
    """--storey: a number from 1, or a storey's name."""
    return int(value) if value is not None and value.isdigit() else value


def _input_files(source: Path) -> list[Path]:
    """The files a plan is read from: `source`, and for a map_server YAML the image it names."""
    files = [source]
    if source.suffix.lower() in (".yaml", ".yml") and source.is_file():
        from .io.yaml_documents import read_yaml_file

        try:
            meta = read_yaml_file(source, str(source))
        except (ValueError, OSError):
            return files
        if isinstance(meta, dict) and isinstance(meta.get("image"), str):
            files.append(source.parent / meta["image"])
    return files


def _refuse_to_overwrite(inputs: list[Path], outputs: list[Path]) -> None:
    """Raises ValueError when an output would be written over an input (after symlinks)."""
    sources = {p.resolve() for p in inputs if p.exists()}
    for output in outputs:
        if output.resolve() in sources:
            raise ValueError(
                f"{output} is an input of this command ({output.resolve()}); it would be written "
                f"over: give another --out folder"
            )


def _read_log(args: argparse.Namespace) -> Any:
    from .io import open_log

    options: dict[str, Any] = {}
    path = Path(args.log)
    if path.is_dir() or path.suffix == ".bag":
        options = {"scan_topic": args.scan_topic, "odom_topic": args.odom_topic or None}
    elif args.laser:
        options = {"laser": args.laser}
    log = open_log(path, **options)
    skipped = ", ".join(f"{n} {kind}" for kind, n in sorted(log.skipped.items()))
    print(f"{path}: {len(log)} scans{f' (skipped: {skipped})' if skipped else ''}")
    return log


def _icp_changes(args: argparse.Namespace) -> dict[str, Any]:
    """The changes the options make to the `Localizer`'s default ICP settings for the plan."""
    return {} if args.max_distance is None else {"max_correspondence_distance": args.max_distance}


def _replay(args: argparse.Namespace) -> int:
    from .evaluation.log_replay import track_log
    from .evaluation.replay_outputs import print_summary, write_outputs
    from .mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid
    from .plans.plan_loading import load_plan
    from .progress import progress_bar
    from .tracking.icp_config import IcpConfig

    if args.out_bag is not None:  # before the long part: a missing rosbags or an existing bag
        from .ros.estimate_bag import refuse_existing_bag

        refuse_existing_bag(args.out_bag)  # the log itself exists, so it is never written over
    plan = load_plan(args.plan, resolution=args.resolution, origin=args.origin)
    log = _read_log(args)
    grid = None if args.no_eog else EnhancedOccupancyGrid(plan, args.eog_resolution)
    tracked = track_log(
        log,
        plan,
        initial_pose=args.initial_pose,
        config=IcpConfig.for_tracking(plan, **_icp_changes(args)),
        grid=grid,
        progress=progress_bar(sys.stdout, len(log), "scans"),
    )
    print()
    extra = {"log": str(args.log), "plan": str(args.plan), "skipped": log.skipped, "bad_lines": len(log.bad_lines)}
    metrics = write_outputs(tracked, plan, grid, args.out, extra)
    print_summary(metrics, args.out, sys.stdout)
    if args.out_bag is not None:
        _write_estimate_bag(args, tracked, plan, grid, log)
    return 0


def _write_estimate_bag(args: argparse.Namespace, tracked: Any, plan: Any, grid: Any, log: Any) -> None:
    """--out-bag: the poses, map -> odom, the plan and the EOG as a ROS 2 bag (`ros.estimate_bag`)."""
    from .ros.estimate_bag import write_estimate_bag
    from .ros.plan_grid import plan_occupancy_grid

    params = getattr(log, "params", {})
    mounts = {f.laser_pose for f in log}
    path = write_estimate_bag(
        args.out_bag,
        tracked,
        plan=plan_occupancy_grid(plan, args.eog_resolution),
        eog=grid.to_occupancy_grid() if grid is not None else None,
        laser_pose=mounts.pop() if len(mounts) == 1 else None,
        storage=args.bag_storage,
        base_frame=params.get("base_frame", "base_link"),
        laser_frame=params.get("laser_frame", "laser"),
    )
    print(f"wrote {path} (ROS 2 bag, {args.bag_storage}: /amcl_pose, /tf, /tf_static, /map, /eog)")


def _evaluate_log(args: argparse.Namespace) -> int:
    from .evaluation.log_evaluation import evaluate_log
    from .evaluation.replay_outputs import print_summary, write_outputs
    from .progress import progress_bar

    log = _read_log(args)
    evaluation = evaluate_log(
        log,
        resolution=args.resolution,
        min_hits=args.min_hits,
        odometry=args.odometry,
        seed=args.seed,
        icp=_icp_changes(args),
        progress=progress_bar(sys.stdout, (len(log) + 1) // 2, "scans"),
    )
    print()
    plan = evaluation.plan
    args.out.mkdir(parents=True, exist_ok=True)
    plan.to_ros_map(args.out / "plan.yaml")
    extra = {
        "log": str(args.log),
        "protocol": {
            "plan_scans": evaluation.plan_scans,
            "tracked_scans": evaluation.tracked_scans,
            "scans_without_reference": evaluation.skipped_scans,
            "plan_resolution_m": args.resolution,
            "min_hits": args.min_hits,
            "odometry": args.odometry,
            "seed": args.seed,
            "max_correspondence_distance_m": evaluation.config.max_correspondence_distance,
        },
    }
    metrics = write_outputs(evaluation.tracked, plan, evaluation.grid, args.out, extra)
    print(
        f"plan drawn from {evaluation.plan_scans} scans ({len(plan)} wall points, plan.yaml); "
        f"tracked the other {evaluation.tracked_scans} with {args.odometry} odometry"
    )
    print_summary(metrics, args.out, sys.stdout)
    return 0


def _sweep(args: argparse.Namespace) -> int:
    import shlex

    from .sweep import load_study, run_study

    study, base = load_study(args.config)
    try:
        result = run_study(
            study,
            args.out,
            base_dir=base,
            ray=args.ray is not None,
            ray_address=args.ray or None,
            workers=args.workers,
            retry_failed=args.retry_failed,
            stream=sys.stdout,
            command="planicp " + shlex.join(args.argv),
        )
    except KeyboardInterrupt:
        print(
            f"\nplanicp sweep: interrupted; the finished runs are recorded in {args.out}: run the same "
            "command again to finish the study",
            file=sys.stderr,
        )
        return 130
    except RuntimeError as exc:  # a worker process died
        print(f"planicp sweep: error: {exc}", file=sys.stderr)
        return 1
    if result.failed:
        print(
            f"planicp sweep: {result.failed} of {result.total} runs failed (their errors are recorded in "
            f"{args.out}); run the same command with --retry-failed to run them again",
            file=sys.stderr,
        )
        return 1
    return 0 if result.executed + result.skipped == result.total else 1


def _add_log_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("log", help="CARMEN log (.log/.clf[.gz]), g2o file, ROS 1 .bag or ROS 2 bag folder")
    parser.add_argument("--scan-topic", default="/scan", help="LaserScan topic (bags)")
    parser.add_argument("--odom-topic", default="/odom", help="Odometry topic (bags; '' for none)")
    parser.add_argument(
        "--laser",
        choices=("FLASER", "RLASER", "ROBOTLASER1"),
        default=None,
        help="which laser of a CARMEN log (default: the first one found)",
    )
    parser.add_argument(
        "--max-distance",
        type=float,
        default=None,
        help="ICP max correspondence distance, metres (default: the Localizer's, 0.25)",
    )
    parser.add_argument("--out", type=Path, required=True, help="output folder")


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
    plan.add_argument(
        "image", help="plan image (PNG, JPG, PGM, BMP), ROS map YAML, HouseExpo JSON, DXF, PDF, SVG or IFC"
    )
    plan.add_argument(
        "--resolution",
        type=float,
        help="metres per pixel (images; without it, read from the drawing's room labels by OCR, with RapidOCR; "
        "rasterises a HouseExpo JSON; a YAML has its own); metres per point of a PDF, per pixel of an SVG",
    )
    plan.add_argument(
        "--origin",
        type=float,
        nargs=3,
        default=(0.0, 0.0, 0.0),
        metavar=("X", "Y", "YAW"),
        help="pose of the image's lower-left corner in the map frame (m, m, rad)",
    )
    plan.add_argument(
        "--walls",
        choices=("drawing", "all-dark"),
        default="drawing",
        help="images: 'drawing' keeps the walls of a drawing and drops text, symbols, door swings, hatching, "
        "fills; 'all-dark' makes every dark pixel a wall (clean wall images, maps drawn as images)",
    )
    plan.add_argument("--threshold", type=int, default=None, help="wall grey level 1..255 (default: Otsu)")
    plan.add_argument("--open-px", type=int, default=0, help="remove dark specks up to this many pixels")
    plan.add_argument("--close-px", type=int, default=0, help="close wall gaps up to this many pixels")
    plan.add_argument("--no-cache", action="store_true", help="do not read or write the plan cache")
    plan.add_argument(
        "--layer",
        action="append",
        default=[],
        help="layer holding walls (repeatable): a DXF layer, a PDF layer, an SVG class, id or layer",
    )
    plan.add_argument(
        "--list-layers", action="store_true", help="list the drawing's layers (DXF, PDF, SVG) or storeys (IFC) and stop"
    )
    plan.add_argument(
        "--scale", default=None, help="print scale of a PDF or SVG: '1:100', '1\"=24\\'' (default: the PDF's own)"
    )
    plan.add_argument("--page", type=int, default=1, help="page of a PDF, from 1")
    plan.add_argument(
        "--raster",
        type=float,
        nargs="?",
        const=0.025,
        default=False,
        metavar="M_PER_PX",
        help="read a PDF page as an image (a scanned drawing), rendered at M_PER_PX metres per pixel (0.025)",
    )
    plan.add_argument("--storey", default=None, help="IFC storey: name or number from 1 (default: lowest with walls)")
    plan.add_argument("--cut-height", type=float, default=1.0, help="IFC: cut the walls this high above the floor, m")
    plan.add_argument("--spacing", type=float, default=0.02, help="point spacing for vector plans, metres")
    plan.add_argument("--out", type=Path, default=None, help="output folder (required unless --list-layers)")
    plan.set_defaults(func=_plan)
    replay = sub.add_parser(
        "replay",
        help="localize every scan of a recorded log or bag against a plan; write trajectory, figures, EOG",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    _add_log_options(replay)
    replay.add_argument("--plan", type=Path, required=True, help="plan image, ROS map YAML, HouseExpo JSON or DXF")
    replay.add_argument("--resolution", type=float, default=None, help="metres per pixel of a plan image")
    replay.add_argument(
        "--origin",
        type=float,
        nargs=3,
        default=(0.0, 0.0, 0.0),
        metavar=("X", "Y", "YAW"),
        help="pose of a plan image's lower-left corner in the map frame (m, m, rad)",
    )
    replay.add_argument(
        "--initial-pose",
        type=float,
        nargs=3,
        default=None,
        metavar=("X", "Y", "YAW"),
        help="robot pose in the map at the first scan (default: the log's first reference pose)",
    )
    replay.add_argument("--eog-resolution", type=float, default=0.05, help="cell size of the EOG, metres")
    replay.add_argument("--no-eog", action="store_true", help="do not build the enhanced occupancy grid")
    replay.add_argument(
        "--out-bag",
        type=Path,
        default=None,
        metavar="PATH",
        help="also write a new ROS 2 bag folder with the poses (/amcl_pose), map->odom (/tf), the plan (/map) "
        "and the EOG (/eog), for RViz or Foxglove; needs pip install 'planicp[ros]'",
    )
    replay.add_argument(
        "--bag-storage", choices=("sqlite3", "mcap"), default="sqlite3", help="storage of the --out-bag bag"
    )
    replay.set_defaults(func=_replay)
    evaluate = sub.add_parser(
        "evaluate-log",
        help="score planicp on a log with reference poses: plan from the even scans, track the odd ones",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    _add_log_options(evaluate)
    evaluate.add_argument("--resolution", type=float, default=0.05, help="pixel size of the plan drawn, metres")
    evaluate.add_argument("--min-hits", type=int, default=2, help="scan end points that make a pixel a wall")
    evaluate.add_argument(
        "--odometry",
        choices=("synthetic", "log"),
        default="synthetic",
        help="synthetic: reference motion + thesis drift + noise; log: the log's own odometry",
    )
    evaluate.add_argument("--seed", type=int, default=0, help="seed of the synthetic odometry noise")
    evaluate.set_defaults(func=_evaluate_log)
    sweep = sub.add_parser(
        "sweep",
        help="a study of many simulated runs (plans x seeds x clutter x sensors x drift x ICP) into one table",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    sweep.add_argument("config", type=Path, help="study YAML (see planicp.sweep.study)")
    sweep.add_argument("--out", type=Path, required=True, help="output folder; an interrupted study there is resumed")
    sweep.add_argument("--workers", type=int, default=None, help="local processes (default: one per CPU)")
    sweep.add_argument(
        "--ray",
        nargs="?",
        const="",
        default=None,
        metavar="ADDRESS",
        help="run on Ray: without ADDRESS Ray's default (RAY_ADDRESS, else a cluster "
        "started here with 'ray start', else a new local instance); or ADDRESS: "
        "'local', 'auto', 'ray://host:10001'; needs pip install 'planicp[cluster]'",
    )
    sweep.add_argument("--retry-failed", action="store_true", help="run the runs recorded as failed again")
    sweep.set_defaults(func=_sweep)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `planicp` command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = [str(a) for a in (sys.argv[1:] if argv is None else argv)]
    try:
        code: int = args.func(args)
    except (ValueError, TypeError, OSError, ImportError) as exc:
        print(f"planicp {args.command}: error: {exc}", file=sys.stderr)
        return 2
    return code


if __name__ == "__main__":
    sys.exit(main())
