//! The axis-aligned box around a set of points (a plan's, a scan's): what a raster over them spans.

/// `(lo, hi)`: the lowest and highest x and y of `points` (metres); `([inf, inf], [-inf, -inf])`
/// for no points. A NaN coordinate is skipped (`f64::min`/`max` ignore it): callers that must not
/// skip one check the points first.
pub fn bounding_box(points: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_the_points_and_is_empty_for_none() {
        assert_eq!(bounding_box(&[[1.0, -2.0], [-3.0, 4.0], [0.5, 0.5]]), ([-3.0, -2.0], [1.0, 4.0]));
        assert_eq!(bounding_box(&[]), ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]));
    }
}
