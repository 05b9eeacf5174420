//! Tests of the nearest-wall index: its look-ups against brute force, its batched passes against
//! single look-ups, its memory and its refusals.

use super::sensor_view::fast_atan2;
use super::*;
use crate::cancel;
use crate::error::IcpError;
use crate::maps::kd_tree::Tree2;
use crate::maps::pair::Pair;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn walls(rng: &mut ChaCha8Rng) -> Vec<[f64; 2]> {
    let mut pts = Vec::new();
    for i in 0..400 {
        let t = i as f64 * 0.05;
        pts.extend([[t, 0.0], [t, 0.2], [t, 6.0], [0.0, t * 0.3], [20.0, t * 0.3], [7.0, 0.2 + t * 0.1]]);
    }
    // Clutter of isolated points, and a wall at an angle.
    pts.extend((0..300).map(|_| [rng.random_range(0.0..20.0), rng.random_range(0.0..6.0)]));
    pts.extend((0..200).map(|i| [2.0 + i as f64 * 0.03, 1.0 + i as f64 * 0.017]));
    pts
}

fn brute(points: &[[f64; 2]], q: [f64; 2]) -> f64 {
    points.iter().map(|p| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).fold(f64::INFINITY, f64::min)
}

/// The batched passes of `find_pairs` against each query answered on its own, with and
/// without a view, for queries inside the raster, outside it and NaN.
#[test]
fn find_pairs_gives_every_point_its_own_look_up() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let pts = walls(&mut rng);
    let tree = Tree2::new_from_slice(&pts);
    let seen: Vec<u16> = (0..pts.len()).map(|_| rng.random_range(0..=u16::MAX)).collect();
    let index = NearestWallIndex::new(&pts, &tree, Some(&seen), 0.03, 0.5, cancel::NEVER).unwrap();
    let mut queries: Vec<[f64; 2]> =
        (0..5000).map(|_| [rng.random_range(-3.0..23.0), rng.random_range(-3.0..9.0)]).collect();
    queries.extend([[f64::NAN, 1.0], [1.0, f64::NAN], [f64::INFINITY, 0.0], [-1e300, 1e300]]);
    let bearings: Vec<f64> = (0..queries.len()).map(|_| rng.random_range(-20.0..20.0)).collect();
    let view = SensorView::new(&bearings, 0.7);
    let mut pairs = Vec::new();
    for max in [0.1f64, 0.3, 0.5, 2.0] {
        let max_sq = max.min(0.5).powi(2);
        // Without a view: the nearest wall point, exactly, within the distance.
        index.find_pairs(&queries, max, None, &mut pairs);
        let expected: Vec<(u32, u32)> = queries
            .iter()
            .enumerate()
            .filter_map(|(i, q)| {
                let (t, d2) = index.nearest(*q)?;
                (d2 <= max_sq).then_some((i as u32, t))
            })
            .collect();
        assert_eq!(pairs.iter().map(|p| (p.source, p.target)).collect::<Vec<_>>(), expected, "{max}");
        for p in &pairs {
            assert!((p.sq_dist - brute(&pts, queries[p.source as usize])).abs() < 1e-12);
        }
        // With a view: the rule applied one query at a time.
        index.find_pairs(&queries, max, Some(view), &mut pairs);
        let mut expected = Vec::new();
        for (i, q) in queries.iter().enumerate() {
            let cell = index.cell_of(*q);
            let (mut t, mut d2) = index.nearest_in(cell, *q);
            let bit = 1u16 << view.sector(i);
            if index.sites[t as usize].seen & bit == 0 {
                let alt = index.alternatives[cell];
                let a = index.sites[alt as usize];
                if a.seen & bit != 0 {
                    (t, d2) = (alt, (a.x - q[0]).powi(2) + (a.y - q[1]).powi(2));
                }
            }
            if d2 <= max_sq && index.sites[t as usize].seen & bit != 0 {
                expected.push(Pair { source: i as u32, target: index.sites[t as usize].plan, sq_dist: d2 });
            }
        }
        assert_eq!(pairs, expected, "{max}");
        assert!(expected.len() > 100, "{max}: {}", expected.len());
    }
}

#[test]
fn agrees_with_brute_force_within_reach_and_answers_none_beyond() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let pts = walls(&mut rng);
    let tree = Tree2::new_from_slice(&pts);
    for (cell, reach) in [(0.02, 0.4), (0.05, 0.25), (0.11, 1.0)] {
        let index = NearestWallIndex::new(&pts, &tree, None, cell, reach, cancel::NEVER).unwrap();
        let (mut answered, mut beyond) = (0, 0);
        for _ in 0..20_000 {
            let q = [rng.random_range(-2.0..22.0), rng.random_range(-2.0..8.0)];
            let exact = brute(&pts, q);
            match index.nearest(q) {
                Some((i, d2)) => {
                    answered += 1;
                    assert!((d2 - exact).abs() < 1e-12, "cell {cell}: {q:?} index {d2} exact {exact}");
                    let p = pts[i as usize];
                    assert_eq!(d2, (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2));
                }
                None => {
                    beyond += 1;
                    assert!(exact > reach * reach, "cell {cell}: {q:?} is {} m from a wall", exact.sqrt());
                }
            }
        }
        assert!(answered > 1000 && beyond > 1000, "cell {cell}: {answered} answered, {beyond} beyond");
    }
}

#[test]
fn stores_only_blocks_near_walls() {
    // One short wall in a large empty extent: most blocks stay empty.
    let mut pts: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 0.05, 0.0]).collect();
    pts.push([40.0, 40.0]);
    let tree = Tree2::new_from_slice(&pts);
    let index = NearestWallIndex::new(&pts, &tree, None, 0.05, 0.3, cancel::NEVER).unwrap();
    let stats = index.stats();
    assert!(stats.stored_blocks * 50 < stats.blocks, "{stats:?}");
    assert!(stats.memory_bytes < 200_000, "{stats:?}");
    assert!(index.nearest([20.0, 20.0]).is_none());
    assert_eq!(index.nearest([0.51, 0.1]).map(|(i, _)| i), Some(10));
    assert!(index.nearest([f64::NAN, 0.0]).is_none());
    assert!(index.nearest([-1e12, 0.0]).is_none());
}

#[test]
fn cell_index_floors_inside_and_lands_on_either_side_of_a_border() {
    for (f, cell) in [(0.0, 0), (0.25, 0), (0.75, 0), (1.5, 1), (2.999_999, 2), (1e6 + 0.3, 1_000_000)] {
        assert_eq!(cell_index(f), cell, "{f}");
    }
    for border in [1.0, 2.0, 3.0, 1e6] {
        let c = cell_index(border);
        assert!(c == border as usize || c + 1 == border as usize, "{border}: {c}");
    }
}

#[test]
fn fast_atan2_is_within_a_tenth_of_a_degree() {
    for k in 0..3600 {
        let a = -std::f64::consts::PI + 0.001 + k as f64 * 0.001_745;
        for r in [1e-3, 1.0, 40.0] {
            let (y, x) = (r * a.sin(), r * a.cos());
            assert!((fast_atan2(y, x) - y.atan2(x)).abs() < 0.0015, "{a}");
        }
    }
    assert_eq!(fast_atan2(0.0, 0.0), 0.0);
}

#[test]
fn rejects_bad_parameters() {
    let pts = vec![[0.0, 0.0], [1.0, 0.0]];
    let tree = Tree2::new_from_slice(&pts);
    for (cell, reach) in [(0.0, 0.3), (f64::NAN, 0.3), (0.05, -1.0), (0.05, f64::INFINITY)] {
        assert!(matches!(
            NearestWallIndex::new(&pts, &tree, None, cell, reach, cancel::NEVER),
            Err(IcpError::InvalidParameter { .. })
        ));
    }
    let far = vec![[0.0, 0.0], [1e6, 1e6]];
    let tree = Tree2::new_from_slice(&far);
    assert!(matches!(
        NearestWallIndex::new(&far, &tree, None, 0.01, 0.3, cancel::NEVER),
        Err(IcpError::RasterTooLarge { .. })
    ));
    assert!(matches!(
        NearestWallIndex::new(&pts, &Tree2::new_from_slice(&pts), Some(&[0u16; 3]), 0.05, 0.3, cancel::NEVER),
        Err(IcpError::InvalidParameter { name: "visibility masks", .. })
    ));
    assert_eq!(
        NearestWallIndex::new(&[], &Tree2::new_from_slice(&[]), None, 0.05, 0.3, cancel::NEVER).unwrap_err(),
        IcpError::Empty { what: "plan" }
    );
}
