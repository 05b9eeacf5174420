//! Tests of the log-odds grid: free and occupied evidence per beam, one update per cell and scan, growth, the cell budget, bad input.

use super::*;

const RES: f64 = 0.1;

fn grid(rows: usize, cols: usize) -> LogOddsGrid {
    LogOddsGrid::new(rows, cols, RES, [0.0, 0.0], OccupancyModel::default(), 1 << 20).unwrap()
}

fn cell(g: &LogOddsGrid, c: usize, r: usize) -> (f32, bool) {
    let k = r * g.shape().1 + c;
    (g.log_odds().nth(k).unwrap(), g.observed().nth(k).unwrap())
}

#[test]
fn one_beam_marks_the_cells_before_its_end_free_and_its_end_occupied() {
    let mut g = grid(10, 10);
    // Sensor in cell (1, 5), return in cell (6, 5).
    g.integrate([0.15, 0.55], &[[0.65, 0.55]], &[], 30.0).unwrap();
    let m = OccupancyModel::default();
    for r in 0..10 {
        for c in 0..10 {
            let (l, seen) = cell(&g, c, r);
            let expected = if r == 5 && (1..6).contains(&c) {
                m.miss
            } else if r == 5 && c == 6 {
                m.hit
            } else {
                0.0
            };
            assert_eq!(l, expected, "cell ({c}, {r})");
            assert_eq!(seen, expected != 0.0, "cell ({c}, {r})");
        }
    }
    assert_eq!(g.scans(), 1);
}

#[test]
fn a_cell_is_updated_once_per_scan_and_hits_win() {
    let mut g = grid(10, 10);
    let m = OccupancyModel::default();
    // Two beams through the same cells; the second ends where the first passes.
    g.integrate([0.15, 0.55], &[[0.85, 0.55], [0.45, 0.55]], &[], 30.0).unwrap();
    assert_eq!(cell(&g, 2, 5).0, m.miss);
    assert_eq!(cell(&g, 4, 5).0, m.hit, "a hit of this scan is not cleared by another beam");
    assert_eq!(cell(&g, 8, 5).0, m.hit);
    // A second scan updates again, with clamping.
    for _ in 0..100 {
        g.integrate([0.15, 0.55], &[[0.85, 0.55]], &[], 30.0).unwrap();
    }
    assert_eq!(cell(&g, 8, 5).0, m.max);
    assert_eq!(cell(&g, 4, 5).0, m.min, "later scans saw the cell free");
}

#[test]
fn a_return_on_a_cell_boundary_occupies_the_cell_behind_it() {
    let hit = OccupancyModel::default().hit;
    // From the left, the surface x = 0.5 belongs to column 5; from the right, to column 4.
    let mut g = grid(10, 10);
    g.integrate([0.15, 0.55], &[[0.5, 0.55]], &[], 30.0).unwrap();
    assert_eq!(cell(&g, 5, 5).0, hit);
    assert!(cell(&g, 4, 5).0 < 0.0);
    let mut g = grid(10, 10);
    g.integrate([0.95, 0.55], &[[0.5, 0.55]], &[], 30.0).unwrap();
    assert_eq!(cell(&g, 4, 5).0, hit);
    assert!(cell(&g, 5, 5).0 < 0.0);
}

#[test]
fn a_beam_without_return_clears_up_to_its_end() {
    let mut g = grid(10, 10);
    g.integrate([0.15, 0.55], &[], &[[0.65, 0.55]], 30.0).unwrap();
    let m = OccupancyModel::default();
    for c in 1..=6 {
        assert_eq!(cell(&g, c, 5).0, m.miss);
    }
    assert!(!cell(&g, 7, 5).1);
}

#[test]
fn a_return_beyond_max_range_clears_up_to_max_range_only() {
    let mut g = grid(10, 10);
    g.integrate([0.15, 0.55], &[[0.95, 0.55]], &[], 0.32).unwrap();
    let m = OccupancyModel::default();
    // Cut at x = 0.47: cells 1..=4 cleared, nothing occupied.
    for c in 1..=4 {
        assert_eq!(cell(&g, c, 5).0, m.miss, "cell {c}");
    }
    for c in 5..10 {
        assert!(!cell(&g, c, 5).1, "cell {c}");
    }
}

#[test]
fn the_grid_grows_keeping_its_lattice_and_contents() {
    let mut g = grid(4, 4);
    g.integrate([0.15, 0.15], &[[0.35, 0.15]], &[], 30.0).unwrap();
    g.integrate([0.15, 0.15], &[[-0.55, 1.25]], &[], 30.0).unwrap();
    let (rows, cols) = g.shape();
    assert!(rows > 4 && cols > 4);
    let o = g.origin();
    // Still on the lattice through (0, 0).
    for v in o {
        assert!(((v / RES).round() * RES - v).abs() < 1e-12, "origin {o:?}");
    }
    // The first scan's hit is still at (0.35, 0.15).
    let c = ((0.35 - o[0]) / RES).floor() as usize;
    let r = ((0.15 - o[1]) / RES).floor() as usize;
    assert_eq!(g.log_odds().nth(r * cols + c), Some(OccupancyModel::default().hit));
    let c = ((-0.55 - o[0]) / RES).floor() as usize;
    let r = ((1.25 - o[1]) / RES).floor() as usize;
    assert_eq!(g.log_odds().nth(r * cols + c), Some(OccupancyModel::default().hit));
}

#[test]
fn a_scan_beyond_the_cell_budget_is_refused_and_the_grid_kept() {
    let mut g = LogOddsGrid::new(10, 10, RES, [0.0, 0.0], OccupancyModel::default(), 400).unwrap();
    g.integrate([0.15, 0.55], &[[0.65, 0.55]], &[], 30.0).unwrap();
    let before: Vec<f32> = g.log_odds().collect();
    let err = g.integrate([0.15, 0.55], &[[25.0, 0.55]], &[], 30.0).unwrap_err();
    assert!(matches!(err, IcpError::GridTooLarge { limit: 400, .. }), "{err}");
    assert!(g.log_odds().eq(before.iter().copied()));
    assert_eq!(g.shape(), (10, 10));
    assert_eq!(g.scans(), 1);
    // Growth that fits the budget only without padding is still done.
    g.integrate([0.15, 0.55], &[[1.45, 0.55]], &[], 30.0).unwrap();
    assert_eq!(g.shape(), (10, 15));
}

#[test]
fn a_return_on_the_coordinate_limit_is_integrated() {
    // The cell behind a surface at -1e9 m starts beyond the limit (found by the fuzz target).
    let mut g = LogOddsGrid::new(20, 20, RES, [-1e9, 0.0], OccupancyModel::default(), 1 << 20).unwrap();
    g.integrate([-1e9 + 0.5, 1.05], &[[-1e9, 1.05]], &[], 30.0).unwrap();
    assert_eq!(g.scans(), 1);
    assert!(g.origin()[0] < -1e9);
}

#[test]
fn bad_input_is_refused() {
    let mut g = grid(4, 4);
    assert!(g.integrate([f64::NAN, 0.0], &[], &[], 30.0).is_err());
    assert!(g.integrate([0.0, 0.0], &[[0.1, f64::INFINITY]], &[], 30.0).is_err());
    assert!(g.integrate([0.0, 0.0], &[], &[[2e9, 0.0]], 30.0).is_err());
    assert!(g.integrate([0.0, 0.0], &[], &[], 0.0).is_err());
    assert!(g.integrate([0.0, 0.0], &[], &[], f64::NAN).is_err());
    assert_eq!(g.scans(), 0);
    let m = OccupancyModel::default();
    for bad in [
        OccupancyModel { hit: -1.0, ..m },
        OccupancyModel { miss: 0.0, ..m },
        OccupancyModel { min: 1.0, ..m },
        OccupancyModel { max: f32::NAN, ..m },
    ] {
        assert!(LogOddsGrid::new(4, 4, RES, [0.0, 0.0], bad, 100).is_err());
    }
    assert!(LogOddsGrid::new(0, 4, RES, [0.0, 0.0], m, 100).is_err());
    assert!(LogOddsGrid::new(4, 4, 0.0, [0.0, 0.0], m, 100).is_err());
    assert!(LogOddsGrid::new(4, 4, RES, [f64::NAN, 0.0], m, 100).is_err());
    assert!(LogOddsGrid::new(20, 20, RES, [0.0, 0.0], m, 100).is_err());
}

#[test]
fn a_wall_seen_from_two_poses_stays_occupied() {
    let mut g = grid(40, 40);
    // A wall along x = 3.05 seen from two positions, beams fanning over it.
    for sensor in [[1.0, 1.0], [1.5, 3.0]] {
        let hits: Vec<[f64; 2]> = (0..30).map(|k| [3.05, 0.55 + 0.1 * k as f64]).collect();
        g.integrate(sensor, &hits, &[], 30.0).unwrap();
    }
    let hit = OccupancyModel::default().hit;
    for r in 5..35 {
        assert_eq!(g.log_odds().nth(r * 40 + 30), Some(2.0 * hit), "wall cell row {r}");
    }
}
