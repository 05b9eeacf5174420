//! Fuzz targets over the grid half of the core: `ray_casting::{OccupancyRaster::new, cast_ranges,
//! add_noise}`, `log_odds_grid::LogOddsGrid::{new, integrate}`, `cell_traversal::for_each_cell`,
//! `WallRaster`, `BucketGrid`, `Pose2` and the ICP stage budget.
//!
//! Every case feeds hostile inputs (see `fuzz_harness`) and checks that the call neither panics
//! nor hangs, that it refuses exactly the inputs the documentation says it refuses, with a
//! message, and that what it returns is finite and consistent. Case counts: `PLANICP_FUZZ_CASES`.

#[macro_use]
mod fuzz_harness;

use fuzz_harness::{clear_error, in_range, run, Case, Outcome};
use icp_core::error::MAX_COORDINATE;
use icp_core::grids::cell_traversal::for_each_cell;
use icp_core::grids::log_odds_grid::{LogOddsGrid, OccupancyModel};
use icp_core::grids::ray_casting::{
    add_noise, cast_ranges, noise_rng, Disc, LidarModel, OccupancyRaster, MAX_BEAMS,
};
use icp_core::grids::wall_raster::WallRaster;
use icp_core::icp::termination::stage_end;
use icp_core::maps::bucket_grid::BucketGrid;
use icp_core::pose::wrap_angle;
use icp_core::Pose2;
use std::f64::consts::PI;

fn within(v: f64) -> bool {
    v.is_finite() && v.abs() <= MAX_COORDINATE
}

/// A shape, mostly small, sometimes empty or absurd (the refusal must not allocate).
fn shape(c: &mut Case) -> (usize, usize) {
    match c.below(10) {
        0 => (c.below(3), c.below(3)),
        1 => (c.pick(&[usize::MAX, 1 << 33, 1 << 20, 3]), c.pick(&[usize::MAX, 1 << 33, 1 << 20, 0, 1])),
        _ => (1 + c.below(120), 1 + c.below(120)),
    }
}

fn random_model(c: &mut Case) -> LidarModel {
    let mut m = LidarModel {
        angle_min: c.uniform(-PI, PI),
        angle_increment: c.pick(&[0.0, 2.0 * PI / 360.0, -0.01, 1e-9, 3.0]),
        beams: c.pick(&[1, 2, 90, 360, 721]),
        range_min: c.pick(&[0.0, 0.05, 0.5]),
        range_max: c.pick(&[0.1, 10.0, 30.0, 1e6]),
    };
    match c.below(12) {
        0 => m.angle_min = c.special(),
        1 => m.angle_increment = c.special(),
        2 => m.beams = c.pick(&[0, MAX_BEAMS + 1, usize::MAX]),
        3 => m.range_min = c.special(),
        4 => m.range_max = c.special(),
        _ => {}
    }
    m
}

fn model_valid(m: &LidarModel) -> bool {
    m.angle_min.is_finite()
        && m.angle_increment.is_finite()
        && (1..=MAX_BEAMS).contains(&m.beams)
        && m.range_min.is_finite()
        && m.range_min >= 0.0
        && m.range_max.is_finite()
        && m.range_max > m.range_min
}

#[test]
fn fuzz_ray_casting() {
    run("ray_casting", 3, |c| {
        let (rows, cols) = shape(c);
        let small = rows.saturating_mul(cols) <= 1 << 16;
        let fill = c.pick(&[0.0, 0.02, 0.3, 1.0]);
        let mut cells: Vec<bool> =
            if small { (0..rows * cols).map(|_| c.coin(fill)).collect() } else { vec![true; 7] };
        if small && c.coin(0.05) {
            cells.push(false);
        }
        let resolution = if c.coin(0.15) { c.special() } else { c.pick(&[1e-6, 0.01, 0.05, 0.5, 1e6]) };
        let origin = if c.coin(0.15) {
            [c.special(), c.special()]
        } else {
            [c.uniform(-10.0, 10.0), c.uniform(-10.0, 10.0)]
        };
        c.note(|| format!("raster {rows}x{cols} res {resolution} origin {origin:?} cells {cells:?}"));
        let far = [origin[0] + cols as f64 * resolution, origin[1] + rows as f64 * resolution];
        let valid = rows > 0
            && cols > 0
            && rows
                .checked_mul(cols)
                .is_some_and(|n| n <= icp_core::grids::ray_casting::MAX_CELLS && n == cells.len())
            && resolution.is_finite()
            && resolution >= icp_core::grids::ray_casting::MIN_RESOLUTION
            && within(origin[0])
            && within(origin[1])
            && within(far[0])
            && within(far[1]);
        let raster = match OccupancyRaster::new(cells.clone(), rows, cols, resolution, origin) {
            Ok(r) => {
                ensure!(valid, "accepted an invalid raster");
                ensure!(r.shape() == (rows, cols), "shape");
                let occupied = cells.iter().filter(|&&o| o).count();
                ensure!(r.occupied_cells() == occupied, "occupied cells");
                r
            }
            Err(e) => {
                clear_error(&e)?;
                ensure!(!valid, "refused a valid raster: {e}");
                return Ok(());
            }
        };
        let mut out = Vec::new();
        for _ in 0..3 {
            let model = random_model(c);
            let pose = if c.coin(0.8) {
                let span = [cols as f64 * resolution, rows as f64 * resolution];
                Pose2 {
                    x: origin[0] + c.uniform(-0.2, 1.2) * span[0],
                    y: origin[1] + c.uniform(-0.2, 1.2) * span[1],
                    yaw: c.f64_or_special(-10.0, 10.0, 0.05),
                }
            } else {
                Pose2 { x: c.special(), y: c.f64_or_special(-5.0, 5.0, 0.5), yaw: c.uniform(-PI, PI) }
            };
            let discs: Vec<Disc> = (0..c.below(4))
                .map(|_| Disc {
                    x: c.f64_or_special(pose.x - 5.0, pose.x + 5.0, 0.05),
                    y: c.uniform(pose.y - 5.0, pose.y + 5.0),
                    radius: c.f64_or_special(0.0, 1.0, 0.05),
                })
                .collect();
            c.note(|| format!("model {model:?} pose {pose:?} discs {discs:?}"));
            let valid = model_valid(&model)
                && pose.is_finite()
                && within(pose.x)
                && within(pose.y)
                && discs.iter().all(|d| within(d.x) && within(d.y) && d.radius.is_finite() && d.radius > 0.0);
            match cast_ranges(&raster, pose, &model, &discs, &mut out) {
                Ok(()) => {
                    ensure!(valid, "accepted an invalid model/pose/disc");
                    ensure!(out.len() == model.beams, "{} ranges for {} beams", out.len(), model.beams);
                    for &r in &out {
                        ensure!(
                            r.is_infinite() || (r >= model.range_min && r <= model.range_max),
                            "range {r} outside [{}, {}] and not +-inf",
                            model.range_min,
                            model.range_max
                        );
                    }
                    let sigma = if c.coin(0.1) { c.special() } else { c.pick(&[0.0, 0.01, 1.0, 1e6]) };
                    let dropout = if c.coin(0.1) { c.special() } else { c.pick(&[0.0, 0.1, 1.0]) };
                    let mut rng = noise_rng(Some(c.below(1000) as u64));
                    let before = out.clone();
                    match add_noise(&mut out, &model, sigma, dropout, &mut rng) {
                        Ok(()) => {
                            ensure!(
                                sigma.is_finite() && sigma >= 0.0 && (0.0..=1.0).contains(&dropout),
                                "accepted sigma {sigma} dropout {dropout}"
                            );
                            for (&r, &b) in out.iter().zip(&before) {
                                ensure!(
                                    r == f64::INFINITY
                                        || (r == f64::NEG_INFINITY && (b.is_finite() || b == r))
                                        || (r >= model.range_min && r <= model.range_max && b.is_finite()),
                                    "noisy range {r} from {b}"
                                );
                            }
                        }
                        Err(e) => {
                            clear_error(&e)?;
                            ensure!(out == before, "add_noise changed the ranges and failed");
                        }
                    }
                }
                Err(e) => {
                    clear_error(&e)?;
                    ensure!(!valid, "refused valid input: {e}");
                }
            }
        }
        Ok(())
    });
}

fn random_occupancy_model(c: &mut Case) -> OccupancyModel {
    let mut m = OccupancyModel::default();
    match c.below(10) {
        0 => m.hit = c.special() as f32,
        1 => m.miss = c.special() as f32,
        2 => m.min = c.special() as f32,
        3 => m.max = c.special() as f32,
        4 => m = OccupancyModel { hit: 1e30, miss: -1e30, min: -1e-30, max: 1e-30 },
        _ => {}
    }
    m
}

/// What integrate must leave unchanged when it refuses a scan.
fn snapshot(g: &LogOddsGrid) -> ((usize, usize), [f64; 2], u64, u64) {
    let h = g.log_odds().fold(0u64, |h, v| h.rotate_left(5) ^ v.to_bits() as u64);
    let o = g.observed().fold(h, |h, v| h.rotate_left(1) ^ v as u64);
    (g.shape(), g.origin(), g.scans(), o)
}

#[test]
fn fuzz_log_odds_grid() {
    run("log_odds_grid", 3, |c| {
        let (rows, cols) = shape(c);
        let resolution = if c.coin(0.15) { c.special() } else { c.pick(&[1e-4, 0.01, 0.05, 0.1, 1.0, 1e3]) };
        let origin = if c.coin(0.1) {
            [c.special(), c.special()]
        } else {
            [c.uniform(-10.0, 10.0), c.uniform(-10.0, 10.0)]
        };
        let model = random_occupancy_model(c);
        let max_cells = if c.coin(0.95) { c.pick(&[0, 1, 100, 1 << 14, 1 << 18]) } else { 1 << 22 };
        c.note(|| {
            format!(
                "grid {rows}x{cols} res {resolution} origin {origin:?} model {model:?} max_cells {max_cells}"
            )
        });
        let far = [origin[0] + cols as f64 * resolution, origin[1] + rows as f64 * resolution];
        let valid = model.validate().is_ok()
            && resolution.is_finite()
            && resolution >= icp_core::grids::log_odds_grid::MIN_RESOLUTION
            && rows > 0
            && cols > 0
            && rows.saturating_mul(cols) <= max_cells
            && [origin[0], origin[1], far[0], far[1]].into_iter().all(within);
        let mut grid = match LogOddsGrid::new(rows, cols, resolution, origin, model, max_cells) {
            Ok(g) => {
                ensure!(valid, "accepted an invalid grid");
                ensure!(g.shape() == (rows, cols) && g.scans() == 0, "fresh grid");
                g
            }
            Err(e) => {
                clear_error(&e)?;
                ensure!(!valid, "refused a valid grid: {e}");
                return Ok(());
            }
        };
        for _ in 0..1 + c.below(4) {
            let extent = (cols.max(rows) as f64 * resolution).min(1e7);
            let sensor = if c.coin(0.9) {
                [origin[0] + c.uniform(-0.3, 1.3) * extent, origin[1] + c.uniform(-0.3, 1.3) * extent]
            } else {
                [c.special(), c.uniform(-1.0, 1.0)]
            };
            let reach = c.pick(&[0.1, 1.0, 10.0, 100.0]) * resolution;
            let around = |c: &mut Case, n: usize| -> Vec<[f64; 2]> {
                let mut v: Vec<[f64; 2]> = (0..n)
                    .map(|_| {
                        let (a, r) = (c.uniform(-PI, PI), c.uniform(0.0, reach));
                        [sensor[0] + r * a.cos(), sensor[1] + r * a.sin()]
                    })
                    .collect();
                if !v.is_empty() && c.coin(0.1) {
                    let i = c.below(v.len());
                    v[i][c.below(2)] = c.special();
                }
                v
            };
            let n_hits = c.pick(&[0, 1, 50, 360]);
            let hits = around(c, n_hits);
            let n_misses = c.pick(&[0, 0, 1, 30]);
            let misses = around(c, n_misses);
            let max_range =
                if c.coin(0.1) { c.special() } else { c.pick(&[1e-3, 0.5, 10.0, 1e300]) * reach.max(1.0) };
            c.note(|| format!("sensor {sensor:?} max_range {max_range} hits {hits:?} misses {misses:?}"));
            let valid = in_range(&[sensor])
                && in_range(&hits)
                && in_range(&misses)
                && max_range.is_finite()
                && max_range > 0.0;
            let before = snapshot(&grid);
            let m = grid.model();
            match grid.integrate(sensor, &hits, &misses, max_range) {
                Ok(()) => {
                    ensure!(valid, "accepted an invalid scan");
                    ensure!(grid.scans() == before.2 + 1, "scan count");
                    let (r, k) = grid.shape();
                    ensure!(r * k <= grid.max_cells(), "grew to {r}x{k} beyond {}", grid.max_cells());
                    let o = grid.origin();
                    ensure!(o[0].is_finite() && o[1].is_finite(), "origin {o:?}");
                    let lattice = ((o[0] - origin[0]) / resolution, (o[1] - origin[1]) / resolution);
                    ensure!(
                        (lattice.0 - lattice.0.round()).abs() < 1e-6 * lattice.0.abs().max(1.0)
                            && (lattice.1 - lattice.1.round()).abs() < 1e-6 * lattice.1.abs().max(1.0),
                        "origin {o:?} left the lattice of {origin:?}"
                    );
                    for (l, seen) in grid.log_odds().zip(grid.observed()) {
                        ensure!(l.is_finite(), "log-odds {l}");
                        ensure!(seen || l == 0.0, "unobserved cell with log-odds {l}");
                        ensure!(
                            l == 0.0 || (l >= m.min.min(m.miss) && l <= m.max.max(m.hit)),
                            "log-odds {l} outside the clamp [{}, {}]",
                            m.min,
                            m.max
                        );
                    }
                    // The sensor's cell is inside the grid now.
                    let span = [o[0] + k as f64 * resolution, o[1] + r as f64 * resolution];
                    let tol = 1e-9 * resolution.max(sensor[0].abs()).max(sensor[1].abs());
                    ensure!(
                        sensor[0] >= o[0] - tol
                            && sensor[0] <= span[0] + tol
                            && sensor[1] >= o[1] - tol
                            && sensor[1] <= span[1] + tol,
                        "sensor {sensor:?} outside the grid {o:?}..{span:?}"
                    );
                }
                Err(e) => {
                    clear_error(&e)?;
                    ensure!(
                        !valid || matches!(e, icp_core::IcpError::GridTooLarge { .. }),
                        "refused a valid scan: {e}"
                    );
                    ensure!(snapshot(&grid) == before, "a refused scan changed the grid");
                }
            }
        }
        Ok(())
    });
}

#[test]
fn fuzz_cell_traversal() {
    run("cell_traversal", 100, |c| {
        // Anywhere the documented domain reaches (finite, exact cell indices), any length up to
        // 20 000 cells: the walk is exactly as long as the cells between its ends.
        let base = c.pick(&[0.0, 1.0, 1e3, 1e6, 1e12, 4e15]) * c.pick(&[-1.0, 1.0]);
        let len = c.pick(&[0.0, 1e-12, 0.5, 1.0, 3.0, 100.0, 10_000.0]);
        let p = |c: &mut Case| -> f64 {
            match c.below(4) {
                0 => base + c.uniform(-len, len).round(),
                1 => base + c.uniform(-len, len).round() + c.pick(&[1e-9, -1e-9, 0.5, 1e-300, -0.0]),
                _ => base + c.uniform(-len, len),
            }
        };
        let (a, b) = ([p(c), p(c)], [p(c), p(c)]);
        c.note(|| format!("{a:?} -> {b:?}"));
        let mut cells = Vec::new();
        for_each_cell(a, b, |col, row| cells.push((col, row)));
        let first = (a[0].floor() as i64, a[1].floor() as i64);
        let last = (b[0].floor() as i64, b[1].floor() as i64);
        let expected = (last.0 - first.0).unsigned_abs() + (last.1 - first.1).unsigned_abs() + 1;
        ensure!(cells.len() as u64 == expected, "{} cells, expected {expected}", cells.len());
        ensure!(cells[0] == first && *cells.last().expect("non-empty") == last, "ends");
        for w in cells.windows(2) {
            ensure!(
                (w[1].0 - w[0].0).abs() + (w[1].1 - w[0].1).abs() == 1,
                "not 4-connected: {:?} -> {:?}",
                w[0],
                w[1]
            );
        }
        Ok(())
    });
}

#[test]
fn fuzz_wall_raster_and_bucket_grid() {
    run("wall_raster", 3, |c| {
        let pts = c.points(2000);
        let res = if c.coin(0.2) { c.special() } else { c.pick(&[1e-3, 0.05, 0.5, 10.0]) };
        c.note(|| format!("res {res} bounds {:?} n {} points {pts:?}", bounds(&pts), pts.len()));
        if !pts.is_empty() && in_range(&pts) && res.is_finite() && res > 0.0 {
            let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
            for p in &pts {
                for k in 0..2 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            let cells = ((hi[0] - lo[0]) / res + 3.0) * ((hi[1] - lo[1]) / res + 3.0);
            if cells <= 4e6 {
                match WallRaster::new(&pts, res) {
                    Ok(r) => {
                        for (i, p) in pts.iter().enumerate() {
                            let cell = r.cell_of(*p);
                            ensure!(cell.is_some(), "point {i} outside its own raster");
                            let inside = r.points_in_cell(cell.expect("checked"));
                            ensure!(inside.contains(&(i as u32)), "point {i} missing from its cell");
                        }
                    }
                    Err(e) => clear_error(&e)?,
                }
            }
            // The bucket grid's range queries agree with brute force (its documented domain:
            // finite points, radius up to the cell it reports).
            let cell = c.pick(&[1e-300, 1e-3, 0.1, 1.0, f64::NAN, 0.0]);
            let grid = BucketGrid::new(pts.iter().enumerate().map(|(i, p)| (*p, i as u32)), cell);
            ensure!(grid.cell().is_finite() && grid.cell() > 0.0, "bucket cell {}", grid.cell());
            for _ in 0..3 {
                let p = pts[c.below(pts.len())];
                let q =
                    [p[0] + c.uniform(-1.0, 1.0) * grid.cell(), p[1] + c.uniform(-1.0, 1.0) * grid.cell()];
                let radius = grid.cell() * c.pick(&[0.0, 0.5, 1.0]);
                c.note(|| format!("bucket cell {cell} -> {}, query {q:?} radius {radius}", grid.cell()));
                let mut found = Vec::new();
                grid.for_each_within(q, radius, |_, i, _| found.push(i));
                found.sort_unstable();
                let r2 = radius * radius;
                let expected: Vec<u32> = pts
                    .iter()
                    .enumerate()
                    .filter(|(_, p)| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) <= r2)
                    .map(|(i, _)| i as u32)
                    .collect();
                // Below ~1e-154 m squared distances underflow to 0 and brute force "finds" every
                // point; the grid (by cells) stays right. Compare where squares are exact enough.
                ensure!(
                    radius < 1e-150 || found == expected,
                    "bucket query {found:?} vs brute force {expected:?}"
                );
            }
        } else if !pts.is_empty() || res.is_nan() {
            match WallRaster::new(&pts, res) {
                Ok(_) => {}
                Err(e) => clear_error(&e)?,
            }
        }
        Ok(())
    });
}

#[test]
fn fuzz_pose_and_budget() {
    run("pose_and_budget", 100, |c| {
        let a = Pose2::new(
            c.f64_or_special(-1e3, 1e3, 0.2),
            c.f64_or_special(-1e3, 1e3, 0.2),
            c.f64_or_special(-1e3, 1e3, 0.2),
        );
        let b = Pose2::new(c.uniform(-1e3, 1e3), c.uniform(-1e3, 1e3), c.f64_or_special(-10.0, 10.0, 0.2));
        c.note(|| format!("{a:?} {b:?}"));
        for yaw in [a.yaw, b.yaw] {
            ensure!(yaw.is_nan() || yaw.is_infinite() || (yaw > -PI && yaw <= PI), "yaw {yaw}");
        }
        let ab = a.compose(&b);
        let inv = a.inverse();
        if a.is_finite() && b.is_finite() && a.x.abs() < 1e6 && a.y.abs() < 1e6 {
            ensure!(ab.is_finite() && inv.is_finite(), "compose/inverse of finite poses");
            let id = a.compose(&inv);
            ensure!(
                id.x.abs() < 1e-9 && id.y.abs() < 1e-9 && wrap_angle(id.yaw).abs() < 1e-12,
                "a * a^-1 = {id:?}"
            );
        }
        // The stage budget: ends never exceed the budget and never go backwards.
        let stages = c.pick(&[1, 2, 3, 7, 1000, usize::MAX]);
        let max_iterations = c.pick(&[1, 30, 1000, usize::MAX / 2, usize::MAX - 1, usize::MAX]);
        let mut picked: Vec<usize> = [0, 1, 2, stages / 2, stages.saturating_sub(2), stages - 1]
            .into_iter()
            .filter(|&s| s < stages)
            .collect();
        picked.sort_unstable();
        picked.dedup();
        let mut previous = 0;
        for stage in picked {
            let end = stage_end(stage, stages, max_iterations);
            ensure!(end <= max_iterations, "stage {stage}/{stages}: end {end} > {max_iterations}");
            ensure!(end >= previous, "stage {stage}/{stages} of {max_iterations}: ends go backwards");
            previous = end;
        }
        ensure!(stage_end(stages - 1, stages, max_iterations) == max_iterations, "last stage end");
        Ok(())
    });
}

/// Sanity of the harness itself: `Outcome` errors are reported (kept out of the random runs).
#[test]
fn harness_reports_violations() {
    let r =
        std::panic::catch_unwind(|| run("harness_self_test", 1, |_c| -> Outcome { Err("expected".into()) }));
    assert!(r.is_err());
}

fn bounds(pts: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}
