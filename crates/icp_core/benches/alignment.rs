//! Criterion benches of the alignment hot path: KD-tree build, nearest-wall index build, one
//! correspondence pass over a 1080-point scan (nearest-wall index; KD-tree over the plan and over
//! the visible subset; the settled candidate cache), visibility ray casting and a full alignment
//! in both correspondence modes (30 fixed iterations, and the default termination).
//!
//! The test case is a generated office floor (40 x 25 m, rooms along a corridor, 0.2 m thick
//! walls with both faces sampled every 5 cm) and a 1080-beam scan cast against it from inside a
//! room, with 1.5 cm noise. Run `cargo bench`; compare numbers within one run only.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use icp_core::cancel;
use icp_core::icp::candidate_cache::CandidateCache;
use icp_core::icp::correspondence::{find_pairs, TargetSet};
use icp_core::icp::visible_through_index::VisibleThroughIndex;
use icp_core::icp::CorrespondenceSearch;
use icp_core::maps::kd_tree::Tree2;
use icp_core::maps::nearest_wall_index::{NearestWallIndex, SensorView};
use icp_core::maps::pair::Pair;
use icp_core::maps::point_map::{DEFAULT_INDEX_CELL, DEFAULT_INDEX_REACH};
use icp_core::{align, IcpConfig, PointMap, Pose2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

mod common;

use common::{noisy_scan, office};

fn benches(c: &mut Criterion) {
    let pts = office();
    let map = PointMap::new(pts.clone(), None).unwrap();
    let truth = Pose2::new(6.0, 5.0, 0.3);
    let guess = Pose2::new(6.15, 4.87, 0.35);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let scan = noisy_scan(&map, truth, 1080, &mut rng);

    let mut g = c.benchmark_group("build");
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("kdtree", |b| b.iter(|| Tree2::new_from_slice(black_box(&pts))));
    g.bench_function("point_map", |b| b.iter(|| PointMap::new(black_box(pts.clone()), None).unwrap()));
    let tree = Tree2::new_from_slice(&pts);
    g.bench_function("nearest_wall_index", |b| {
        b.iter(|| {
            NearestWallIndex::new(
                black_box(&pts),
                &tree,
                None,
                DEFAULT_INDEX_CELL,
                DEFAULT_INDEX_REACH,
                cancel::NEVER,
            )
            .unwrap()
        })
    });
    g.bench_function("wall_index_with_facing", |b| {
        b.iter(|| {
            let map = PointMap::new(black_box(pts.clone()), None).unwrap();
            map.wall_index(cancel::NEVER).unwrap();
            map
        })
    });
    g.finish();

    let mut g = c.benchmark_group("correspondences_1080");
    g.throughput(Throughput::Elements(scan.len() as u64));
    let moved: Vec<[f64; 2]> = scan.iter().map(|p| guess.transform_point(*p)).collect();
    let mut pairs: Vec<Pair> = Vec::with_capacity(scan.len());
    let wall = map.wall_index(cancel::NEVER).unwrap();
    let bearings = SensorView::bearings_of(&scan);
    let sensor = Some(SensorView::new(&bearings, guess.yaw));
    g.bench_function("wall_index", |b| {
        b.iter(|| wall.find_pairs(black_box(&moved), 0.4, sensor, &mut pairs))
    });
    g.bench_function("wall_index_no_facing", |b| {
        b.iter(|| wall.find_pairs(black_box(&moved), 0.4, None, &mut pairs))
    });
    let full = TargetSet::Full(&map);
    g.bench_function("kdtree_full_plan", |b| {
        b.iter(|| find_pairs(&full, black_box(&moved), 0.4, &mut pairs))
    });
    let visible = TargetSet::subset(&map, map.visible_from(guess, 30.0).unwrap()).unwrap();
    g.bench_function("kdtree_visible_subset", |b| {
        b.iter(|| find_pairs(&visible, black_box(&moved), 0.4, &mut pairs))
    });
    // The KD-tree search as `align` runs it: the plan's index first, the subset's tree for hidden ones.
    let through = VisibleThroughIndex::new(wall, &visible, 0.4).expect("within the index's reach");
    g.bench_function("kdtree_visible_through_index", |b| {
        b.iter(|| through.find_pairs(&visible, black_box(&moved), 0.4, &mut pairs))
    });
    // The cached path ICP iterations take once the pose has settled: candidates fetched once.
    let mut cache = CandidateCache::new(0.8);
    cache.find_pairs(&visible, &moved, 0.4, &mut pairs);
    cache.find_pairs(&visible, &moved, 0.4, &mut pairs);
    g.bench_function("candidate_cache_settled", |b| {
        b.iter(|| cache.find_pairs(&visible, black_box(&moved), 0.1, &mut pairs))
    });
    g.finish();

    let mut g = c.benchmark_group("visibility");
    g.bench_function("visible_from_30m", |b| b.iter(|| map.visible_from(black_box(guess), 30.0).unwrap()));
    // The tracking step's one cast: visible points and the occlusion rule's 1440 wall ranges.
    g.bench_function("view_from_30m_1440", |b| {
        b.iter(|| map.view_from(black_box(guess), 30.0, 1440, None, true).unwrap())
    });
    g.finish();

    let mut g = c.benchmark_group("align_1080");
    let fixed = IcpConfig {
        max_correspondence_distance: 0.4,
        translation_tolerance: 0.0,
        rotation_tolerance: 0.0,
        ..IcpConfig::default()
    };
    let kd = CorrespondenceSearch::KdTree;
    for (name, cfg) in [
        ("wall_index_fixed_30", fixed.clone()),
        ("wall_index_default", IcpConfig { max_correspondence_distance: 0.4, ..IcpConfig::default() }),
        ("kdtree_fixed_30", IcpConfig { search: kd, ..fixed.clone() }),
        ("kdtree_fixed_30_no_visibility", IcpConfig { search: kd, use_visibility: false, ..fixed.clone() }),
        (
            "kdtree_default",
            IcpConfig { search: kd, max_correspondence_distance: 0.4, ..IcpConfig::default() },
        ),
    ] {
        g.bench_with_input(BenchmarkId::from_parameter(name), &cfg, |b, cfg| {
            b.iter(|| align(&map, black_box(&scan), guess, cfg, None, cancel::NEVER).unwrap())
        });
    }
    g.finish();
}

criterion_group!(alignment, benches);
criterion_main!(alignment);
