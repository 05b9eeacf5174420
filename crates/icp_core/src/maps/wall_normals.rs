//! The wall normal at every plan point: the least-squares line through the point's nearest
//! neighbours, fitted once when a [`crate::PointMap`] is built (or given with a cached plan).
//!
//! The covariance of an alignment measures residuals along these normals
//! ([`crate::icp::covariance`]), and the facing masks tell a point's own wall from an occluder
//! with them ([`crate::visibility::wall_facing`]).

use crate::cancel::{self, Cancel};
use crate::error::Result;
use crate::maps::kd_tree::Tree2;

/// Neighbours used to fit a wall direction at a plan point.
pub const NORMAL_NEIGHBOURS: usize = 6;

/// Points farther than the sixth neighbour by at most this share of its squared distance are its
/// ties, and take part in the fit too.
pub const TIE_TOLERANCE: f64 = 1e-9;

/// Unit normal of the plan's wall at every point (least-squares line through the point's
/// [`NORMAL_NEIGHBOURS`] nearest plan points and every other point as near as the last of them);
/// `[0, 0]` where no direction can be fitted.
///
/// `cancel` is polled every [`cancel::POLL_EVERY`] points; when it returns true the fit stops with
/// [`crate::error::IcpError::Interrupted`] ([`cancel::NEVER`]: it cannot be stopped, and never fails).
pub fn estimate_normals(map_points: &[[f64; 2]], tree: &Tree2, cancel: Cancel<'_>) -> Result<Vec<[f64; 2]>> {
    let mut normals = Vec::with_capacity(map_points.len());
    for chunk in map_points.chunks(cancel::POLL_EVERY) {
        cancel::check(cancel)?;
        normals.extend(chunk.iter().map(|p| normal_at(map_points, tree, p)));
    }
    Ok(normals)
}

/// The wall normal at `p` (see [`estimate_normals`]).
fn normal_at(map_points: &[[f64; 2]], tree: &Tree2, p: &[f64; 2]) -> [f64; 2] {
    // On a plan's pixel lattice the sixth neighbour is often one of several at the same distance:
    // take them all (to a relative TIE_TOLERANCE, the rounding of lattice coordinates), so that the
    // fit is symmetric and does not depend on which of the ties a query keeps.
    let mut nn = tree.nearest_n_with_ties(p, NORMAL_NEIGHBOURS, TIE_TOLERANCE);
    if nn.len() < 3 {
        return [0.0, 0.0];
    }
    if nn.len() < NORMAL_NEIGHBOURS {
        // Fewer plan points than neighbours: all of them, summed nearest first (as before the
        // query kept ties, so that the normals stay the same to the last bit).
        nn.sort_unstable_by(|a, b| a.distance.total_cmp(&b.distance).then(a.item.cmp(&b.item)));
    }
    let inv = 1.0 / nn.len() as f64;
    let (mut mx, mut my) = (0.0, 0.0);
    for n in &nn {
        let q = map_points[n.item as usize];
        mx += q[0] - p[0];
        my += q[1] - p[1];
    }
    mx *= inv;
    my *= inv;
    let (mut cxx, mut cxy, mut cyy) = (0.0, 0.0, 0.0);
    for n in &nn {
        let q = map_points[n.item as usize];
        let (dx, dy) = (q[0] - p[0] - mx, q[1] - p[1] - my);
        cxx += dx * dx;
        cxy += dx * dy;
        cyy += dy * dy;
    }
    if cxx + cyy <= 0.0 {
        return [0.0, 0.0];
    }
    // Direction of the major axis; the normal is perpendicular to it.
    let phi = 0.5 * (2.0 * cxy).atan2(cxx - cyy);
    [-phi.sin(), phi.cos()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_of_a_straight_wall_are_perpendicular() {
        let pts: Vec<[f64; 2]> = (0..50).map(|i| [i as f64 * 0.05, 1.0]).collect();
        let tree = Tree2::new_from_slice(&pts);
        for n in estimate_normals(&pts, &tree, cancel::NEVER).unwrap() {
            assert!(n[0].abs() < 1e-9 && (n[1].abs() - 1.0).abs() < 1e-9, "{n:?}");
        }
    }

    #[test]
    fn normals_do_not_depend_on_the_order_of_the_points() {
        // A plan's pixel lattice: an L of walls two cells thick, where a point's sixth-nearest
        // neighbour is often one of several at the same distance.
        let mut pts = Vec::new();
        for i in 0..60 {
            for j in 0..2 {
                pts.push([i as f64 * 0.05, j as f64 * 0.05]);
                if i >= 2 {
                    pts.push([j as f64 * 0.05, i as f64 * 0.05]);
                }
            }
        }
        let normals = estimate_normals(&pts, &Tree2::new_from_slice(&pts), cancel::NEVER).unwrap();
        let reversed: Vec<[f64; 2]> = pts.iter().rev().copied().collect();
        let reversed_normals =
            estimate_normals(&reversed, &Tree2::new_from_slice(&reversed), cancel::NEVER).unwrap();
        let n = pts.len();
        for (i, a) in normals.iter().enumerate() {
            // A line's normal has no preferred side: compare up to sign.
            let b = reversed_normals[n - 1 - i];
            let same = (a[0] * b[0] + a[1] * b[1]).abs();
            assert!((same - 1.0).abs() < 1e-9, "point {i}: {a:?} vs {b:?}");
        }
        // Along the middle of a straight stretch the fit is symmetric: the normal is the wall's.
        let mid = pts.iter().position(|p| (p[0] - 1.5).abs() < 1e-9 && p[1] == 0.0).unwrap();
        assert!(normals[mid][0].abs() < 1e-9, "{:?}", normals[mid]);
    }

    /// The neighbours of the fit as they were found before the tree had a query that keeps ties:
    /// the six nearest, then every point within the sixth's distance (to the tolerance) by a
    /// radius query.
    fn neighbours_by_two_queries(map_points: &[[f64; 2]], tree: &Tree2, p: &[f64; 2]) -> Vec<u32> {
        let mut nn = tree.nearest_n(p, NORMAL_NEIGHBOURS);
        if nn.len() == NORMAL_NEIGHBOURS {
            nn = tree.within_unsorted(p, nn[NORMAL_NEIGHBOURS - 1].distance * (1.0 + TIE_TOLERANCE));
        }
        assert!(nn.iter().all(|n| (n.item as usize) < map_points.len()));
        nn.iter().map(|n| n.item).collect()
    }

    /// One query that keeps the ties at the sixth distance finds the very points (in the same
    /// order) that the kNN query and the radius query found together, on lattices full of ties:
    /// the normals, summed in that order, are the same to the last bit.
    #[test]
    fn the_query_with_ties_finds_what_knn_and_a_radius_query_found() {
        let lattice: Vec<[f64; 2]> =
            (0..1600).map(|i| [(i % 40) as f64 * 0.05, (i / 40) as f64 * 0.05]).collect();
        let mut thick_l = Vec::new();
        for i in 0..60 {
            for j in 0..3 {
                thick_l.push([i as f64 * 0.05, j as f64 * 0.05]);
                thick_l.push([j as f64 * 0.05, 0.15 + i as f64 * 0.05]);
            }
        }
        let mut copies = vec![[1.0, 1.0]; 9];
        copies.extend((0..20).map(|i| [1.0 + i as f64 * 0.1, 1.0]));
        for pts in [lattice, thick_l, copies, vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]] {
            let tree = Tree2::new_from_slice(&pts);
            let mut tied = 0;
            for p in &pts {
                let found: Vec<u32> = tree
                    .nearest_n_with_ties(p, NORMAL_NEIGHBOURS, TIE_TOLERANCE)
                    .iter()
                    .map(|n| n.item)
                    .collect();
                let mut expected = neighbours_by_two_queries(&pts, &tree, p);
                if expected.len() < NORMAL_NEIGHBOURS {
                    // All points: the same set, in the order of the descent.
                    let mut sorted = found.clone();
                    sorted.sort_unstable();
                    expected.sort_unstable();
                    assert_eq!(sorted, expected, "{p:?}");
                } else {
                    assert_eq!(found, expected, "{p:?}");
                }
                tied += usize::from(found.len() > NORMAL_NEIGHBOURS);
            }
            assert!(pts.len() < 10 || tied * 4 > pts.len(), "{tied} of {} points with ties", pts.len());
        }
    }
}
