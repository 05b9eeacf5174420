//! The fuzz harness shared by the `fuzz_*` integration tests: seeded cases, panics caught and
//! reported with the seed that replays them, a watchdog that turns a hang into a report, and
//! generators of hostile inputs (NaN, inf, huge, tiny, empty, duplicate and collinear points).
//!
//! Environment:
//! - `PLANICP_FUZZ_CASES`: base number of cases per target (default 200; cheap targets run a
//!   multiple of it, see [`run`]).
//! - `PLANICP_FUZZ_SEED`: replay one case with this seed, printing its inputs (the seed of a
//!   failing case is in its report).
//! - `PLANICP_FUZZ_CASE_SECONDS`: a case running longer than this is a hang (default 120).

#![allow(dead_code)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Base case count when `PLANICP_FUZZ_CASES` is not set (the CI run).
pub const DEFAULT_CASES: u64 = 200;

/// What one case reports when a property does not hold.
pub type Outcome = std::result::Result<(), String>;

/// A case's inputs and checks: a random source plus, when replaying, a printer of the inputs.
pub struct Case {
    /// The random source of the case.
    pub rng: ChaCha8Rng,
    /// Print inputs (replay of one seed).
    pub verbose: bool,
}

impl Case {
    /// Prints `what` when replaying a single case.
    pub fn note(&self, what: impl FnOnce() -> String) {
        if self.verbose {
            let mut s = what();
            if s.len() > 4000 {
                s.truncate(4000);
                s.push_str(" ...");
            }
            eprintln!("  input: {s}");
        }
    }

    /// True with probability `p`.
    pub fn coin(&mut self, p: f64) -> bool {
        self.rng.random_bool(p.clamp(0.0, 1.0))
    }

    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        self.rng.random_range(0..n)
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.rng.random::<f64>()
    }

    /// One of `items`.
    pub fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.below(items.len())]
    }

    /// A value from the edge of `f64` and of the core's documented limits.
    pub fn special(&mut self) -> f64 {
        self.pick(SPECIALS)
    }

    /// A magnitude from 1e-300 to 1e300, biased to the ones a building has.
    pub fn scale(&mut self) -> f64 {
        self.pick(&[1e-300, 1e-12, 1e-6, 1e-3, 0.05, 1.0, 1.0, 1.0, 10.0, 1e3, 1e6, 1e9, 1e12, 1e300])
    }

    /// Mostly an ordinary value in `[lo, hi)`, sometimes a special one.
    pub fn f64_or_special(&mut self, lo: f64, hi: f64, p_special: f64) -> f64 {
        if self.coin(p_special) {
            self.special()
        } else {
            self.uniform(lo, hi)
        }
    }

    /// A point set of a random kind: empty, a few points, duplicates, collinear points, the walls
    /// of a room, a cloud; then sometimes scaled, shifted or with one coordinate replaced by a
    /// special value. At most `max_n` points.
    pub fn points(&mut self, max_n: usize) -> Vec<[f64; 2]> {
        let max_n = max_n.max(4);
        let mut pts: Vec<[f64; 2]> = match self.below(8) {
            0 => Vec::new(),
            1 => (0..1 + self.below(3)).map(|_| [self.uniform(-5.0, 5.0), self.uniform(-5.0, 5.0)]).collect(),
            2 => {
                let p = [self.uniform(-5.0, 5.0), self.uniform(-5.0, 5.0)];
                vec![p; 1 + self.below(max_n.min(500))]
            }
            3 => {
                let (a, d) = ([self.uniform(-5.0, 5.0), self.uniform(-5.0, 5.0)], self.uniform(-3.2, 3.2));
                let step = self.pick(&[0.0, 1e-9, 0.01, 0.05, 0.3]);
                let n = 2 + self.below(max_n.min(800));
                (0..n).map(|i| [a[0] + i as f64 * step * d.cos(), a[1] + i as f64 * step * d.sin()]).collect()
            }
            4 | 5 => {
                let w = self.uniform(0.5, 20.0);
                let h = self.uniform(0.5, 20.0);
                let spacing = self.pick(&[0.02, 0.05, 0.05, 0.1, 0.5]);
                room(w, h, spacing, max_n)
            }
            6 => {
                let r = self.uniform(0.1, 30.0);
                (0..1 + self.below(max_n.min(2000)))
                    .map(|_| [self.uniform(-r, r), self.uniform(-r, r)])
                    .collect()
            }
            _ => (0..1 + self.below(12)).map(|_| [self.special(), self.special()]).collect(),
        };
        pts.truncate(max_n);
        if !pts.is_empty() && self.coin(0.15) {
            let s = self.scale();
            pts.iter_mut().for_each(|p| *p = [p[0] * s, p[1] * s]);
        }
        if !pts.is_empty() && self.coin(0.1) {
            let o = [self.scale() * self.pick(&[-1.0, 1.0]), self.scale() * self.pick(&[-1.0, 1.0])];
            pts.iter_mut().for_each(|p| *p = [p[0] + o[0], p[1] + o[1]]);
        }
        if !pts.is_empty() && self.coin(0.1) {
            let (i, k) = (self.below(pts.len()), self.below(2));
            pts[i][k] = self.special();
        }
        pts
    }
}

/// Boundary values: signed zeros, NaN, infinities, the core's coordinate limit and its
/// neighbours, the extremes of `f64`, subnormals, the end of exact integers and of `i64`.
pub const SPECIALS: &[f64] = &[
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    1e9,
    -1e9,
    1.000_000_000_000_001e9,
    -1.000_000_000_000_001e9,
    1e18,
    9.3e18,
    1e300,
    -1e300,
    1e-300,
    -1e-300,
    5e-324,
    f64::MAX,
    f64::MIN,
    f64::MIN_POSITIVE,
    f64::EPSILON,
    9_007_199_254_740_992.0,
    1e-6,
    1e-4,
    1e6,
];

/// Wall points of a `w x h` rectangle every `spacing` metres, at most `max_n`.
pub fn room(w: f64, h: f64, spacing: f64, max_n: usize) -> Vec<[f64; 2]> {
    let mut pts = Vec::new();
    for (a, b) in [([0.0, 0.0], [w, 0.0]), ([w, 0.0], [w, h]), ([w, h], [0.0, h]), ([0.0, h], [0.0, 0.0])] {
        let n = ((w.max(h) / spacing) as usize).clamp(1, max_n);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let k = ((len / spacing).round() as usize).clamp(1, n);
        for i in 0..k {
            let t = i as f64 / k as f64;
            pts.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    pts.truncate(max_n);
    pts
}

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().and_then(|v| v.trim().parse().ok())
}

/// Number of cases for a target of relative cost `weight` (1 for the costliest).
pub fn cases(weight: u64) -> u64 {
    env_u64("PLANICP_FUZZ_CASES").unwrap_or(DEFAULT_CASES) * weight
}

/// Seed of case `i` of target `name`: a hash of the name plus `i`, so that targets differ.
fn seed_of(name: &str, i: u64) -> u64 {
    let h = name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3));
    h.wrapping_add(i.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// Runs `cases(weight)` cases of `body` (or the one case `PLANICP_FUZZ_SEED` names, verbosely).
/// A panic, a violated property or a case over the time limit fails the test with the case's seed.
pub fn run(name: &str, weight: u64, body: impl Fn(&mut Case) -> Outcome) {
    let replay = env_u64("PLANICP_FUZZ_SEED");
    let n = if replay.is_some() { 1 } else { cases(weight) };
    let limit = Duration::from_secs(env_u64("PLANICP_FUZZ_CASE_SECONDS").unwrap_or(120));
    let current = Arc::new(AtomicU64::new(0));
    let started = Arc::new(std::sync::Mutex::new(Instant::now()));
    let done = Arc::new(AtomicBool::new(false));
    let watchdog = {
        let (current, started, done, name) =
            (current.clone(), started.clone(), done.clone(), name.to_string());
        std::thread::spawn(move || {
            while !done.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(200));
                let since = started.lock().map(|s| s.elapsed()).unwrap_or_default();
                if since > limit && !done.load(Ordering::Relaxed) {
                    eprintln!(
                        "fuzz target {name}: HANG, case with seed {} still running after {since:?}; \
                         replay: PLANICP_FUZZ_SEED={} cargo test -p icp_core --test <file> {name}",
                        current.load(Ordering::Relaxed),
                        current.load(Ordering::Relaxed),
                    );
                    std::process::abort();
                }
            }
        })
    };
    let t0 = Instant::now();
    let mut slowest = (Duration::ZERO, 0u64);
    let mut failure = None;
    let mut executed = 0u64;
    for i in 0..n {
        executed += 1;
        let seed = replay.unwrap_or_else(|| seed_of(name, i));
        current.store(seed, Ordering::Relaxed);
        *started.lock().expect("watchdog lock") = Instant::now();
        let mut case = Case { rng: ChaCha8Rng::seed_from_u64(seed), verbose: replay.is_some() };
        let t = Instant::now();
        let result = catch_unwind(AssertUnwindSafe(|| body(&mut case)));
        let took = t.elapsed();
        if took > slowest.0 {
            slowest = (took, seed);
        }
        let why = match result {
            Ok(Ok(())) => continue,
            Ok(Err(msg)) => format!("property violated: {msg}"),
            Err(panic) => {
                let msg = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                format!("PANIC: {msg}")
            }
        };
        failure = Some(format!(
            "fuzz target {name}, case {i}, seed {seed}: {why}\n  replay with inputs printed: \
             PLANICP_FUZZ_SEED={seed} cargo test -p icp_core --test <file> {name} -- --nocapture"
        ));
        break;
    }
    done.store(true, Ordering::Relaxed);
    let _ = watchdog.join();
    eprintln!(
        "fuzz target {name}: {executed} cases in {:.2?} (slowest {:.2?}, seed {})",
        t0.elapsed(),
        slowest.0,
        slowest.1
    );
    if let Some(f) = failure {
        panic!("{f}");
    }
}

/// Checks `cond`, else fails the case with `msg`.
macro_rules! ensure {
    ($cond:expr, $($msg:tt)+) => {
        let holds: bool = $cond;
        if !holds {
            return Err(format!($($msg)+));
        }
    };
}

/// An error must say what is wrong.
pub fn clear_error(e: &icp_core::IcpError) -> Outcome {
    let msg = e.to_string();
    if msg.trim().is_empty() {
        return Err(format!("empty error message for {e:?}"));
    }
    Ok(())
}

/// Whether every coordinate is finite and within the core's coordinate limit.
pub fn in_range(points: &[[f64; 2]]) -> bool {
    points.iter().all(|p| p.iter().all(|v| v.is_finite() && v.abs() <= icp_core::error::MAX_COORDINATE))
}
