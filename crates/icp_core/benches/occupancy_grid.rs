//! Criterion bench of the enhanced occupancy grid's scan integration: one 1081-beam, 270-degree,
//! 30 m scan (cast through the office floor of the `ray_casting` bench) integrated into a 5 cm
//! log-odds grid covering the floor, from inside a room and from the corridor (long beams). The
//! same group times casting that scan, as the baseline of the same run.
//! Run `cargo bench --bench occupancy_grid`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use icp_core::grids::log_odds_grid::{LogOddsGrid, OccupancyModel};
use icp_core::grids::ray_casting::{cast_ranges, LidarModel};
use icp_core::Pose2;
use std::hint::black_box;

mod common;

use common::{hokuyo, office_raster, RES};

/// Map-frame end points of the returns of `ranges` from `pose` (finite ranges only).
fn returns(pose: Pose2, model: &LidarModel, ranges: &[f64]) -> Vec<[f64; 2]> {
    ranges
        .iter()
        .enumerate()
        .filter(|(_, r)| r.is_finite())
        .map(|(k, &r)| {
            let a = pose.yaw + model.angle_min + model.angle_increment * k as f64;
            [pose.x + r * a.cos(), pose.y + r * a.sin()]
        })
        .collect()
}

fn benches(c: &mut Criterion) {
    let raster = office_raster();
    let model = hokuyo();
    let (rows, cols) = raster.shape();
    let mut g = c.benchmark_group("occupancy_grid");
    g.throughput(Throughput::Elements(model.beams as u64));
    for (name, pose) in [("room", Pose2::new(6.0, 5.0, 0.3)), ("corridor", Pose2::new(3.0, 12.25, 0.0))] {
        let mut ranges = Vec::new();
        cast_ranges(&raster, pose, &model, &[], &mut ranges).unwrap();
        let hits = returns(pose, &model, &ranges);
        let mut grid =
            LogOddsGrid::new(rows, cols, RES, raster.origin(), OccupancyModel::default(), 1 << 24).unwrap();
        g.bench_function(format!("integrate_1081_{name}"), |b| {
            b.iter(|| grid.integrate(black_box([pose.x, pose.y]), &hits, &[], 30.0).unwrap())
        });
        g.bench_function(format!("cast_1081_{name}_baseline"), |b| {
            b.iter(|| cast_ranges(&raster, black_box(pose), &model, &[], &mut ranges).unwrap())
        });
    }
    g.finish();
}

criterion_group!(occupancy_grid, benches);
criterion_main!(occupancy_grid);
