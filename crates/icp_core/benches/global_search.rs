//! Criterion benches of global relocalization: building the likelihood pyramid, the
//! branch-and-bound search over the whole plan, and the whole relocalization (search plus ICP
//! refinement of every candidate).
//!
//! The test case is the office floor of `common/mod.rs` (40 x 25 m, rooms along a corridor, 0.2 m
//! thick walls with both faces sampled every 5 cm) and a 1081-point scan from inside a room with
//! 1.5 cm noise. Run `cargo bench --bench global_search`; compare numbers within one run only.

use criterion::{criterion_group, criterion_main, Criterion};
use icp_core::cancel;
use icp_core::search::global_search::{GlobalMatcher, GlobalSearchConfig, SearchWindow};
use icp_core::search::relocalization::{relocalize, RankingConfig};
use icp_core::{IcpConfig, PointMap, Pose2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::time::Duration;

mod common;

use common::{noisy_scan, office};

fn benches(c: &mut Criterion) {
    let map = PointMap::new(office(), None).unwrap();
    // In a room, looking towards its door: the corridor and the room tell the place apart.
    let truth = Pose2::new(6.0, 5.0, 1.2);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let scan = noisy_scan(&map, truth, 1081, &mut rng);
    let config = GlobalSearchConfig::default();
    let matcher = GlobalMatcher::new(&map, config.clone()).unwrap();
    let found = matcher.search(&scan, None, cancel::NEVER).unwrap();
    eprintln!(
        "whole-plan search: {} rotations, {} nodes, complete {}, best {:?}",
        found.rotations,
        found.nodes,
        found.complete,
        found.candidates.first()
    );

    // The office's rooms are alike: the result should say so rather than pick one with confidence.
    let (icp, ranking) = (IcpConfig::default(), RankingConfig::default());
    let out = relocalize(&map, &matcher, &scan, None, &icp, &ranking, cancel::NEVER).unwrap();
    for c in &out.candidates {
        eprintln!("candidate {:?} inlier ratio {:.3}", c.pose, c.score);
    }
    eprintln!("ambiguity {:.3}, ambiguous {}", out.ambiguity, out.ambiguous);

    let mut g = c.benchmark_group("global_search_office_40x25");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("build_pyramid", |b| {
        b.iter(|| GlobalMatcher::new(black_box(&map), config.clone()).unwrap())
    });
    g.bench_function("search_whole_plan", |b| {
        b.iter(|| matcher.search(black_box(&scan), None, cancel::NEVER).unwrap())
    });
    let window = SearchWindow::new(Pose2::new(6.5, 4.6, 1.4), 1.0, 0.35);
    g.bench_function("search_window_1m_20deg", |b| {
        b.iter(|| matcher.search(black_box(&scan), Some(&window), cancel::NEVER).unwrap())
    });
    g.bench_function("relocalize_whole_plan", |b| {
        b.iter(|| relocalize(&map, &matcher, black_box(&scan), None, &icp, &ranking, cancel::NEVER).unwrap())
    });
    g.finish();
}

criterion_group!(global_search, benches);
criterion_main!(global_search);
