//! The range of a ray to the wall it stopped at, from the plan points in its stop cell (the cell
//! only says the wall is somewhere within it).

use crate::grids::wall_raster::WallRaster;
use crate::visibility::visible_points::wall_rays::Ray;

/// The range along a ray to the wall it stopped at: the along-ray distance of the wall point in
/// the stop's cell that lies nearest the ray (the cell only says the wall is somewhere within it).
pub(super) struct SurfaceRanges<'a> {
    pub(super) raster: &'a WallRaster,
    pub(super) points: &'a [[f64; 2]],
    pub(super) position: [f64; 2],
    /// The last cell looked up and its points: neighbouring rays mostly stop in the same cell.
    pub(super) cached: Option<(usize, &'a [u32])>,
}

impl<'a> SurfaceRanges<'a> {
    /// Metres along `ray` to its wall, `inf` when it stopped at none.
    pub(super) fn range(&mut self, ray: &Ray) -> f64 {
        let Some(stop) = ray.hit else { return f64::INFINITY };
        let (cols, _) = self.raster.shape();
        let cell = stop.cell.1 as usize * cols + stop.cell.0 as usize;
        let in_cell = match self.cached {
            Some((c, points)) if c == cell => points,
            _ => {
                let points = self.raster.points_in_cell(cell);
                self.cached = Some((cell, points));
                points
            }
        };
        let (dx, dy) = ray.dir;
        let mut best: Option<(f64, f64)> = None;
        for &i in in_cell {
            let Some(p) = self.points.get(i as usize) else { continue };
            let (px, py) = (p[0] - self.position[0], p[1] - self.position[1]);
            let lateral = (px * dy - py * dx).abs();
            if best.is_none_or(|(nearest, _)| lateral < nearest) {
                best = Some((lateral, px * dx + py * dy));
            }
        }
        // No point of the given ones in the cell (points that are not the raster's): the cell's
        // centre, projected on the ray, is the unbiased guess of where the ray meets its wall.
        best.map_or_else(|| self.centre_along(stop.cell, ray.dir), |(_, along)| along)
    }

    /// Metres along the unit direction `(dx, dy)` from the cast's position to the centre of `cell`,
    /// projected on the ray.
    fn centre_along(&self, cell: (i64, i64), (dx, dy): (f64, f64)) -> f64 {
        let (res, origin) = (self.raster.resolution(), self.raster.origin());
        let centre = [origin[0] + (cell.0 as f64 + 0.5) * res, origin[1] + (cell.1 as f64 + 0.5) * res];
        (centre[0] - self.position[0]) * dx + (centre[1] - self.position[1]) * dy
    }
}
