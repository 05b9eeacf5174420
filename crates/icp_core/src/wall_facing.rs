//! Which side of a wall face its points look out from: the outward (free-space) normal of every
//! plan point, so that a pairing with the far face of a wall can be refused without ray casting.
//!
//! A plan drawn with thick walls gives two parallel faces a wall's thickness apart, with nothing
//! between them in the point set. From a point on one face, march along both directions of its
//! (unoriented) wall normal through the plan's [`WallRaster`]: leave the face's own cells, cross
//! free cells, and note the distance of the next wall cell. The side that meets another face within
//! [`WALL_THICKNESS_LIMIT`], while the other side stays free at least twice as far and
//! [`WALL_MARGIN`] farther, is the inside of the wall; the normal points the other way. Points
//! where that cannot be told (a single-line wall, a corner, a wall thicker than the limit, a gap
//! narrower than it on both sides) are two-sided: visible from anywhere, as without this module.
//!
//! The known misreading: a one-line (thin) wall beside a space narrower than
//! [`WALL_THICKNESS_LIMIT`] on one side only looks like a thick wall's face; that space is then
//! taken for the wall's inside. No robot fits in such a space.

use crate::wall_raster::WallRaster;

/// Thickest wall whose faces are told apart, metres.
pub const WALL_THICKNESS_LIMIT: f64 = 0.45;
/// How much farther than the inside the outside must stay free, metres.
pub const WALL_MARGIN: f64 = 0.3;
/// Farthest a march looks, metres...
const MARCH_LIMIT: f64 = 1.5;
/// ...and in steps of half a raster cell (a plan sampled at micrometres would march forever).
const MARCH_STEPS: usize = 1024;

/// Outward unit normal per point, or `[0, 0]` for a two-sided point. `normals` are the plan's
/// unoriented wall normals (`[0, 0]` where none was fitted).
pub fn outward_normals(points: &[[f64; 2]], normals: &[[f64; 2]], raster: &WallRaster) -> Vec<[f32; 2]> {
    points
        .iter()
        .zip(normals)
        .map(|(&p, &n)| {
            if n == [0.0, 0.0] {
                return [0.0, 0.0];
            }
            let ahead = next_face(raster, p, n);
            let behind = next_face(raster, p, [-n[0], -n[1]]);
            let inside_is = |near: Option<f64>, far: Option<f64>| match near {
                Some(d) if d <= WALL_THICKNESS_LIMIT => {
                    far.is_none_or(|f| f >= (2.0 * d).max(d + WALL_MARGIN))
                }
                _ => false,
            };
            if inside_is(behind, ahead) {
                [n[0] as f32, n[1] as f32]
            } else if inside_is(ahead, behind) {
                [-n[0] as f32, -n[1] as f32]
            } else {
                [0.0, 0.0]
            }
        })
        .collect()
}

/// Distance from `p` along the unit direction `d` to the first wall cell past the free cells that
/// follow `p`'s own run of wall cells; `None` within [`MARCH_LIMIT`].
fn next_face(raster: &WallRaster, p: [f64; 2], d: [f64; 2]) -> Option<f64> {
    let res = raster.resolution();
    let origin = raster.origin();
    let step = 0.5 * res;
    let mut left_own_face = false;
    let limit = MARCH_LIMIT.min(MARCH_STEPS as f64 * step);
    let mut t = step;
    while t <= limit {
        let x = ((p[0] + t * d[0] - origin[0]) / res).floor() as i64;
        let y = ((p[1] + t * d[1] - origin[1]) / res).floor() as i64;
        let wall = raster.is_wall(x, y);
        if !left_own_face {
            left_own_face = !wall;
        } else if wall {
            return Some(t);
        }
        t += step;
    }
    None
}

/// Whether a point with outward normal `outward` at `p` faces a sensor at `sensor`: two-sided
/// points always do; others when the sensor lies on the outward side, with a grazing tolerance of
/// about 6 degrees.
#[inline]
pub fn faces(outward: [f32; 2], p: [f64; 2], sensor: [f64; 2]) -> bool {
    let (dx, dy) = (sensor[0] - p[0], sensor[1] - p[1]);
    let dot = outward[0] as f64 * dx + outward[1] as f64 * dy;
    dot >= 0.0 || dot * dot <= GRAZING_SQ * (dx * dx + dy * dy)
}

/// sin^2 of the grazing tolerance of [`faces`].
pub const GRAZING_SQ: f64 = 0.01;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::covariance::estimate_normals;
    use crate::point_map::Tree2;

    fn sample(pts: &mut Vec<[f64; 2]>, a: [f64; 2], b: [f64; 2]) {
        let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / 0.05).round() as usize;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }

    #[test]
    fn thick_wall_faces_look_out_and_a_thin_wall_is_two_sided() {
        let mut pts = Vec::new();
        // A 0.2 m thick wall along x between rooms (faces at y = 0 and y = 0.2)...
        sample(&mut pts, [0.0, 0.0], [6.0, 0.0]);
        sample(&mut pts, [0.0, 0.2], [6.0, 0.2]);
        let thick = pts.len();
        // ...and a one-line wall far from everything.
        sample(&mut pts, [10.0, -3.0], [10.0, 3.0]);
        let tree = Tree2::new_from_slice(&pts);
        let normals = estimate_normals(&pts, &tree);
        let raster = WallRaster::new(&pts, 0.075).unwrap();
        let out = outward_normals(&pts, &normals, &raster);
        for (i, p) in pts.iter().enumerate() {
            // Away from the wall ends, where the faces are clear.
            if p[0] < 0.5 || (p[0] > 5.5 && p[0] < 9.0) {
                continue;
            }
            let o = out[i];
            if i < thick {
                let expected = if p[1] < 0.1 { -1.0 } else { 1.0 };
                assert!((o[1] - expected).abs() < 1e-3 && o[0].abs() < 1e-3, "{p:?}: {o:?}");
                assert!(faces(o, *p, [3.0, 3.0 * expected as f64]));
                assert!(!faces(o, *p, [3.0, -3.0 * expected as f64]));
            } else {
                assert_eq!(o, [0.0, 0.0], "{p:?}");
                assert!(faces(o, *p, [0.0, 0.0]) && faces(o, *p, [20.0, 0.0]));
            }
        }
        // Grazing views still count.
        assert!(faces([0.0, 1.0], [0.0, 0.0], [10.0, -0.5]));
        assert!(!faces([0.0, 1.0], [0.0, 0.0], [10.0, -2.0]));
    }
}
