//! The plan as the ICP sees it: wall-surface points in metres (map frame), a KD-tree over them and
//! a visibility raster, all built once and shared read-only between alignments and threads.

use crate::cancel::{self, Cancel};
use crate::error::{check_finite, IcpError, Result};
use crate::grids::bounding_box::bounding_box;
use crate::grids::wall_raster::WallRaster;
use crate::maps::kd_tree::Tree2;
use crate::maps::nearest_wall_index::{cell_within_budget, NearestWallIndex};
use crate::maps::wall_normals::estimate_normals;
use crate::pose::Pose2;
use crate::visibility::visible_points::visible_points;
use crate::visibility::wall_facing::visibility_masks;
use crate::visibility::wall_view::{ViewScan, WallView};
use std::sync::{Mutex, OnceLock};

/// Largest number of points a map may hold (indices are `u32`).
pub const MAX_POINTS: usize = u32::MAX as usize;

/// When no raster resolution is given, the raster is coarsened until it has at most this many cells.
pub const AUTO_RASTER_MAX_CELLS: f64 = 16.0 * 1024.0 * 1024.0;

/// Default reach of the nearest-wall index, metres: the largest correspondence distance it
/// answers (alignments asking for more use the KD-tree).
pub const DEFAULT_INDEX_REACH: f64 = 0.5;

/// Finest default cell of the nearest-wall index, metres: a plan whose points lie farther apart
/// gets a cell as wide as its spacing (see [`PointMap::wall_index`]).
pub const DEFAULT_INDEX_CELL: f64 = 0.03;

/// Wall points, their KD-tree, their wall normals and their visibility raster; the nearest-wall
/// index with the visibility masks of the points is built at first use.
#[derive(Debug, Clone)]
pub struct PointMap {
    points: Vec<[f64; 2]>,
    tree: Tree2,
    raster: WallRaster,
    normals: Vec<[f64; 2]>,
    spacing: f64,
    /// The index's cell; `None`: [`DEFAULT_INDEX_CELL`] or the plan's spacing, the larger,
    /// coarsened if the plan is too large for it.
    index_cell: Option<f64>,
    index_reach: f64,
    wall_index: OnceLock<Result<NearestWallIndex>>,
    /// Held while the index is built, so that one thread builds it and the others wait.
    index_build: BuildLock,
}

/// A mutex that a cloned map gets afresh (nothing is being built in the clone).
#[derive(Debug, Default)]
struct BuildLock(Mutex<()>);

impl Clone for BuildLock {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl PointMap {
    /// Builds the map from wall points (metres, map frame). A plan denser than [`THIN_ABOVE`]
    /// points per [`THIN_CELL`] square is thinned first (see [`thinned`]): [`PointMap::points`]
    /// are the points kept.
    ///
    /// `raster_resolution` is the cell size of the visibility raster in metres; `None` estimates it
    /// from the point spacing (see [`estimate_raster_resolution`]).
    ///
    /// The wall normals are fitted here, and the build cannot be stopped: [`PointMap::build`]
    /// takes normals computed before and a cancel hook.
    pub fn new(points: Vec<[f64; 2]>, raster_resolution: Option<f64>) -> Result<Self> {
        Self::build(points, None, raster_resolution, cancel::NEVER)
    }

    /// Like [`PointMap::new`], with wall normals computed before (e.g. stored with a cached plan)
    /// instead of fitted again: one per point, unit length or `[0, 0]` (thinned with the points);
    /// `None` fits them.
    ///
    /// `cancel` is polled while the normals are fitted; when it returns true the build stops with
    /// [`IcpError::Interrupted`] (callers that cannot be cancelled pass [`cancel::NEVER`]).
    pub fn build(
        points: Vec<[f64; 2]>,
        normals: Option<Vec<[f64; 2]>>,
        raster_resolution: Option<f64>,
        cancel: Cancel<'_>,
    ) -> Result<Self> {
        if points.is_empty() {
            return Err(IcpError::Empty { what: "plan" });
        }
        if points.len() > MAX_POINTS {
            return Err(IcpError::TooFewPoints {
                what: "plan (too many points)",
                got: points.len(),
                need: MAX_POINTS,
            });
        }
        check_finite("plan", &points)?;
        if let Some(n) = &normals {
            if n.len() != points.len() {
                return Err(IcpError::InvalidParameter {
                    name: "normals",
                    value: format!("{} rows", n.len()),
                    requirement: "must have one row per plan point",
                });
            }
            check_finite("normals", n)?;
        }
        let (points, normals) = match thinned(&points) {
            None => (points, normals),
            Some(kept) => {
                let pick = |v: &[[f64; 2]]| kept.iter().map(|&i| v[i as usize]).collect::<Vec<_>>();
                (pick(&points), normals.as_deref().map(pick))
            }
        };
        let tree = Tree2::new_from_slice(&points);
        let spacing = median_spacing(&points, &tree);
        let resolution = match raster_resolution {
            Some(r) => r,
            None => estimate_raster_resolution(&points, spacing),
        };
        let raster = WallRaster::new(&points, resolution)?;
        let normals = match normals {
            Some(n) => n,
            None => estimate_normals(&points, &tree, cancel)?,
        };
        Ok(Self {
            points,
            tree,
            raster,
            normals,
            spacing,
            index_cell: None,
            index_reach: DEFAULT_INDEX_REACH,
            wall_index: OnceLock::new(),
            index_build: BuildLock::default(),
        })
    }

    /// Sets the cell and reach (metres) of the nearest-wall index, which is built at its first
    /// use (see [`PointMap::wall_index`]). Errors: values that are not positive and finite.
    pub fn with_index_settings(mut self, cell: f64, reach: f64) -> Result<Self> {
        for (name, v) in [("index cell", cell), ("index reach", reach)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(crate::error::invalid(name, v, "must be a positive finite number of metres"));
            }
        }
        self.index_cell = Some(cell);
        self.index_reach = reach;
        self.wall_index = OnceLock::new();
        Ok(self)
    }

    /// The nearest-wall index if it has been built (by [`Self::wall_index`], perhaps on another
    /// thread), without building it: for look-ups the KD-tree can answer too.
    pub fn built_wall_index(&self) -> Option<&NearestWallIndex> {
        self.wall_index.get().and_then(|built| built.as_ref().ok())
    }

    /// The nearest-wall index, with the directions each point is seen from
    /// ([`crate::visibility::wall_facing`]), built on the first call (thread-safe) and kept. Its
    /// cell, unless set ([`Self::with_index_settings`]), is [`DEFAULT_INDEX_CELL`] or the plan's
    /// spacing, the larger: a cell about as wide as the spacing meets the Voronoi regions of one or
    /// two points along a wall, which the index's two slots hold, and a finer one only multiplies
    /// the cells (a map_server map at 5 cm: 2.3 times as many at 3 cm, and as much longer a build,
    /// for the same exact answers). Threads that ask
    /// while another builds wait for its index. Errors: the index would be too large for the plan's extent at
    /// its cell size.
    ///
    /// `cancel` is polled while the index is built; when it returns true the build stops with
    /// [`IcpError::Interrupted`], is not kept, and the next call starts it again (callers that
    /// cannot be cancelled pass [`cancel::NEVER`]).
    pub fn wall_index(&self, cancel: Cancel<'_>) -> Result<&NearestWallIndex> {
        if let Some(built) = self.wall_index.get() {
            return built.as_ref().map_err(Clone::clone);
        }
        // A panic while building (a bug) poisons the lock; the index was not set, so building
        // again is sound.
        let _building = self.index_build.0.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if self.wall_index.get().is_none() {
            match self.build_wall_index(cancel) {
                Err(IcpError::Interrupted) => return Err(IcpError::Interrupted),
                outcome => {
                    // Under the lock no other thread sets it.
                    let _ = self.wall_index.set(outcome);
                }
            }
        }
        match self.wall_index.get() {
            Some(built) => built.as_ref().map_err(Clone::clone),
            None => unreachable!("set above under the build lock"),
        }
    }

    fn build_wall_index(&self, cancel: Cancel<'_>) -> Result<NearestWallIndex> {
        let cell = if let Some(cell) = self.index_cell {
            cell
        } else {
            let (lo, hi) = bounding_box(&self.points);
            let cell = DEFAULT_INDEX_CELL.max(self.spacing);
            cell_within_budget(cell, [hi[0] - lo[0], hi[1] - lo[1]], self.index_reach)
        };
        let seen = visibility_masks(&self.points, &self.normals, &self.raster, cancel)?;
        NearestWallIndex::new(&self.points, &self.tree, Some(&seen), cell, self.index_reach, cancel)
    }

    /// The wall points, metres, map frame.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }

    /// Number of wall points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Never true: a map holds at least one point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The KD-tree over all points.
    pub fn tree(&self) -> &Tree2 {
        &self.tree
    }

    /// Unit wall normal at every point (`[0, 0]` where none could be fitted).
    pub fn normals(&self) -> &[[f64; 2]] {
        &self.normals
    }

    /// Median distance between neighbouring wall points, metres (0.05 m when it cannot be told).
    pub fn spacing(&self) -> f64 {
        self.spacing
    }

    /// The visibility raster.
    pub fn raster(&self) -> &WallRaster {
        &self.raster
    }

    /// Index and squared distance of the plan point nearest to `q`.
    #[inline]
    pub fn nearest(&self, q: [f64; 2]) -> (u32, f64) {
        let nn = self.tree.nearest_one(&q);
        (nn.item, nn.distance)
    }

    /// Indices (ascending) of the wall points a range sensor at `position` sees within `max_range`
    /// metres. See [`visible_points`].
    pub fn visible_from(&self, pose: Pose2, max_range: f64) -> Result<Vec<u32>> {
        visible_points(&self.raster, [pose.x, pose.y], max_range)
    }

    /// The plan as seen from `pose` (`T_map_base`) within `max_range` metres: the visible points and
    /// the range to the first wall in `directions` evenly spaced directions, over the arc `scan`
    /// spans when given (and only as far as its returns can pair, with its pair distance); only
    /// the visible points without `with_ranges`. See [`WallView::cast`].
    pub fn view_from(
        &self,
        pose: Pose2,
        max_range: f64,
        directions: usize,
        scan: Option<ViewScan<'_>>,
        with_ranges: bool,
    ) -> Result<WallView> {
        WallView::cast(&self.raster, &self.points, pose, max_range, directions, scan, with_ranges)
    }
}

/// Side of the squares a plan denser than [`THIN_ABOVE`] points per square is thinned on, metres:
/// a sixth of the nearest-wall index's cell ([`DEFAULT_INDEX_CELL`]), a fraction of a LIDAR's
/// range noise. Plans drawn as they usually are (points 1 to 5 cm apart: an image at 2.5 cm per
/// pixel, segments sampled every 2 cm) hold about one point per square and are never thinned.
pub const THIN_CELL: f64 = 0.005;

/// A plan holding more than this many points per occupied [`THIN_CELL`] square, on average, is
/// thinned (see [`thinned`]).
pub const THIN_ABOVE: f64 = 2.0;

/// Which points a plan keeps: `None` for all of them, or, when they hold more than [`THIN_ABOVE`]
/// points per occupied [`THIN_CELL`] square on average, the indices (ascending) of the first point
/// in each occupied square.
///
/// Points far denser than that add nothing to an alignment, whose pairs are a LIDAR's centimetres
/// apart, but every part of a plan costs in proportion to them: the nearest-wall index lists,
/// per 3 cm cell, every point whose Voronoi region meets it (75 at 0.4 mm spacing), and 10^7 points
/// on two 2 km walls took 660 s to build and 3 GB for the first alignment (issue 19). Thinned, a
/// plan's size follows its walls' length, not the density it was drawn at: `O(n log n)` to find
/// the squares, then a plan of at most one point per 5 mm of wall.
pub fn thinned(points: &[[f64; 2]]) -> Option<Vec<u32>> {
    // Coordinates are checked finite and within +-1e9 m: the square numbers fit an i64.
    let mut keyed: Vec<(i64, i64, u32)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| ((p[0] / THIN_CELL).floor() as i64, (p[1] / THIN_CELL).floor() as i64, i as u32))
        .collect();
    keyed.sort_unstable();
    keyed.dedup_by_key(|k| (k.0, k.1));
    if points.len() as f64 <= THIN_ABOVE * keyed.len() as f64 {
        return None;
    }
    let mut kept: Vec<u32> = keyed.into_iter().map(|k| k.2).collect();
    kept.sort_unstable();
    Some(kept)
}

/// Median distance from a point to its nearest other point, over up to 4096 evenly strided
/// points; 0.05 m when every point coincides with another or there is only one.
pub fn median_spacing(points: &[[f64; 2]], tree: &Tree2) -> f64 {
    const FALLBACK: f64 = 0.05;
    let stride = (points.len() / 4096).max(1);
    let mut spacing: Vec<f64> = points
        .iter()
        .step_by(stride)
        .filter_map(|p| {
            let nn = tree.nearest_n(p, 2);
            nn.iter().map(|n| n.distance).find(|&d| d > 0.0).map(f64::sqrt)
        })
        .collect();
    if spacing.is_empty() {
        return FALLBACK;
    }
    let mid = spacing.len() / 2;
    let (_, median, _) = spacing.select_nth_unstable_by(mid, f64::total_cmp);
    *median
}

/// A raster cell size that keeps consecutive wall points in touching cells: 1.5 times the point
/// `spacing`, coarsened if the raster would exceed [`AUTO_RASTER_MAX_CELLS`] cells.
pub fn estimate_raster_resolution(points: &[[f64; 2]], spacing: f64) -> f64 {
    let mut resolution = 1.5 * spacing;
    let (lo, hi) = bounding_box(points);
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    let area = (w + 2.0 * resolution) * (h + 2.0 * resolution);
    if area / (resolution * resolution) > AUTO_RASTER_MAX_CELLS {
        resolution = (area / AUTO_RASTER_MAX_CELLS).sqrt() * 1.01;
    }
    // The raster has up to w / res + 3 cells across each side (margins and rounding), which the
    // area misses on a thin plan (1e9 m long, a micrometre wide): coarsen until that fits too.
    while (w / resolution + 3.0) * (h / resolution + 3.0) > AUTO_RASTER_MAX_CELLS {
        resolution *= 1.25;
    }
    resolution
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn tree_matches_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        // Wall-like data: many points share an axis value.
        let mut pts = Vec::new();
        for i in 0..2000 {
            let t = i as f64 * 0.01;
            pts.push([t, 0.0]);
            pts.push([0.0, t]);
            pts.push([rng.random_range(-5.0..25.0), rng.random_range(-5.0..25.0)]);
        }
        let map = PointMap::new(pts.clone(), None).unwrap();
        for _ in 0..2000 {
            let q = [rng.random_range(-10.0..30.0), rng.random_range(-10.0..30.0)];
            let (idx, d2) = map.nearest(q);
            let best = pts
                .iter()
                .map(|p| (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2))
                .fold(f64::INFINITY, f64::min);
            assert!((d2 - best).abs() < 1e-12, "tree {d2} vs brute force {best}");
            let p = pts[idx as usize];
            assert!(((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) - d2).abs() < 1e-12);
        }
    }

    #[test]
    fn rejects_empty_and_non_finite_plans() {
        assert_eq!(PointMap::new(vec![], None).unwrap_err(), IcpError::Empty { what: "plan" });
        assert_eq!(
            PointMap::new(vec![[0.0, 0.0], [f64::NAN, 1.0]], None).unwrap_err(),
            IcpError::NonFinite { what: "plan", row: 1 }
        );
    }

    #[test]
    fn a_build_asked_to_stop_stops() {
        let pts: Vec<[f64; 2]> = (0..10_000).map(|i| [i as f64 * 0.01, 0.0]).collect();
        assert_eq!(PointMap::build(pts.clone(), None, None, &|| true).unwrap_err(), IcpError::Interrupted);
        // With normals given there is nothing long to poll in.
        let normals = vec![[0.0, 1.0]; pts.len()];
        assert!(PointMap::build(pts, Some(normals), None, &|| true).is_ok());
    }

    /// Two 20 m walls drawn at `spacing` metres.
    fn two_walls(spacing: f64) -> Vec<[f64; 2]> {
        let n = (20.0 / spacing).round() as usize;
        let mut pts: Vec<[f64; 2]> = (0..=n).map(|i| [i as f64 * spacing, 0.0]).collect();
        pts.extend((0..=n).map(|i| [i as f64 * spacing, 3.0]));
        pts
    }

    #[test]
    fn a_plan_far_denser_than_useful_is_thinned_to_its_walls_length() {
        // Ordinary densities keep every point, as given.
        for spacing in [0.05, 0.02, 0.005] {
            let pts = two_walls(spacing);
            assert_eq!(thinned(&pts), None, "{spacing} m");
            assert_eq!(PointMap::new(pts.clone(), None).unwrap().points(), &pts[..]);
        }
        // 10 and 100 times denser than a point per THIN_CELL: the same plan size, one point per
        // square along the walls (20 m / 5 mm + 1 per wall), so the same work to build and use.
        let sizes: Vec<usize> =
            [5e-4, 5e-5].iter().map(|&s| PointMap::new(two_walls(s), None).unwrap().len()).collect();
        assert_eq!(sizes, vec![2 * 4001, 2 * 4001]);
        // Copies of a point are one point; normals given are thinned with their points.
        let mut pts = vec![[1.0, 1.0]; 1000];
        pts.extend(two_walls(0.05));
        let normals: Vec<[f64; 2]> =
            (0..pts.len()).map(|i| if i < 1000 { [1.0, 0.0] } else { [0.0, 1.0] }).collect();
        let map = PointMap::build(pts.clone(), Some(normals), None, cancel::NEVER).unwrap();
        assert_eq!(map.len(), pts.len() - 999);
        assert_eq!(map.points()[0], [1.0, 1.0]);
        assert_eq!(map.normals()[0], [1.0, 0.0]);
        assert!(map.normals()[1..].iter().all(|n| *n == [0.0, 1.0]));
    }

    #[test]
    fn given_normals_are_used_and_checked() {
        let pts: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 0.05, 0.0]).collect();
        let fitted = PointMap::new(pts.clone(), None).unwrap();
        let given =
            PointMap::build(pts.clone(), Some(fitted.normals().to_vec()), None, cancel::NEVER).unwrap();
        assert_eq!(given.normals(), fitted.normals());
        assert!(matches!(
            PointMap::build(pts.clone(), Some(vec![[0.0, 1.0]; 3]), None, cancel::NEVER),
            Err(IcpError::InvalidParameter { name: "normals", .. })
        ));
        assert!(matches!(
            PointMap::build(pts, Some(vec![[f64::NAN, 1.0]; 100]), None, cancel::NEVER),
            Err(IcpError::NonFinite { what: "normals", row: 0 })
        ));
    }

    #[test]
    fn a_thin_plan_a_billion_metres_long_gets_a_raster_that_fits() {
        // Found by the core fuzz target `point_map`: points a nanometre apart along a line, plus
        // one point 1e9 m away. The area-based estimate gave 6 mm cells (the plan's area is
        // tiny), i.e. 1.6e11 columns of 3 rows, and the plan was refused although no resolution
        // had been asked for.
        let mut pts: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 1e-9, i as f64 * 1e-9]).collect();
        pts.push([1e9, 0.0]);
        let map = PointMap::new(pts, None).unwrap();
        let (cols, rows) = map.raster().shape();
        assert!((cols * rows) as f64 <= AUTO_RASTER_MAX_CELLS, "{cols} x {rows}");
    }

    #[test]
    fn a_plan_checks_its_index_settings_and_coarsens_a_default_cell_that_would_not_fit() {
        let pts: Vec<[f64; 2]> = (0..100).map(|i| [i as f64 * 0.05, 0.0]).collect();
        for (cell, reach) in [(0.0, 0.5), (0.03, f64::NAN), (-1.0, 0.5)] {
            assert!(matches!(
                PointMap::new(pts.clone(), None).unwrap().with_index_settings(cell, reach),
                Err(IcpError::InvalidParameter { .. })
            ));
        }
        let custom = PointMap::new(pts.clone(), None).unwrap().with_index_settings(0.05, 0.25).unwrap();
        let index = custom.wall_index(cancel::NEVER).unwrap();
        assert_eq!((index.cell(), index.reach()), (0.05, 0.25));
        // 1 km across: the default 3 cm cell would need over 2^28 cells, so it is coarsened; an
        // explicit one is refused.
        let mut wide = pts.clone();
        wide.push([1000.0, 1000.0]);
        let map = PointMap::new(wide.clone(), None).unwrap();
        assert!(map.wall_index(cancel::NEVER).unwrap().cell() > DEFAULT_INDEX_CELL);
        let explicit = PointMap::new(wide, None).unwrap().with_index_settings(0.01, 0.5).unwrap();
        assert!(matches!(explicit.wall_index(cancel::NEVER), Err(IcpError::RasterTooLarge { .. })));
    }

    #[test]
    fn the_default_index_cell_follows_a_coarse_spacing_and_stays_exact() {
        // An occupancy grid's wall cells, 5 cm apart: a room 4 x 3 m with walls two cells thick.
        let mut pts = Vec::new();
        for i in 0..=80 {
            for j in 0..=60 {
                let (x, y) = (i as f64 * 0.05, j as f64 * 0.05);
                if i <= 1 || i >= 79 || j <= 1 || j >= 59 {
                    pts.push([x, y]);
                }
            }
        }
        let coarse = PointMap::new(pts.clone(), None).unwrap();
        assert!((coarse.spacing() - 0.05).abs() < 1e-9);
        let index = coarse.wall_index(cancel::NEVER).unwrap();
        assert!((index.cell() - 0.05).abs() < 1e-9, "{}", index.cell());
        // A plan sampled every 2 cm keeps the finest default.
        let fine: Vec<[f64; 2]> = (0..200).map(|i| [i as f64 * 0.02, 0.0]).collect();
        let fine = PointMap::new(fine, None).unwrap();
        assert_eq!(fine.wall_index(cancel::NEVER).unwrap().cell(), DEFAULT_INDEX_CELL);
        // Every look-up within reach is the KD-tree's nearest point.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..5000 {
            let q = [rng.random_range(-0.6..4.6), rng.random_range(-0.6..3.6)];
            let exact = coarse.tree().nearest_one(&q).distance;
            match index.nearest(q) {
                Some((i, d2)) => {
                    assert!((d2 - exact).abs() < 1e-12, "{q:?}: {d2} vs {exact}");
                    let p = coarse.points()[i as usize];
                    assert!(((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) - exact).abs() < 1e-12);
                }
                None => {
                    assert!(exact > index.reach().powi(2), "{q:?}: none within reach, nearest {exact} m^2")
                }
            }
        }
    }

    #[test]
    fn estimated_resolution_follows_spacing() {
        let pts: Vec<[f64; 2]> = (0..1000).map(|i| [i as f64 * 0.02, 0.0]).collect();
        let map = PointMap::new(pts, None).unwrap();
        assert!((map.raster().resolution() - 0.03).abs() < 1e-9);
        let single = PointMap::new(vec![[1.0, 1.0]], None).unwrap();
        assert!((single.raster().resolution() - 0.075).abs() < 1e-12);
        assert!((single.spacing() - 0.05).abs() < 1e-12);
    }
}
