//! Memory and build time of the nearest-wall index for a large floor, and its look-up cost.
//!
//! The floor is 100 x 100 m of 5 x 10 m rooms with 0.2 m walls, sampled every 2 cm (a plan drawn
//! at 2 cm per pixel). For each (cell, reach) the index is built once from the plan's points and
//! KD-tree and reported; the default settings are also built through `PointMap::wall_index`
//! (visibility masks included). Run:
//!
//!     cargo run --release -p icp_core --example wall_index_report
#[path = "../benches/common/mod.rs"]
mod common;

use icp_core::cancel;
use icp_core::maps::nearest_wall_index::{NearestWallIndex, SensorView};
use icp_core::maps::point_map::{DEFAULT_INDEX_CELL, DEFAULT_INDEX_REACH};
use icp_core::{PointMap, Pose2};
use rand::SeedableRng;
use std::time::Instant;

fn main() {
    let pts = common::grid_floor(100.0, [5.0, 10.0], 0.02);
    let t = Instant::now();
    let map = PointMap::new(pts.clone(), None).unwrap();
    println!(
        "floor 100 x 100 m, {} wall points every 2 cm; PointMap (KD-tree, normals, raster) {:.2} s",
        pts.len(),
        t.elapsed().as_secs_f64()
    );
    println!("| cell | reach | build | memory | stored blocks | candidates per stored cell |");
    println!("|---|---|---|---|---|---|");
    for (cell, reach) in [(0.02, 0.25), (0.02, 0.5), (0.03, 0.5), (0.05, 0.5), (0.05, 1.0)] {
        let t = Instant::now();
        let index = NearestWallIndex::new(&pts, map.tree(), None, cell, reach, cancel::NEVER).unwrap();
        let s = index.stats();
        println!(
            "| {cell} m | {reach} m | {:.2} s | {:.1} MB | {} of {} | {:.2} |",
            t.elapsed().as_secs_f64(),
            s.memory_bytes as f64 / 1e6,
            s.stored_blocks,
            s.blocks,
            s.candidates as f64 / (s.stored_blocks * 64) as f64
        );
    }
    let t = Instant::now();
    let index = map.wall_index(cancel::NEVER).unwrap();
    println!(
        "default (cell {DEFAULT_INDEX_CELL} m, reach {DEFAULT_INDEX_REACH} m) with visibility masks: {:.2} s, {:.1} MB",
        t.elapsed().as_secs_f64(),
        index.memory_bytes() as f64 / 1e6
    );
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let truth = Pose2::new(52.5, 45.0, 0.3);
    let scan = common::noisy_scan(&map, truth, 1080, &mut rng);
    let moved: Vec<[f64; 2]> =
        scan.iter().map(|p| Pose2::new(52.6, 44.9, 0.32).transform_point(*p)).collect();
    let mut pairs = Vec::new();
    let bearings = SensorView::bearings_of(&scan);
    let view = SensorView::new(&bearings, 0.32);
    let reps = 2000;
    let t = Instant::now();
    for _ in 0..reps {
        index.find_pairs(std::hint::black_box(&moved), 0.4, Some(view), &mut pairs);
    }
    let ns = t.elapsed().as_nanos() as f64 / (reps * moved.len()) as f64;
    println!("look-ups: {ns:.1} ns each over a 1080-point scan ({} pairs)", pairs.len());
}
