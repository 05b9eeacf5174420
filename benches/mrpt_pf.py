"""MRPT `pf-localization` (Debian package `mrpt-apps`) run on the same inputs as planicp.

Used by `benches/intel_harder.py`; not a test. The pipeline, all with MRPT 2.5's own tools:

1. The plan: `PlanMap.to_ros_map` writes the plan's wall raster (walls occupied, the rest free; the
   same pixels planicp's wall points come from) as a map_server YAML + PGM, and MRPT's
   `ros-map-yaml2mrpt` turns it into a `.gridmap` (resolution and origin from the YAML).
2. The scans and odometry: a CARMEN log with one `FLASER` line per tracked scan, whose odometry
   fields are the variant's (drifting, gapped, mis-stepped) odometry and whose laser pose is that
   odometry composed with the laser mount, so MRPT recovers the mount as `sensorPose`. MRPT's
   `carmen2rawlog` converts it into an observations-only rawlog (CObservationOdometry +
   CObservation2DRangeScan per scan). MRPT spreads `laser_front_laser_resolution * n` degrees
   over n beams as -aperture/2 + i * aperture/(n-1); the CARMEN 180-beam FLASER has beams at
   -90 + i degrees, so the aperture is written as (n-1) degrees and the mount yaw turned by half a
   beam.
3. `pf-localization CONFIG.ini`: particles start uniform in a box around the start pose, odometry
   increments get MRPT's Gaussian motion model (`[DummyOdometryParams]` minStdXY / minStdPHI: the
   floor of the per-step noise, large enough to cover a 10 degree odometry error), the likelihood
   is the likelihood field on the gridmap. Its "PDF estimation: (x,y,phi deg)" log lines are the
   estimated poses (the particles' mean, one per scan); `exec_times.txt` holds the filter's time
   per step.

Two facts measured with MRPT 2.5.8 (Debian bookworm) that a reader of the numbers should know:

* With `map_file` a `.gridmap`, the `[MetricMap_occupancyGrid_00_likelihoodOpts]` of the .ini
  have no visible effect: a run with `LF_stdHit=5` and `LF_maxCorrsDistance=20` (a flat
  likelihood that cannot track) followed the baseline run to within 8 cm. The observation model is
  whatever the loaded grid carries (MRPT's defaults); the section stays because the app builds its
  grid from it before loading the file.
* pf-localization seeds its random generator from the clock (`getRandomGenerator().randomize()`),
  so two runs on the same inputs differ; the benchmark runs it several times.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from planicp.io import ScanFrame
from planicp.plans.plan_map import PlanMap
from planicp.se2 import compose

TOOLS = ("pf-localization", "carmen2rawlog", "ros-map-yaml2mrpt")


@dataclass(frozen=True)
class PfSettings:
    """The pf-localization settings the benchmark uses (written into its .ini)."""

    particles: int = 3000
    init_xy_m: float = 0.25
    """Half-width of the uniform initial box around the start pose, metres."""
    init_yaw_deg: float = 5.0
    """Half-width of the initial yaw interval, degrees."""
    min_std_xy_m: float = 0.10
    min_std_phi_deg: float = 5.0
    lf_decimation: int = 5
    lf_std_hit_m: float = 0.10
    lf_max_corrs_m: float = 0.30
    """(The three likelihood settings are written to the .ini but, see above, not used by MRPT.)"""


def available() -> str | None:
    """None when every MRPT tool is on PATH, else which one is missing."""
    for tool in TOOLS:
        if shutil.which(tool) is None:
            return f"{tool} not found (apt-get install mrpt-apps)"
    return None


def write_carmen(path: Path, frames: list[ScanFrame]) -> None:
    """The frames as a CARMEN FLASER log with their odometry (see the module documentation)."""
    lines = ["# planicp intel_harder: FLASER lines with the variant's odometry"]
    beams = {f.beams for f in frames}
    if len(beams) != 1:
        raise ValueError(f"MRPT's FLASER reader needs one beam count, got {sorted(beams)}")
    n = beams.pop()
    inc = frames[0].angle_increment
    aperture_deg = math.degrees(inc) * (n - 1)
    lines.append(f"PARAM laser_front_laser_resolution {aperture_deg / n:.12f} nohost 0")
    max_range = frames[0].range_max
    lines.append(f"PARAM robot_front_laser_max {max_range:.3f} nohost 0")
    for f in frames:
        if f.odometry is None:
            raise ValueError("every scan needs odometry")
        # MRPT's first beam is at -aperture/2 relative to the sensor yaw.
        yaw_offset = f.angle_min + aperture_deg * math.pi / 360.0
        mount = (f.laser_pose[0], f.laser_pose[1], f.laser_pose[2] + yaw_offset)
        laser = compose(f.odometry, mount)
        r = np.where(np.isfinite(f.ranges), f.ranges, max_range + 1.0)
        text = " ".join(f"{v:.3f}" for v in r)
        o = f.odometry
        lines.append(
            f"FLASER {n} {text} {laser[0]:.6f} {laser[1]:.6f} {laser[2]:.6f} "
            f"{o[0]:.6f} {o[1]:.6f} {o[2]:.6f} {f.time:.6f} bench {f.time:.6f}"
        )
    path.write_text("\n".join(lines) + "\n")


def write_ini(
    path: Path, gridmap: Path, rawlog: Path, out_prefix: Path, start: tuple[float, float, float], s: PfSettings
) -> None:
    """The pf-localization configuration."""
    x, y, yaw = start
    path.write_text(f"""# planicp intel_harder: MRPT pf-localization on the Intel evaluation inputs
[KLD_options]
KLD_binSize_PHI_deg=5
KLD_binSize_XY=0.05
KLD_delta=0.01
KLD_epsilon=0.01
KLD_maxSampleSize={s.particles}
KLD_minSampleSize={s.particles}
KLD_minSamplesPerBin=0

[PF_options]
PF_algorithm=0
resamplingMethod=0
adaptiveSampleSize=0
pfAuxFilterOptimal_MaximumSearchSamples=10
BETA=0.5
sampleSize=1

[DummyOdometryParams]
minStdXY={s.min_std_xy_m}
minStdPHI={s.min_std_phi_deg}

[LocalizationExperiment]
use_3D_poses=false
map_file={gridmap}
rawlog_file={rawlog}
logOutput_dir={out_prefix}
3DSceneFrequency=-1
experimentRepetitions=1
particles_count={s.particles}
init_PDF_mode=1
init_PDF_min_x={x - s.init_xy_m}
init_PDF_max_x={x + s.init_xy_m}
init_PDF_min_y={y - s.init_xy_m}
init_PDF_max_y={y + s.init_xy_m}
init_PDF_min_yaw_deg={math.degrees(yaw) - s.init_yaw_deg}
init_PDF_max_yaw_deg={math.degrees(yaw) + s.init_yaw_deg}
SHOW_PROGRESS_3D_REAL_TIME=false

[MetricMap]
occupancyGrid_count=1
gasGrid_count=0
landmarksMap_count=0
pointsMap_count=0
beaconMap_count=0
likelihoodMapSelection=-1
enableInsertion_pointsMap=0
enableInsertion_landmarksMap=0
enableInsertion_gridMaps=0
enableInsertion_gasGridMaps=0
enableInsertion_beaconMap=0

[MetricMap_occupancyGrid_00_creationOpts]
resolution=0.05

[MetricMap_occupancyGrid_00_insertOpts]
mapAltitude=0
useMapAltitude=0
maxDistanceInsertion=15
maxOccupancyUpdateCertainty=0.55
considerInvalidRangesAsFreeSpace=0
minLaserScanNoiseStd=0.001

[MetricMap_occupancyGrid_00_likelihoodOpts]
likelihoodMethod=4
LF_decimation={s.lf_decimation}
LF_stdHit={s.lf_std_hit_m}
LF_maxCorrsDistance={s.lf_max_corrs_m}
LF_zHit=0.95
LF_zRandom=0.05
LF_maxRange=80
LF_alternateAverageMethod=0
enableLikelihoodCache=1
""")


_ESTIMATE = re.compile(r"PDF estimation:\s*\(([-+0-9.eE]+),([-+0-9.eE]+),([-+0-9.eE]+)deg\)")


def parse_estimates(text: str) -> NDArray[np.float64]:
    """(N, 3) poses (x, y, yaw radians) from pf-localization's "PDF estimation" log lines."""
    rows = [(float(a), float(b), math.radians(float(c))) for a, b, c in _ESTIMATE.findall(text)]
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


@dataclass
class PfRun:
    estimate: NDArray[np.float64]
    step_seconds: NDArray[np.float64]
    wall_seconds: float
    workdir: Path


def run(
    frames: list[ScanFrame],
    plan: PlanMap,
    start: tuple[float, float, float],
    workdir: Path,
    settings: PfSettings | None = None,
    timeout_s: float = 3600.0,
) -> PfRun:
    """Writes the inputs into `workdir`, runs pf-localization, returns one pose per frame.

    Raises:
        RuntimeError: a tool failed, or the number of estimates is not the number of scans.
    """
    s = settings or PfSettings()
    workdir.mkdir(parents=True, exist_ok=True)
    yaml_path = plan.to_ros_map(workdir / "plan.yaml")
    _check(["ros-map-yaml2mrpt", "-q", "-w", "-i", str(yaml_path), "-d", str(workdir)], workdir)
    gridmaps = sorted(workdir.glob("plan*.gridmap*"))
    if not gridmaps:
        raise RuntimeError(f"ros-map-yaml2mrpt wrote no .gridmap into {workdir}")
    carmen = workdir / "scans.log"
    write_carmen(carmen, frames)
    rawlog = workdir / "scans.rawlog"
    _check(["carmen2rawlog", "-q", "-w", "-i", str(carmen), "-o", str(rawlog)], workdir)
    ini = workdir / "pf.ini"
    out_prefix = workdir / "pf_out"
    write_ini(ini, gridmaps[0], rawlog, out_prefix, start, s)
    began = time.perf_counter()
    proc = subprocess.run(
        ["pf-localization", str(ini)],
        cwd=workdir,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=timeout_s,
    )
    wall = time.perf_counter() - began
    (workdir / "pf.stdout").write_text(proc.stdout + proc.stderr)
    if proc.returncode != 0:
        raise RuntimeError(f"pf-localization exited {proc.returncode}: {(proc.stdout + proc.stderr)[-2000:]}")
    est = parse_estimates(proc.stdout + proc.stderr)
    if len(est) != len(frames):
        raise RuntimeError(
            f"pf-localization gave {len(est)} estimates for {len(frames)} scans (see {workdir / 'pf.stdout'})"
        )
    times_files = sorted(workdir.glob("pf_out_*/exec_times.txt"))
    steps = np.loadtxt(times_files[0]).reshape(-1) if times_files else np.array([])
    return PfRun(est, steps, wall, workdir)


def _check(cmd: list[str], cwd: Path) -> None:
    proc = subprocess.run(cmd, cwd=cwd, stdin=subprocess.DEVNULL, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}: {(proc.stdout + proc.stderr)[-2000:]}")
