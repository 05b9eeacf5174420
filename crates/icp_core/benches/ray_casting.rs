//! Criterion bench of the simulated LIDAR: one 1081-beam, 270-degree, 30 m scan cast through the
//! office floor of the `alignment` bench (40 x 25 m, 0.2 m thick walls, eight rooms along a
//! corridor) rasterised at 5 cm, from inside a room and from the corridor (long beams), with and
//! without noise and a few people (discs). Run `cargo bench --bench ray_casting`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use icp_core::grids::ray_casting::{add_noise, cast_ranges, noise_rng, Disc, LidarModel};
use icp_core::Pose2;
use std::f64::consts::PI;
use std::hint::black_box;

mod common;

use common::{hokuyo, office_raster};

fn benches(c: &mut Criterion) {
    let raster = office_raster();
    let model = hokuyo();
    let room = Pose2::new(6.0, 5.0, 0.3);
    let corridor = Pose2::new(3.0, 12.25, 0.0);
    let people: Vec<Disc> =
        (0..5).map(|k| Disc { x: 8.0 + 5.0 * k as f64, y: 12.0 + 0.3 * k as f64, radius: 0.25 }).collect();
    let mut out = Vec::with_capacity(model.beams);

    let mut g = c.benchmark_group("ray_casting");
    g.throughput(Throughput::Elements(model.beams as u64));
    g.bench_function("scan_1081_room", |b| {
        b.iter(|| cast_ranges(&raster, black_box(room), &model, &[], &mut out).unwrap())
    });
    g.bench_function("scan_1081_corridor", |b| {
        b.iter(|| cast_ranges(&raster, black_box(corridor), &model, &[], &mut out).unwrap())
    });
    g.bench_function("scan_1081_corridor_5_people_noise", |b| {
        let mut rng = noise_rng(Some(1));
        b.iter(|| {
            cast_ranges(&raster, black_box(corridor), &model, &people, &mut out).unwrap();
            add_noise(&mut out, &model, 0.015, 0.01, &mut rng).unwrap();
        })
    });
    // A full circle of 3600 beams from the corridor, the widest case.
    let circle = LidarModel { angle_min: -PI, angle_increment: 2.0 * PI / 3600.0, beams: 3600, ..model };
    g.bench_function("scan_3600_full_circle_corridor", |b| {
        b.iter(|| cast_ranges(&raster, black_box(corridor), &circle, &[], &mut out).unwrap())
    });
    g.finish();
}

criterion_group!(ray_casting, benches);
criterion_main!(ray_casting);
