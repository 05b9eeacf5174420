#!/usr/bin/env python3
"""The Intel evaluation made harder (issue 7): planicp vs ICP trackers vs MRPT pf-localization.

    /tmp/dev-harder/bin/python benches/intel_harder.py --json /tmp/intel_harder.json

(`--peers-venv /tmp/peers-venv` is the default: its site-packages are appended to sys.path for
small_gicp, Open3D and KISS-ICP, after the running interpreter's own packages, so the planicp
under test is the one installed in the running venv. `--no-mrpt` skips pf-localization.)

Inputs, exactly as `planicp.evaluation.log_evaluation.evaluate_log` builds them (seed 0): the plan drawn at
5 cm from the even-numbered scans of `intel-corrected.log.gz` at their reference poses, the
odd-numbered scans tracked from the first odd scan's reference pose with odometry synthesised by
`synthesise_odometry(times, reference, OdometryDrift(), default_rng(seed))`. Then four variants:

* baseline: those inputs;
* gap: the tracked scans inside two 30 s windows are dropped while odometry keeps integrating
  (the first scan after a window gets the odometry pose accumulated over the whole window). The
  windows are chosen by a fixed rule, not by trying trackers: the 30 s span with the longest path
  of the reference trajectory, and the one with the most turning;
* steps: 10 degree heading errors (random sign) added to `--steps` odometry steps at seeded random
  scans (at least 30 scans apart, away from the gap windows); the error stays in the odometry
  afterwards, as a wheel slip would;
* gap+steps: both.

Trackers on each variant, all from the same start pose, the same scans (base frame) and the same
odometry: odometry alone; planicp (`track_log` with the default `Localizer`); the ICP peers of
`../shared/bench/peers.py` (imported by path) as trackers: initial guess = last pose composed with
the odometry motion since the last scan, then one alignment to the plan's wall points (max
correspondence distance 0.25 m, 30 iterations); and MRPT pf-localization (`benches/mrpt_pf.py`;
3000 particles, run `--mrpt-runs` times since it seeds itself from the clock; its time per scan is
the filter's own step time from `exec_times.txt`).
Scored on the scans each variant keeps: translation ATE (RMS), worst error, share of scans over
0.3 m ("lost"), time per scan. Not a test: pytest does not collect `benches/`.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from peers_module import DEFAULT_PEERS_FILE, load_peers_module  # benches/ is on sys.path

HERE = Path(__file__).resolve().parent
DEFAULT_LOG = HERE.parent.parent / "shared" / "data" / "logs" / "intel-corrected.log.gz"
DEFAULT_PEERS = DEFAULT_PEERS_FILE
GAP_S = 30.0
STEP_ERROR_DEG = 10.0
PEER_NAMES = ("small_gicp_icp", "open3d", "kiss_icp", "numpy")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument("--log", type=Path, default=DEFAULT_LOG)
    p.add_argument("--peers-file", type=Path, default=DEFAULT_PEERS)
    p.add_argument("--peers-venv", type=Path, default=Path("/tmp/peers-venv"))
    p.add_argument("--seed", type=int, default=0, help="odometry noise seed (evaluate_log's default)")
    p.add_argument("--step-seed", type=int, default=7, help="seed placing the 10 degree odometry errors")
    p.add_argument("--steps", type=int, default=6, help="odometry steps given a 10 degree heading error")
    p.add_argument("--max-corr", type=float, default=0.25)
    p.add_argument("--max-iter", type=int, default=30)
    p.add_argument("--variants", default="baseline,gap,steps,gap+steps")
    p.add_argument("--no-mrpt", action="store_true")
    p.add_argument(
        "--mrpt-runs", type=int, default=3, help="pf-localization runs per variant (it seeds itself from the clock)"
    )
    p.add_argument("--mrpt-dir", type=Path, help="keep MRPT's inputs and outputs here (default: temporary)")
    p.add_argument("--json", type=Path)
    return p.parse_args(argv)


# --------------------------------------------------------------------------- inputs


def evaluation_inputs(log_path: Path, seed: int) -> tuple[Any, list[Any]]:
    """(plan, odd frames with synthetic odometry) as `evaluate_log` builds them."""
    from planicp.evaluation.log_evaluation import OdometryDrift, plan_from_scans, synthesise_odometry
    from planicp.io import open_log

    usable = [f for f in open_log(log_path) if f.reference is not None]
    even, odd = usable[0::2], usable[1::2]
    plan = plan_from_scans(even, 0.05, 2)
    times = np.array([f.time for f in odd])
    reference = np.array([f.reference for f in odd], dtype=np.float64)
    poses = synthesise_odometry(times, reference, OdometryDrift(), np.random.default_rng(seed))
    frames = [replace(f, odometry=(float(p[0]), float(p[1]), float(p[2]))) for f, p in zip(odd, poses)]
    return plan, frames


def gap_windows(frames: list[Any]) -> list[dict[str, Any]]:
    """Two 30 s windows: the span with the longest reference path, and the one with the most turning
    (not overlapping the first). Each drops the scans strictly between scan i and the first scan at
    least 30 s after it."""
    t = np.array([f.time for f in frames])
    ref = np.array([f.reference for f in frames])
    dist = np.r_[0.0, np.cumsum(np.hypot(*np.diff(ref[:, :2], axis=0).T))]
    turn = np.r_[0.0, np.cumsum(np.abs((np.diff(ref[:, 2]) + math.pi) % (2 * math.pi) - math.pi))]
    spans = []
    for i in range(len(t)):
        j = int(np.searchsorted(t, t[i] + GAP_S))
        if j >= len(t):
            break
        spans.append((i, j, dist[j] - dist[i], turn[j] - turn[i]))
    first = max(spans, key=lambda s: s[2])
    second = max((s for s in spans if s[1] <= first[0] or s[0] >= first[1]), key=lambda s: s[3])
    out = []
    for (i, j, d, r), rule in ((first, "longest path"), (second, "most turning")):
        out.append(
            {
                "rule": rule,
                "last_scan_before": i,
                "first_scan_after": j,
                "dropped_scans": list(range(i + 1, j)),
                "from_t": float(t[i]),
                "to_t": float(t[j]),
                "from_t_rel": float(t[i] - t[0]),
                "seconds_without_scan": float(t[j] - t[i]),
                "path_m": float(d),
                "turn_deg": math.degrees(r),
            }
        )
    return out


def step_errors(frames: list[Any], windows: list[dict[str, Any]], count: int, seed: int) -> list[dict[str, Any]]:
    """`count` scans whose odometry step (from the previous scan) gets a +-10 degree heading error."""
    rng = np.random.default_rng(seed)
    n = len(frames)
    banned = set()
    for w in windows:
        banned.update(range(w["last_scan_before"] - 5, w["first_scan_after"] + 6))
    chosen: list[int] = []
    while len(chosen) < count:
        k = int(rng.integers(10, n - 10))
        if k in banned or any(abs(k - c) < 30 for c in chosen):
            continue
        chosen.append(k)
    chosen.sort()
    signs = rng.choice([-1.0, 1.0], size=count)
    return [
        {
            "scan": k,
            "t": float(frames[k].time),
            "t_rel": float(frames[k].time - frames[0].time),
            "error_deg": float(s * STEP_ERROR_DEG),
        }
        for k, s in zip(chosen, signs)
    ]


def with_step_errors(frames: list[Any], errors: list[dict[str, Any]]) -> list[Any]:
    """The frames with each listed odometry step's heading turned by its error (and every later
    odometry pose composed through the erroneous step)."""
    from planicp.se2 import between, compose

    extra = {e["scan"]: math.radians(e["error_deg"]) for e in errors}
    out = [frames[0]]
    odom = frames[0].odometry
    for k in range(1, len(frames)):
        step = between(frames[k - 1].odometry, frames[k].odometry)
        step = (step[0], step[1], step[2] + extra.get(k, 0.0))
        odom = compose(odom, step)
        out.append(replace(frames[k], odometry=odom))
    return out


def make_variants(
    frames: list[Any], windows: list[dict[str, Any]], errors: list[dict[str, Any]]
) -> dict[str, list[Any]]:
    dropped = {k for w in windows for k in w["dropped_scans"]}
    stepped = with_step_errors(frames, errors)

    def gapped(fs: list[Any]) -> list[Any]:
        return [f for k, f in enumerate(fs) if k not in dropped]

    return {"baseline": frames, "gap": gapped(frames), "steps": stepped, "gap+steps": gapped(stepped)}


# --------------------------------------------------------------------------- trackers


def score(estimate: NDArray[np.float64], frames: list[Any], seconds: float | None) -> dict[str, Any]:
    from planicp.evaluation.trajectory_metrics import error_summary, pose_errors

    reference = np.array([f.reference for f in frames], dtype=np.float64)
    out: dict[str, Any] = dict(error_summary(estimate, reference))
    position, _ = pose_errors(estimate, reference)
    out["first_lost_scan"] = int(np.argmax(position > 0.3)) if (position > 0.3).any() else None
    out["ms_per_scan"] = None if seconds is None else 1e3 * seconds / len(frames)
    return out


def odometry_alone(frames: list[Any]) -> NDArray[np.float64]:
    from planicp.se2 import between, compose

    start, origin = frames[0].reference, frames[0].odometry
    return np.array([compose(start, between(origin, f.odometry)) for f in frames])


def run_planicp(frames: list[Any], plan: Any) -> tuple[NDArray[np.float64], float, dict[str, Any]]:
    from planicp.evaluation.log_replay import track_log

    tracked = track_log(frames, plan)
    extra = {"accepted_share": float(tracked.accepted.mean())}
    return tracked.estimate, tracked.seconds, extra


def run_peer(peer: Any, frames: list[Any]) -> tuple[NDArray[np.float64], float]:
    from planicp.se2 import between, compose

    pose = frames[0].reference
    scans = [np.ascontiguousarray(f.points()) for f in frames]
    peer.align(scans[0], pose)  # warm-up
    out = np.zeros((len(frames), 3))
    spent = 0.0
    for k, f in enumerate(frames):
        guess = pose if k == 0 else compose(pose, between(frames[k - 1].odometry, f.odometry))
        began = time.perf_counter()
        x, y, yaw = peer.align(scans[k], guess)
        spent += time.perf_counter() - began
        pose = (float(x), float(y), float(yaw))
        out[k] = pose
    return out, spent


# --------------------------------------------------------------------------- report


def print_table(name: str, rows: dict[str, dict[str, Any]], scans: int) -> None:
    print(f"\n## {name} ({scans} scans scored)")
    head = f"| {'tracker':<26} | {'ATE RMS':>9} | {'worst':>8} | {'lost > 0.3 m':>12} | {'time per scan':>13} |"
    print(head)
    print("|" + "|".join("-" * (len(c)) for c in head.split("|")[1:-1]) + "|")
    for tracker, r in rows.items():
        if "error" in r:
            print(f"| {tracker:<26} | failed: {r['error'][:80]}")
            continue
        ms = "-" if r["ms_per_scan"] is None else f"{r['ms_per_scan']:.2f} ms"
        print(
            f"| {tracker:<26} | {r['ate_rms_m'] * 100:>7.1f} cm | {r['position_max_m']:>6.2f} m "
            f"| {r['lost_share'] * 100:>10.1f} % | {ms:>13} |"
        )


def git_commit() -> str:
    try:
        return subprocess.run(
            ["git", "rev-parse", "HEAD"], cwd=HERE, capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "?"


def main(argv: list[str] | None = None) -> None:
    args = parse_args(argv)
    site = next(iter(sorted(args.peers_venv.glob("lib/python3*/site-packages"))), None)
    if site is not None and str(site) not in sys.path:
        sys.path.append(str(site))
    import mrpt_pf  # noqa: E402  (benches/ is the script's folder, on sys.path)
    import planicp

    peers_mod = load_peers_module(args.peers_file)
    cfg = argparse.Namespace(
        max_corr=args.max_corr, max_iter=args.max_iter, trim=0.8, trim_start=10, threads=1, res=0.05
    )
    plan, frames = evaluation_inputs(args.log, args.seed)
    windows = gap_windows(frames)
    errors = step_errors(frames, windows, args.steps, args.step_seed)
    variants = make_variants(frames, windows, errors)
    print(
        f"# planicp {planicp.__file__} (commit {git_commit()[:10]}); plan {len(plan)} wall points; "
        f"{len(frames)} tracked scans"
    )
    for w in windows:
        print(
            f"# gap ({w['rule']}): scans {w['dropped_scans'][0]}..{w['dropped_scans'][-1]} dropped, "
            f"{w['seconds_without_scan']:.1f} s without a scan from t={w['from_t']:.2f} "
            f"(+{w['from_t_rel']:.1f} s), robot moved {w['path_m']:.2f} m and turned {w['turn_deg']:.0f} deg"
        )
    print(
        "# odometry step errors: "
        + ", ".join(f"scan {e['scan']} (t={e['t']:.2f}) {e['error_deg']:+.0f} deg" for e in errors)
    )
    peers, skipped = peers_mod.load_peers(list(PEER_NAMES), cfg)
    for key, why in skipped.items():
        print(f"# skipped peer {key}: {why}")
    for peer in peers:
        peer.build(np.ascontiguousarray(plan.points))
    mrpt_missing = None if args.no_mrpt else mrpt_pf.available()
    results: dict[str, Any] = {}
    for name in [v.strip() for v in args.variants.split(",") if v.strip()]:
        fs = variants[name]
        rows: dict[str, dict[str, Any]] = {}
        rows["odometry alone"] = score(odometry_alone(fs), fs, None)
        est, seconds, extra = run_planicp(fs, plan)
        rows["planicp (Localizer)"] = {**score(est, fs, seconds), **extra}
        for peer in peers:
            est, seconds = run_peer(peer, fs)
            rows[peer.name] = score(est, fs, seconds)
        if not args.no_mrpt:
            if mrpt_missing:
                rows["MRPT pf-localization"] = {"error": mrpt_missing}
            else:
                for run in range(1, args.mrpt_runs + 1):
                    label = f"MRPT pf-localization #{run}"
                    with tempfile.TemporaryDirectory() as tmp:
                        work = (args.mrpt_dir or Path(tmp)) / f"{name.replace('+', '_')}_{run}"
                        try:
                            pf = mrpt_pf.run(fs, plan, fs[0].reference, work)
                            seconds = float(pf.step_seconds.sum()) if len(pf.step_seconds) else None
                            rows[label] = {**score(pf.estimate, fs, seconds), "wall_seconds": pf.wall_seconds}
                        except (RuntimeError, subprocess.TimeoutExpired) as exc:
                            rows[label] = {"error": str(exc)}
        print_table(name, rows, len(fs))
        results[name] = {"scans": len(fs), "trackers": rows}
    if args.json:
        doc = {
            "command": " ".join([Path(sys.executable).name, *sys.argv]),
            "commit": git_commit(),
            "planicp": str(Path(planicp.__file__).parent),
            "python": platform.python_version(),
            "seed": args.seed,
            "step_seed": args.step_seed,
            "max_corr_m": args.max_corr,
            "max_iter": args.max_iter,
            "gap_windows": windows,
            "step_errors": errors,
            "mrpt_settings": None if args.no_mrpt else vars(mrpt_pf.PfSettings()),
            "peer_versions": {p.name: p.version for p in peers},
            "results": results,
        }
        args.json.write_text(json.dumps(doc, indent=1))
        print(f"\n# wrote {args.json}")


if __name__ == "__main__":
    main()
