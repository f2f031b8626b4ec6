//! The bad-input sweep over the public API, shared by the `bad_input_*` tests (one
//! per concern: sensing and kinematics, contours, paths, control, codec, machines).
//!
//! Every call site takes one value that replaces one input of a nominal call (a
//! config field, a point coordinate, a reference, a measurement) and runs the call,
//! and what it builds, a few steps. Each site is fed every value of [`VALUES`] (NaN,
//! ±inf, 0, negative, 1e±30, f32 and f64 extremes) in f32 and in f64 where the code is
//! generic, plus degenerate geometries. A case ends in one of:
//!
//! - a typed error (or, for a machine, a latched fault: the supervisor then writes the
//!   safe outputs),
//! - finite outputs,
//! - non-finite outputs passed through by a pure kernel whose docs say so, from a
//!   non-finite input or one so large (|v| ≥ 1e30) that the arithmetic overflows,
//! - non-finite outputs otherwise: a failure,
//! - a panic (caught per case): a failure.
//!
//! `cargo test -p host-tests --test 'bad_input_*' -- --nocapture` prints a table per
//! module and every failure; each test asserts that there are none.

use kerf::sensing::hall::HallConfig;
use kerf::trajectory::Reference;
use kerf::{Float, Real};
use nalgebra::{Vector2, Vector3};
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The bad values every site is fed (and 1.0 as a sanity case that must pass).
pub const VALUES: [f64; 21] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    0.0,
    -0.0,
    -1.0,
    1.0,
    1e30,
    -1e30,
    1e-30,
    -1e-30,
    f32::MAX as f64,
    -(f32::MAX as f64),
    3.5e38, // just beyond f32
    1e-39,  // f32 subnormal
    1e-46,  // below f32's smallest subnormal
    f32::MIN_POSITIVE as f64,
    f32::EPSILON as f64,
    f64::MAX,
    f64::MIN_POSITIVE,
    f64::EPSILON,
];

/// What one case ended in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Out {
    /// A typed error, or a latched fault with the safe outputs.
    Refused,
    /// Accepted, every output finite.
    Finite,
    /// Accepted, some output NaN or infinite.
    NonFinite,
    /// Accepted, outputs finite, but a contour follower's step is longer than the arc
    /// it was commanded: θ ran away.
    Runaway,
}

impl Out {
    /// The worse of two outcomes (non-finite, then runaway, then refused, then finite).
    pub fn and(self, other: Out) -> Out {
        match (self, other) {
            (Out::NonFinite, _) | (_, Out::NonFinite) => Out::NonFinite,
            (Out::Runaway, _) | (_, Out::Runaway) => Out::Runaway,
            (Out::Refused, _) | (_, Out::Refused) => Out::Refused,
            _ => Out::Finite,
        }
    }
}

/// How a site's input enters the call.
#[derive(Clone, Copy, PartialEq)]
pub enum Kind {
    /// A configuration value (f64): any finite value must end refused or finite.
    Config,
    /// A per-period input of the public API (converted to the scalar): a non-finite
    /// one must be refused (or latch a fault), a finite one refused or finite.
    Step,
    /// A pure hot-path kernel documented to pass non-finite input, and the overflow
    /// of huge input, through to its output.
    Kernel,
}

#[derive(Default, Clone)]
struct Tally {
    cases: usize,
    refused: usize,
    finite: usize,
    passed_through: usize,
    non_finite: usize,
    panics: usize,
}

/// The cases run so far, tallied per module, and their failures.
pub struct Sweep {
    tallies: BTreeMap<&'static str, Tally>,
    failures: Vec<String>,
}

thread_local! {
    static PANIC_MESSAGE: RefCell<String> = const { RefCell::new(String::new()) };
}

fn finite_in(scalar: &str, v: f64) -> bool {
    if scalar == "f32" {
        (v as f32).is_finite()
    } else {
        v.is_finite()
    }
}

impl Sweep {
    fn new() -> Self {
        Self {
            tallies: BTreeMap::new(),
            failures: Vec::new(),
        }
    }

    /// Runs one case and files it under `module`.
    pub fn case(
        &mut self,
        module: &'static str,
        site: &str,
        scalar: &str,
        kind: Kind,
        v: f64,
        call: impl FnOnce() -> Out,
    ) {
        let outcome = catch_unwind(AssertUnwindSafe(call));
        let tally = self.tallies.entry(module).or_default();
        tally.cases += 1;
        let input_finite = match kind {
            Kind::Config => v.is_finite(),
            Kind::Step | Kind::Kernel => finite_in(scalar, v),
        };
        match outcome {
            Ok(Out::Refused) => tally.refused += 1,
            Ok(Out::Finite) => tally.finite += 1,
            Ok(Out::NonFinite) => {
                let huge = !input_finite || v.abs() >= 1e30;
                if kind == Kind::Kernel && huge {
                    tally.passed_through += 1;
                } else {
                    tally.non_finite += 1;
                    self.failures.push(format!(
                        "{module}: {site} [{scalar}] v = {v:e}: non-finite output"
                    ));
                }
            }
            Ok(Out::Runaway) => {
                tally.non_finite += 1;
                self.failures.push(format!(
                    "{module}: {site} [{scalar}] v = {v:e}: theta runs away"
                ));
            }
            Err(_) => {
                tally.panics += 1;
                let message = PANIC_MESSAGE.with(|m| m.borrow().clone());
                self.failures.push(format!(
                    "{module}: {site} [{scalar}] v = {v:e}: panic: {message}"
                ));
            }
        }
    }

    /// Feeds every value of [`VALUES`] to `call`.
    pub fn site(
        &mut self,
        module: &'static str,
        site: &str,
        scalar: &str,
        kind: Kind,
        call: impl Fn(f64) -> Out,
    ) {
        for v in VALUES {
            self.case(module, site, scalar, kind, v, || call(v));
        }
    }

    fn print(&self) {
        println!(
            "{:<12} {:>6} {:>8} {:>7} {:>8} {:>11} {:>7}",
            "module", "cases", "refused", "finite", "passed", "non-finite", "panics"
        );
        for (module, t) in &self.tallies {
            println!(
                "{:<12} {:>6} {:>8} {:>7} {:>8} {:>11} {:>7}",
                module, t.cases, t.refused, t.finite, t.passed_through, t.non_finite, t.panics
            );
        }
        println!("(refused: typed error or latched fault with safe outputs; passed: non-finite or overflowing input passed through by a documented pure kernel)");
        for f in &self.failures {
            println!("FAIL {f}");
        }
    }
}

/// Finite when every value is.
pub fn finite<T: Real>(values: impl IntoIterator<Item = T>) -> Out {
    if values.into_iter().all(|v| v.is_finite()) {
        Out::Finite
    } else {
        Out::NonFinite
    }
}

/// [`finite`] for f64 values.
pub fn finite_f64(values: impl IntoIterator<Item = f64>) -> Out {
    finite(values)
}

/// Refused on an error, else what `then` makes of the value.
pub fn refused_or<X, E>(result: Result<X, E>, then: impl FnOnce(X) -> Out) -> Out {
    match result {
        Ok(x) => then(x),
        Err(_) => Out::Refused,
    }
}

/// Refused on `None`, else what `then` makes of the value.
pub fn some_or<X>(option: Option<X>, then: impl FnOnce(X) -> Out) -> Out {
    match option {
        Some(x) => then(x),
        None => Out::Refused,
    }
}

/// A reference's position, velocity and acceleration.
pub fn reference_values<T: Real>(r: &Reference<T>) -> [T; 3] {
    [r.position, r.velocity, r.acceleration]
}

/// A 3-vector's components.
pub fn v3<T: Float>(v: &Vector3<T>) -> [T; 3] {
    [v.x, v.y, v.z]
}

/// A 2-vector's components.
pub fn v2<T: Float>(v: &Vector2<T>) -> [T; 2] {
    [v.x, v.y]
}

/// Nominal LM1247 Hall counts at phase `phi` (rad).
pub fn counts(phi: f64) -> [u16; 3] {
    let c = HallConfig::LM1247_16BIT;
    let ch = |k: usize, s: f64| {
        (f64::from(c.calibration.offset_counts[k]) + c.amplitude_counts * (phi + s).sin()).round()
            as u16
    };
    [ch(0, 0.0), ch(1, 2.0 * PI / 3.0), ch(2, -2.0 * PI / 3.0)]
}

/// A measurement made of `v`: channel 0 reads `v` counts (saturating cast).
pub fn bad_counts(v: f64) -> [u16; 3] {
    let mut c = counts(0.3);
    c[0] = v as u16;
    c
}

/// `v` as f64 (`Real::to_f64`).
pub fn to_t<T: Real>(v: T) -> f64 {
    Real::to_f64(v)
}

/// `v` in the scalar (`Real::from_f64`, named apart from nalgebra's conversions).
pub fn re<T: Real>(v: f64) -> T {
    <T as Real>::from_f64(v)
}

/// Runs `sites` with panics caught per case, prints the table and every failure, and
/// asserts that no case gave a non-finite output or panicked.
pub fn sweep(sites: impl FnOnce(&mut Sweep)) {
    std::panic::set_hook(Box::new(|info| {
        let message = info.to_string();
        PANIC_MESSAGE.with(|m| *m.borrow_mut() = message);
    }));
    let mut s = Sweep::new();
    sites(&mut s);
    let _ = std::panic::take_hook();
    s.print();
    let non_finite: usize = s.tallies.values().map(|t| t.non_finite).sum();
    let panics: usize = s.tallies.values().map(|t| t.panics).sum();
    assert_eq!((non_finite, panics), (0, 0), "see the FAIL lines above");
}
