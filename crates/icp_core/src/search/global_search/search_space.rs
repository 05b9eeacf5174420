//! The space a global search covers: the scan thinned to the search's cells, the rotations swept
//! (a fixed step or one from the scan's extent) and the lattice of translations over the window or
//! the plan, laid out as a [`SearchRun`] that has scored nothing yet.

use crate::error::{check_finite, invalid, IcpError, Result};
use crate::pose::{wrap_angle, Pose2};
use crate::search::global_search::branch_and_bound::SearchRun;
use crate::search::global_search::node_scoring::{BestList, RotatedScan};
use crate::search::global_search::{GlobalMatcher, SearchWindow, MAX_ROTATIONS, MIN_SEARCH_POINTS};
use std::collections::BinaryHeap;
use std::f64::consts::PI;

impl GlobalMatcher {
    /// Thins `scan` (robot frame, metres) to one point per cell, then to at most
    /// `max_scan_points` by an even stride.
    pub fn thin_scan(&self, scan: &[[f64; 2]]) -> Result<Vec<[f64; 2]>> {
        if scan.is_empty() {
            return Err(IcpError::Empty { what: "scan" });
        }
        check_finite("scan", scan)?;
        let res = self.config.resolution;
        let mut keyed: Vec<((i64, i64), usize)> = scan
            .iter()
            .enumerate()
            .map(|(i, p)| (((p[0] / res).floor() as i64, (p[1] / res).floor() as i64), i))
            .collect();
        keyed.sort_unstable();
        keyed.dedup_by_key(|k| k.0);
        let mut kept: Vec<usize> = keyed.into_iter().map(|(_, i)| i).collect();
        kept.sort_unstable();
        if kept.len() < MIN_SEARCH_POINTS {
            return Err(IcpError::TooFewPoints {
                what: "scan (one point per search cell)",
                got: kept.len(),
                need: MIN_SEARCH_POINTS,
            });
        }
        let stride = kept.len().div_ceil(self.config.max_scan_points);
        Ok(kept.into_iter().step_by(stride).map(|i| scan[i]).collect())
    }

    /// The rotation step for `points`: far points move by about one cell per step.
    fn angular_step(&self, points: &[[f64; 2]]) -> f64 {
        if let Some(step) = self.config.angular_step {
            return step.min(PI);
        }
        let mut ranges: Vec<f64> = points.iter().map(|p| p[0].hypot(p[1])).collect();
        let k = (ranges.len() * 95 / 100).min(ranges.len() - 1);
        let (_, r, _) = ranges.select_nth_unstable_by(k, f64::total_cmp);
        let r = r.max(self.config.resolution);
        let res = self.config.resolution;
        let step = (1.0 - res * res / (2.0 * r * r)).clamp(-1.0, 1.0).acos();
        step.min(self.config.max_angular_step)
    }
    /// A search of the whole plan (`window` `None`) or a window for `scan` (robot frame, metres)
    /// that has not scored any node yet: [`SearchRun::advance`] does the work a budget of nodes
    /// at a time, and a run advanced to its end finds what [`GlobalMatcher::search`] finds.
    pub fn start(&self, scan: &[[f64; 2]], window: Option<&SearchWindow>) -> Result<SearchRun> {
        if let Some(w) = window {
            w.validate()?;
        }
        let points = self.thin_scan(scan)?;
        let res = self.config.resolution;
        let step = self.angular_step(&points);
        // Per rotation: its heading and the centre of its square of positions.
        let (half_cells, rotations) = match window {
            None => {
                let [lo, hi] = self.bounds;
                let center = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
                let half = [((hi[0] - lo[0]) / 2.0 / res).ceil(), ((hi[1] - lo[1]) / 2.0 / res).ceil()];
                (half, full_circle(step)?.into_iter().map(|yaw| (yaw, center)).collect::<Vec<_>>())
            }
            Some(w) => {
                // A window wider than the plan along an axis is the plan's extent there (the whole
                // plan's search covers exactly that extent): a huge window costs no more than the
                // whole plan. Any other window is searched as given, on its own lattice. (Clipping
                // every window to the plan moved the lattice of those near its edges by up to half
                // a cell and left a window beyond them a single position; fhw's recovery, over
                // odometry seeds 1-5, then lost 63-84 % of the scans instead of 43-60 %.)
                let [lo, hi] = self.bounds;
                let whole = |axis: usize| 2.0 * w.half_width >= hi[axis] - lo[axis];
                let half = |axis: usize| {
                    if whole(axis) {
                        ((hi[axis] - lo[axis]) / 2.0 / res).ceil()
                    } else {
                        (w.half_width / res).ceil()
                    }
                };
                let centre = |c: f64, axis: usize| if whole(axis) { (lo[axis] + hi[axis]) / 2.0 } else { c };
                let yaws = if w.half_angle >= PI {
                    full_circle(step)?
                } else {
                    let m = (w.half_angle / step).ceil() as i64;
                    let n = (2 * m + 1) as usize;
                    if n > MAX_ROTATIONS {
                        return Err(rotations_error(n));
                    }
                    let d = if m > 0 { w.half_angle / m as f64 } else { 0.0 };
                    (-m..=m).map(|k| w.center.yaw + k as f64 * d).collect()
                };
                let rotations = yaws
                    .into_iter()
                    .map(|yaw| {
                        let [cx, cy] = w.center_at(yaw);
                        (yaw, [centre(cx, 0), centre(cy, 1)])
                    })
                    .collect();
                ([half(0), half(1)], rotations)
            }
        };
        // The lattice must fit in i32 offsets and in the node budget's meaning.
        if !(half_cells[0] < 1e8 && half_cells[1] < 1e8) {
            return Err(invalid(
                "window half_width",
                half_cells[0].max(half_cells[1]) * res,
                "is too large for the search lattice; search a smaller window",
            ));
        }
        let (wx, wy) = (half_cells[0] as i32, half_cells[1] as i32);
        let rotated: Vec<RotatedScan> = rotations
            .iter()
            .map(|&(yaw, center)| {
                let pose = Pose2::new(center[0], center[1], yaw);
                let cells = points.iter().map(|p| self.pyramid.cell_of(pose.transform_point(*p))).collect();
                RotatedScan { yaw, center, cells }
            })
            .collect();
        let top = self.config.levels - 1;
        let block = 1i64 << top;
        let blocks = |w: i32| ((2 * i64::from(w)) / block + 1) as usize;
        Ok(SearchRun {
            rotated,
            inv_n: 1.0 / (255.0 * points.len() as f32),
            limits: [wx, wy],
            nodes: 0,
            max_nodes: self.config.max_nodes,
            complete: true,
            finished: false,
            best: BestList {
                entries: Vec::new(),
                capacity: self.config.max_candidates,
                floor: self.config.min_score,
                relative: self.config.relative_score,
                nms_distance: self.config.nms_distance,
                nms_angle: self.config.nms_angle,
            },
            res,
            step,
            scan_points: points.len(),
            top,
            root_blocks: [blocks(wx), blocks(wy)],
            next_root: 0,
            roots: Vec::new(),
            queue: BinaryHeap::new(),
        })
    }
}

fn rotations_error(n: usize) -> IcpError {
    invalid(
        "angular_step",
        format!("{n} rotations"),
        "would sweep more than 20000 rotations; give a larger step",
    )
}

/// Headings `k * step'` around the circle, `step'` the largest divisor of 2 pi not above `step`.
fn full_circle(step: f64) -> Result<Vec<f64>> {
    let n = (2.0 * PI / step).ceil().max(1.0);
    if n > MAX_ROTATIONS as f64 {
        return Err(rotations_error(n as usize));
    }
    let n = n as usize;
    Ok((0..n).map(|k| wrap_angle(k as f64 * 2.0 * PI / n as f64)).collect())
}
