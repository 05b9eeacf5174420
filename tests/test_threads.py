"""`localize` releases the GIL and is deterministic when called from many threads at once."""

from __future__ import annotations

import math
import threading
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import pytest

from planicp import IcpConfig, IcpResult, Localizer, PlanMap, localize
from planicp import sim as syn

DEG = math.pi / 180.0


@pytest.fixture(scope="module")
def floor() -> Any:
    return syn.generate_floor(11, "diagonal")


@pytest.fixture(scope="module")
def plan(floor: Any) -> PlanMap:
    return PlanMap.from_points(floor.wall_points())


@pytest.fixture(scope="module")
def jobs(floor: Any) -> list[tuple[Any, np.ndarray, tuple[float, float, float], IcpConfig]]:
    rng = np.random.default_rng(2024)
    configs = [IcpConfig(), IcpConfig(subsample=2), IcpConfig(use_visibility=False), IcpConfig(trim_ratio=0.9)]
    out = []
    for i in range(40):
        truth = floor.sample_pose(rng, clearance=0.6)
        pts, _ = syn.simulate_scan(floor, truth, rng)
        guess = syn.perturb_pose(truth, rng, 0.2, 3 * DEG)
        out.append((truth, pts, guess, configs[i % len(configs)]))
    return out


def same(a: IcpResult, b: IcpResult) -> bool:
    return (
        a.pose == b.pose
        and a.converged == b.converged
        and a.iterations == b.iterations
        and a.num_inliers == b.num_inliers
        and a.inlier_ratio == b.inlier_ratio
        and (a.rmse == b.rmse or (math.isnan(a.rmse) and math.isnan(b.rmse)))
        and a.num_target_points == b.num_target_points
        and np.array_equal(a.covariance, b.covariance)
        and np.array_equal(a.inlier_mask, b.inlier_mask)
    )


def test_concurrent_results_are_bitwise_identical_to_serial(plan: PlanMap, jobs: list[Any]) -> None:
    serial = [localize(pts, plan, guess, cfg) for _, pts, guess, cfg in jobs]
    # sanity: these are real alignments, not trivial ones
    good = sum(math.hypot(r.pose[0] - t[0], r.pose[1] - t[1]) < 0.05 for r, (t, *_) in zip(serial, jobs))
    assert good >= 0.85 * len(jobs)
    with ThreadPoolExecutor(max_workers=4) as pool:
        for _ in range(2):
            concurrent = list(pool.map(lambda job: localize(job[1], plan, job[2], job[3]), jobs))
            mismatched = [i for i, (a, b) in enumerate(zip(serial, concurrent)) if not same(a, b)]
            assert not mismatched, mismatched


def test_concurrent_localizers_sharing_one_plan(plan: PlanMap, jobs: list[Any]) -> None:
    """Independent Localizers in different threads share one PlanMap without interfering."""

    def run(offset: int) -> list[tuple[float, float, float]]:
        truth0, _, _, _ = jobs[offset]
        loc = Localizer(plan, truth0)
        return [loc.update(jobs[offset][1], (0.0, 0.0, 0.0)).pose for _ in range(3)]

    serial = [run(k) for k in range(8)]
    with ThreadPoolExecutor(max_workers=4) as pool:
        concurrent = list(pool.map(run, range(8)))
    assert serial == concurrent


COUNT_TO = 100_000


def python_progress_during(fn: Any) -> tuple[int, bool]:
    """Runs `fn` in a worker thread and, meanwhile, counts in this thread up to COUNT_TO.

    Returns (the count reached, whether `fn` was still running when the count stopped). If `fn`
    holds the GIL, this thread cannot run until it returns (only about one 5 ms switch interval,
    far fewer than COUNT_TO increments, can slip in around the call)."""
    started = threading.Event()

    def worker() -> None:
        started.set()
        fn()

    t = threading.Thread(target=worker)
    t.start()
    started.wait()
    counter = 0
    while counter < COUNT_TO and t.is_alive():
        counter += 1
    still_running = t.is_alive()
    t.join()
    return counter, still_running


def test_progress_probe_detects_a_call_that_holds_the_gil() -> None:
    """Negative control of the probe below: a 0.3 s C call made through ctypes.PyDLL keeps the GIL,
    the same call through ctypes.CDLL releases it."""
    ctypes = pytest.importorskip("ctypes")
    try:
        holding, releasing = ctypes.PyDLL(None), ctypes.CDLL(None)
        holding.usleep  # noqa: B018
    except (OSError, AttributeError):
        pytest.skip("no libc usleep")
    count, running = python_progress_during(lambda: holding.usleep(300_000))
    assert count < COUNT_TO and not running, count
    count, running = python_progress_during(lambda: releasing.usleep(300_000))
    assert count == COUNT_TO and running, count


def test_the_gil_is_released_during_alignment(floor: Any, plan: PlanMap) -> None:
    """While a long native alignment (4000 iterations over 8000 points) runs in a worker thread, this
    Python thread keeps executing bytecode: it counts to COUNT_TO before the alignment finishes."""
    rng = np.random.default_rng(5)
    truth = floor.sample_pose(rng, clearance=0.6)
    pts, _ = syn.simulate_scan(floor, truth, rng, beams=8000)
    cfg = IcpConfig(max_iterations=4000, translation_tolerance=0.0, rotation_tolerance=0.0)
    guess = syn.perturb_pose(truth, rng, 0.1, 2 * DEG)
    box: dict[str, Any] = {}

    def align() -> None:
        box["result"] = localize(pts, plan, guess, cfg)

    count, running = python_progress_during(align)
    assert count == COUNT_TO and running, (
        f"the alignment finished after only {count} increments of a Python thread: the GIL was held"
    )
    res = box["result"]
    assert res.iterations == 4000
    assert all(math.isfinite(v) for v in res.pose)


def test_the_gil_is_released_during_occupancy_grid_integration(plan: PlanMap) -> None:
    """One scan of 40,000 beams of 20 m into a 2 cm grid (about 4e7 cell updates) runs in a worker
    thread while this thread counts."""
    from planicp import EnhancedOccupancyGrid, EogState

    grid = EnhancedOccupancyGrid(plan, 0.02, margin=25.0)
    angles = np.linspace(-math.pi, math.pi, 40_000, endpoint=False)
    scan = 20.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    x0, y0 = plan.points.mean(axis=0)

    count, running = python_progress_during(lambda: grid.integrate(scan, (float(x0), float(y0), 0.0)))
    assert count == COUNT_TO and running, (
        f"the integration finished after only {count} increments of a Python thread: the GIL was held"
    )
    assert grid.scans == 1
    assert (grid.observation_states() == EogState.OCCUPIED).sum() > 5000


def test_an_occupancy_grid_shared_by_threads_integrates_every_scan() -> None:
    """Four threads integrating into one grid raised RuntimeError('Already borrowed') and integrated
    44 of 400 scans: the grid now serialises its calls."""
    from concurrent.futures import ThreadPoolExecutor

    from planicp import EnhancedOccupancyGrid
    from planicp.plans.default_plan import load_default_plan
    from planicp.sim.experiment import ExperimentConfig, run_experiment

    plan = load_default_plan()
    recording, _ = run_experiment(plan, ExperimentConfig(duration_s=10.0, seed=4))
    shared, alone = EnhancedOccupancyGrid(plan), EnhancedOccupancyGrid(plan)
    scans = [(recording.scans[k], tuple(recording.truth[k])) for k in range(0, len(recording.scans), 1)][:100]

    def integrate(k: int) -> None:
        scan, pose = scans[k]
        shared.integrate(scan, pose)
        shared.states()  # reads while others write

    with ThreadPoolExecutor(max_workers=4) as pool:
        list(pool.map(integrate, range(len(scans))))
    for scan, pose in scans:
        alone.integrate(scan, pose)
    assert shared.scans == alone.scans == len(scans)
    # The log odds are clamped at each update, so the order of the scans moves a few cells.
    differ = np.count_nonzero(shared.observation_states() != alone.observation_states())
    assert differ < 1e-4 * shared.shape[0] * shared.shape[1], differ
