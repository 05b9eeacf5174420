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
        seed=args.seed,
        layout=args.layout,
        trials=args.trials,
        offset_m=args.offset,
        offset_deg=args.offset_deg,
        out=args.out,
        stream=sys.stdout,
    )
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
        help="align simulated scans to a generated floor plan and print the errors",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    demo.add_argument("--seed", type=int, default=0, help="seed of the floor, poses and noise")
    demo.add_argument("--layout", choices=synthetic.LAYOUTS, default="office", help="kind of floor")
    demo.add_argument("--trials", type=int, default=100, help="number of scans to align")
    demo.add_argument("--offset", type=float, default=0.2, help="initial-guess offset, metres")
    demo.add_argument("--offset-deg", type=float, default=3.0, help="initial-guess offset, degrees")
    demo.add_argument("--out", type=Path, default=None, help="folder for metrics.json")
    demo.set_defaults(func=_demo)
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
