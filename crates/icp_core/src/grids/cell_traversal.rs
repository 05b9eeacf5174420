//! The cells a straight segment passes through on a square grid (Amanatides-Woo traversal).
//!
//! Coordinates are in cell units: cell `(col, row)` covers `[col, col + 1) x [row, row + 1)`. The
//! walk is 4-connected and visits exactly `|end_col - start_col| + |end_row - start_row| + 1`
//! cells, from the cell of the start point to the cell of the end point, each once. Where the
//! segment passes exactly through a cell corner it steps along x first, so it enters one of the two
//! cells it grazes there (a 4-connected walk must).

/// Calls `visit(col, row)` for every cell the segment from `start` to `end` (cell units) passes
/// through, in order, including both end cells. Both points must be finite.
#[inline]
pub fn for_each_cell(start: [f64; 2], end: [f64; 2], mut visit: impl FnMut(i64, i64)) {
    let (mut col, mut row) = (start[0].floor() as i64, start[1].floor() as i64);
    let (end_col, end_row) = (end[0].floor() as i64, end[1].floor() as i64);
    let (dx, dy) = (end[0] - start[0], end[1] - start[1]);
    let step_x: i64 = if end_col >= col { 1 } else { -1 };
    let step_y: i64 = if end_row >= row { 1 } else { -1 };
    // The number of grid lines crossed along each axis is fixed by the end cells; counting them
    // down (rather than comparing parameters to the end) makes the walk end in the end cell
    // whatever the rounding of the crossing parameters.
    let mut left_x = (end_col - col).abs();
    let mut left_y = (end_row - row).abs();
    let (mut t_x, delta_x) = first_crossing(start[0], col, dx, step_x);
    let (mut t_y, delta_y) = first_crossing(start[1], row, dy, step_y);
    visit(col, row);
    while left_x > 0 || left_y > 0 {
        if left_y == 0 || (left_x > 0 && t_x <= t_y) {
            col += step_x;
            t_x += delta_x;
            left_x -= 1;
        } else {
            row += step_y;
            t_y += delta_y;
            left_y -= 1;
        }
        visit(col, row);
    }
}

/// The segment parameter (0 at the start, 1 at the end) of the first crossing of a grid line along
/// one axis, and the parameter between consecutive crossings. `inf` when the segment does not move
/// along the axis.
#[inline]
fn first_crossing(p: f64, cell: i64, d: f64, step: i64) -> (f64, f64) {
    if d == 0.0 {
        return (f64::INFINITY, f64::INFINITY);
    }
    let boundary = if step > 0 { (cell + 1) as f64 } else { cell as f64 };
    let inv = 1.0 / d.abs();
    ((boundary - p).abs() * inv, inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells(start: [f64; 2], end: [f64; 2]) -> Vec<(i64, i64)> {
        let mut out = Vec::new();
        for_each_cell(start, end, |c, r| out.push((c, r)));
        out
    }

    #[test]
    fn a_horizontal_segment_visits_the_cells_of_its_row() {
        assert_eq!(cells([0.5, 2.5], [3.2, 2.5]), vec![(0, 2), (1, 2), (2, 2), (3, 2)]);
        assert_eq!(cells([3.2, 2.5], [0.5, 2.5]), vec![(3, 2), (2, 2), (1, 2), (0, 2)]);
    }

    #[test]
    fn a_segment_inside_one_cell_visits_only_it() {
        assert_eq!(cells([1.1, 1.1], [1.9, 1.8]), vec![(1, 1)]);
    }

    #[test]
    fn a_diagonal_segment_visits_the_cells_it_crosses() {
        // From (0.5, 0.2) to (2.5, 1.2): y = 0.2 + 0.5 (x - 0.5); crosses y = 1 at x = 2.1.
        assert_eq!(cells([0.5, 0.2], [2.5, 1.2]), vec![(0, 0), (1, 0), (2, 0), (2, 1)]);
        // Negative directions and negative cells.
        assert_eq!(cells([-0.5, -0.2], [-2.5, -1.2]), vec![(-1, -1), (-2, -1), (-3, -1), (-3, -2)]);
    }

    #[test]
    fn a_segment_through_a_corner_enters_one_grazed_cell() {
        assert_eq!(cells([0.5, 0.5], [1.5, 1.5]), vec![(0, 0), (1, 0), (1, 1)]);
    }

    #[test]
    fn every_walk_is_4_connected_and_ends_in_the_end_cell() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 40.0 - 20.0
        };
        for _ in 0..2000 {
            let (a, b) = ([next(), next()], [next(), next()]);
            let v = cells(a, b);
            let expected = (b[0].floor() - a[0].floor()).abs() + (b[1].floor() - a[1].floor()).abs() + 1.0;
            assert_eq!(v.len(), expected as usize);
            assert_eq!(v[0], (a[0].floor() as i64, a[1].floor() as i64));
            assert_eq!(*v.last().unwrap(), (b[0].floor() as i64, b[1].floor() as i64));
            for w in v.windows(2) {
                assert_eq!((w[1].0 - w[0].0).abs() + (w[1].1 - w[0].1).abs(), 1);
            }
            // Every visited cell is within a cell's diagonal of the segment.
            for &(c, r) in &v {
                let (cx, cy) = (c as f64 + 0.5, r as f64 + 0.5);
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let len2 = dx * dx + dy * dy;
                let t = if len2 > 0.0 {
                    (((cx - a[0]) * dx + (cy - a[1]) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let d = ((cx - a[0] - t * dx).powi(2) + (cy - a[1] - t * dy).powi(2)).sqrt();
                assert!(
                    d <= std::f64::consts::FRAC_1_SQRT_2 + 1e-9,
                    "cell ({c}, {r}) is {d} from the segment"
                );
            }
        }
    }
}
