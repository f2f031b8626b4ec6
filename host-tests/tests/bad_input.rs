//! Bad-input sweep over the public API, module by module.
//!
//! Every call site below takes one value that replaces one input of a nominal call (a
//! config field, a point coordinate, a reference, a measurement) and runs the call,
//! and what it builds, a few steps. Each site is fed every value of [`VALUES`] (NaN,
//! ±inf, 0, negative, 1e±30, f32 and f64 extremes) in f32 and in f64 where the code is
//! generic, plus the degenerate geometries of [`degenerate_geometry`]. A case ends in
//! one of:
//!
//! - a typed error (or, for a machine, a latched fault: the supervisor then writes the
//!   safe outputs),
//! - finite outputs,
//! - non-finite outputs passed through by a pure kernel whose docs say so, from a
//!   non-finite input or one so large (|v| ≥ 1e30) that the arithmetic overflows,
//! - non-finite outputs otherwise: a failure,
//! - a panic (caught per case): a failure.
//!
//! `cargo test -p host-tests --test bad_input -- --nocapture` prints a table per module
//! and every failure; the test asserts that there are none.

use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, AxisStatus, HallAxis};
use kerf::app::delta_slave::{DeltaJob, DeltaSlave, DeltaSlaveConfig, SlaveOutputs};
use kerf::app::joints::{JointJob, Joints, JointsConfig, Segment};
use kerf::app::stream::SignalSender;
use kerf::app::supervisor::{Machine, Step};
use kerf::app::PeriodClock;
use kerf::codec::dct::Dct;
use kerf::codec::packet::{self, PacketDecoder};
use kerf::codec::sdct::{Block, SdctConfig, SdctDecoder, SdctEncoder, Selection};
use kerf::control::dob::{Dob, DobConfig, DobState};
use kerf::control::pd::{Pd, PdConfig, Reference};
use kerf::hal::{FrameLink, LinkBusy};
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::sensing::hall::{HallConfig, HallDecoder, HallState};
use kerf::sensing::velocity::{TrackingObserver, TrackingObserverConfig, TrackingObserverState};
use kerf::trajectory::constraint::{
    fit_geometric, fit_kasa, fit_taubin, ConstraintConfig, MotionConstraint,
};
use kerf::trajectory::efd::Efd;
use kerf::trajectory::quintic::Quintic;
use kerf::trajectory::resample::{self, ArcResampler};
use kerf::trajectory::shapes;
use kerf::trajectory::spline::{JointSpline, KnotTiming};
use kerf::trajectory::tangential::{
    max_speed_m_s, ContourFollower, FollowerConfig, SpeedRamp, SpeedRampConfig,
};
use kerf::{Float, Real};
use nalgebra::{Vector2, Vector3};
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// The bad values every site is fed (and 1.0 as a sanity case that must pass).
const VALUES: [f64; 21] = [
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
enum Out {
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
    fn and(self, other: Out) -> Out {
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
enum Kind {
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

struct Sweep {
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
    fn case(
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
    fn site(
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

fn finite<T: Real>(values: impl IntoIterator<Item = T>) -> Out {
    if values.into_iter().all(|v| v.is_finite()) {
        Out::Finite
    } else {
        Out::NonFinite
    }
}

fn finite_f64(values: impl IntoIterator<Item = f64>) -> Out {
    finite(values)
}

fn refused_or<X, E>(result: Result<X, E>, then: impl FnOnce(X) -> Out) -> Out {
    match result {
        Ok(x) => then(x),
        Err(_) => Out::Refused,
    }
}

fn some_or<X>(option: Option<X>, then: impl FnOnce(X) -> Out) -> Out {
    match option {
        Some(x) => then(x),
        None => Out::Refused,
    }
}

fn reference_values<T: Real>(r: &Reference<T>) -> [T; 3] {
    [r.position, r.velocity, r.acceleration]
}

fn v3<T: Float>(v: &Vector3<T>) -> [T; 3] {
    [v.x, v.y, v.z]
}

fn v2<T: Float>(v: &Vector2<T>) -> [T; 2] {
    [v.x, v.y]
}

/// Nominal LM1247 Hall counts at phase `phi` (rad).
fn counts(phi: f64) -> [u16; 3] {
    let c = HallConfig::LM1247_16BIT;
    let ch = |k: usize, s: f64| {
        (f64::from(c.calibration.offset_counts[k]) + c.amplitude_counts * (phi + s).sin()).round()
            as u16
    };
    [ch(0, 0.0), ch(1, 2.0 * PI / 3.0), ch(2, -2.0 * PI / 3.0)]
}

/// A measurement made of `v`: channel 0 reads `v` counts (saturating cast).
fn bad_counts(v: f64) -> [u16; 3] {
    let mut c = counts(0.3);
    c[0] = v as u16;
    c
}

// ---------------------------------------------------------------------------------
// sensing

fn hall_sites(s: &mut Sweep) {
    const M: &str = "sensing";
    type Edit = fn(&mut HallConfig, f64);
    let edits: [(&str, Edit); 10] = [
        ("pitch_m", |c, v| c.pitch_m = v),
        ("fault_error_budget_m", |c, v| c.fault_error_budget_m = v),
        ("amplitude_counts", |c, v| c.amplitude_counts = v),
        ("magnitude_band.0", |c, v| c.magnitude_band.0 = v),
        ("magnitude_band.1", |c, v| c.magnitude_band.1 = v),
        ("sum_limit", |c, v| c.sum_limit = v),
        ("calibration.offset_counts[0]", |c, v| {
            c.calibration.offset_counts[0] = v as f32
        }),
        ("calibration.sin_row[1]", |c, v| {
            c.calibration.sin_row[1] = v as f32
        }),
        ("calibration.cos_row[2]", |c, v| {
            c.calibration.cos_row[2] = v as f32
        }),
        ("calibration.sum_row[0]", |c, v| {
            c.calibration.sum_row[0] = v as f32
        }),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("HallDecoder::new({field}) + update"),
            "-",
            Kind::Config,
            |v| {
                let mut config = HallConfig::LM1247_16BIT;
                edit(&mut config, v);
                refused_or(HallDecoder::new(&config), |decoder| {
                    let mut state = HallState::default();
                    let mut out = Out::Finite;
                    for k in 0..8 {
                        let r = decoder.update(&mut state, counts(0.4 * k as f64), 0);
                        out = out.and(refused_or(r, |p| finite_f64([p.position_m(0.018)])));
                    }
                    out
                })
            },
        );
    }
    s.site(
        M,
        "HallDecoder::update(predicted_step)",
        "-",
        Kind::Step,
        |v| {
            let decoder = HallDecoder::new(&HallConfig::LM1247_16BIT).unwrap();
            let mut state = HallState::default();
            let step = (v * 4_294_967_296.0) as i64;
            let mut out = Out::Finite;
            for k in 0..4 {
                let r = decoder.update(&mut state, counts(0.2 * k as f64), step);
                out = out.and(refused_or(r, |p| finite_f64([p.position_m(0.018)])));
            }
            out
        },
    );
    s.site(M, "HallDecoder::update(counts)", "-", Kind::Step, |v| {
        let decoder = HallDecoder::new(&HallConfig::LM1247_16BIT).unwrap();
        let mut state = HallState::default();
        let r = decoder.update(&mut state, bad_counts(v), 0);
        refused_or(r, |p| finite_f64([p.position_m(0.018)]))
    });
    observer_sites::<f32>(s, "f32");
    observer_sites::<f64>(s, "f64");
}

fn observer_sites<T: Real>(s: &mut Sweep, scalar: &str) {
    const M: &str = "sensing";
    let nominal = TrackingObserverConfig {
        bandwidth_rad_s: 2.0 * PI * 600.0,
    };
    let run = |observer: TrackingObserver<T>| {
        let mut state = TrackingObserverState::at_rest(T::ZERO);
        let mut values = Vec::new();
        for k in 0..20 {
            values.push(observer.update(&mut state, re::<T>(1e-5 * k as f64), T::ZERO));
        }
        finite(values)
    };
    s.site(
        M,
        "TrackingObserver::new(bandwidth_rad_s)",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                TrackingObserver::<T>::new(&TrackingObserverConfig { bandwidth_rad_s: v }, 1e-4),
                run,
            )
        },
    );
    s.site(
        M,
        "TrackingObserver::new(ts_s)",
        scalar,
        Kind::Config,
        |v| refused_or(TrackingObserver::<T>::new(&nominal, v), run),
    );
    // The bandwidth scaled with the period (ω·Ts = 0.4 stays valid), so only the
    // period's own extremes matter.
    s.site(
        M,
        "TrackingObserver::new(ts_s, ω·Ts = 0.4)",
        scalar,
        Kind::Config,
        |v| {
            let config = TrackingObserverConfig {
                bandwidth_rad_s: 0.4 / v,
            };
            refused_or(TrackingObserver::<T>::new(&config, v), run)
        },
    );
    let observer = TrackingObserver::<T>::new(&nominal, 1e-4).unwrap();
    s.site(
        M,
        "TrackingObserver::update(measured)",
        scalar,
        Kind::Kernel,
        |v| {
            let mut state = TrackingObserverState::at_rest(T::ZERO);
            finite([
                observer.update(&mut state, re::<T>(v), T::ZERO),
                state.position,
            ])
        },
    );
    s.site(
        M,
        "TrackingObserver::update(acceleration)",
        scalar,
        Kind::Kernel,
        |v| {
            let mut state = TrackingObserverState::at_rest(T::ZERO);
            finite([
                observer.update(&mut state, T::ZERO, re::<T>(v)),
                state.position,
            ])
        },
    );
}

// ---------------------------------------------------------------------------------
// kinematics

fn delta_sites<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "kinematics";
    let nominal = DeltaConfig::SLAVE_KEOPS;
    let q_mid = Vector3::new(0.02, 0.02, 0.02);
    let probe = |g: &DeltaGeometry<T>| {
        let q = q_mid.map(re::<T>);
        refused_or(g.forward(&q), |p| {
            finite(v3(&p)).and(refused_or(g.inverse(&p), |q| finite(v3(&q))))
        })
    };
    type Edit = fn(&mut DeltaConfig, f64);
    let edits: [(&str, Edit); 7] = [
        ("theta_rad", |c, v| c.actuators[1].theta_rad = v),
        ("alpha_rad", |c, v| c.actuators[1].alpha_rad = v),
        ("arm_m", |c, v| c.actuators[1].arm_m = v),
        ("base_radius_m", |c, v| c.actuators[1].base_radius_m = v),
        ("effector_radius_m", |c, v| {
            c.actuators[1].effector_radius_m = v
        }),
        ("travel_min_m", |c, v| c.actuators[1].travel_min_m = v),
        ("travel_max_m", |c, v| c.actuators[1].travel_max_m = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("DeltaGeometry::new({field}) + FK/IK"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = nominal;
                edit(&mut config, v);
                refused_or(DeltaGeometry::<T>::new(&config), |g| probe(&g))
            },
        );
    }
    // All lengths scaled by v: a robot of any size, up to what the scalar holds.
    s.site(
        M,
        "DeltaGeometry::new(all lengths × v) + FK/IK",
        scalar,
        Kind::Config,
        |v| {
            let mut config = nominal;
            for a in &mut config.actuators {
                a.arm_m *= v;
                a.base_radius_m *= v;
                a.effector_radius_m *= v;
                a.travel_min_m *= v;
                a.travel_max_m *= v;
            }
            refused_or(DeltaGeometry::<T>::new(&config), |g| {
                let q = (q_mid * v).map(re::<T>);
                refused_or(g.forward(&q), |p| {
                    finite(v3(&p)).and(refused_or(g.inverse(&p), |q| finite(v3(&q))))
                })
            })
        },
    );
    let g = DeltaGeometry::<T>::new(&nominal).unwrap();
    let p_mid = g.forward(&q_mid.map(re::<T>)).unwrap();
    for axis in 0..3 {
        s.site(M, &format!("forward(q[{axis}])"), scalar, Kind::Step, |v| {
            let mut q = q_mid.map(re::<T>);
            q[axis] = re::<T>(v);
            refused_or(g.forward(&q), |p| finite(v3(&p)))
        });
        s.site(M, &format!("inverse(p[{axis}])"), scalar, Kind::Step, |v| {
            let mut p = p_mid;
            p[axis] = re::<T>(v);
            refused_or(g.inverse(&p), |q| finite(v3(&q)))
        });
        s.site(
            M,
            &format!("jacobian(q[{axis}]), jacobian(p[{axis}])"),
            scalar,
            Kind::Step,
            |v| {
                let (mut q, mut p) = (q_mid.map(re::<T>), p_mid);
                q[axis] = re::<T>(v);
                let a = refused_or(g.jacobian(&q, &p_mid), |j| finite(j.iter().copied()));
                p[axis] = re::<T>(v);
                let q = q_mid.map(re::<T>);
                a.and(refused_or(g.jacobian(&q, &p), |j| {
                    finite(j.iter().copied())
                }))
            },
        );
        s.site(
            M,
            &format!("jacobian_inverse(p[{axis}])"),
            scalar,
            Kind::Step,
            |v| {
                let mut p = p_mid;
                p[axis] = re::<T>(v);
                let q = q_mid.map(re::<T>);
                refused_or(g.jacobian_inverse(&q, &p), |j| finite(j.iter().copied()))
            },
        );
        s.site(
            M,
            &format!("jacobian_derivative(q_dot[{axis}])"),
            scalar,
            Kind::Step,
            |v| {
                let mut q_dot = Vector3::new(T::ZERO, T::ZERO, T::ZERO);
                q_dot[axis] = re::<T>(v);
                let q = q_mid.map(re::<T>);
                refused_or(g.jacobian_derivative(&q, &p_mid, &q_dot), |j| {
                    finite(j.iter().copied())
                })
            },
        );
    }
    // Geometry: the travel box's corners and beyond, and rays from the workspace
    // centre out past the reach (arms stretched: singular J1, then out of reach).
    let corners: Vec<Vector3<f64>> = (0..27)
        .map(|k| {
            let pick =
                |i: usize| [-0.01, 0.0, 0.04, 0.05][(k / 3usize.pow(i as u32)) % 3 + (k % 2)];
            Vector3::new(pick(0), pick(1), pick(2))
        })
        .collect();
    for (i, q) in corners.iter().enumerate() {
        s.case(
            M,
            "forward/jacobians at travel corners",
            scalar,
            Kind::Step,
            i as f64,
            || {
                let q = q.map(re::<T>);
                refused_or(g.forward(&q), |p| {
                    let j = refused_or(g.jacobian(&q, &p), |j| finite(j.iter().copied()));
                    let ji = refused_or(g.jacobian_inverse(&q, &p), |j| finite(j.iter().copied()));
                    finite(v3(&p)).and(j).and(ji)
                })
            },
        );
    }
    for direction in 0..12 {
        let angle = direction as f64 * PI / 6.0;
        for step in 0..24 {
            let reach = 0.005 * step as f64;
            let elevation = if direction % 2 == 0 { 0.0 } else { reach };
            s.case(
                M,
                "IK/jacobians on rays past the reach",
                scalar,
                Kind::Step,
                reach,
                || {
                    let p = Vector3::new(
                        to_t::<T>(p_mid.x) + reach * angle.cos(),
                        to_t::<T>(p_mid.y) + reach * angle.sin(),
                        to_t::<T>(p_mid.z) + elevation,
                    )
                    .map(re::<T>);
                    refused_or(g.inverse(&p), |q| {
                        let j = refused_or(g.jacobian(&q, &p), |j| finite(j.iter().copied()));
                        let jd = refused_or(
                            g.jacobian_derivative(
                                &q,
                                &p,
                                &Vector3::new(T::one(), T::ZERO, T::ZERO),
                            ),
                            |j| finite(j.iter().copied()),
                        );
                        finite(v3(&q)).and(j).and(jd)
                    })
                },
            );
        }
    }
}

fn to_t<T: Real>(v: T) -> f64 {
    Real::to_f64(v)
}

/// `v` in the scalar (`Real::from_f64`, named apart from nalgebra's conversions).
fn re<T: Real>(v: f64) -> T {
    <T as Real>::from_f64(v)
}

// ---------------------------------------------------------------------------------
// trajectory

fn follower_config() -> FollowerConfig {
    FollowerConfig {
        ramp: SpeedRampConfig {
            speed_m_s: 0.01,
            accel_m_s2: 0.5,
            jerk_m_s3: 50.0,
            ts_s: 1e-3,
        },
        accel_limit_m_s2: 10.0,
        newton_steps: 2,
    }
}

/// Steps a follower `periods` times: every output finite, and each step's chord at
/// most the arc the ramp commanded (plus rounding): θ must not run away.
fn follow<T: Float, const N: usize>(mut f: ContourFollower<T, N>, periods: usize) -> Out {
    let speed = to_t(f.ramp().speed());
    let ts = follower_ts(&f);
    f.start();
    let mut previous: Option<Vector2<T>> = None;
    for _ in 0..periods {
        let Ok(r) = f.step() else {
            return Out::Refused;
        };
        let out = finite(
            v2(&r.position)
                .into_iter()
                .chain(v2(&r.velocity))
                .chain(v2(&r.acceleration))
                .chain(v2(&r.jerk))
                .chain([r.speed, r.theta]),
        );
        if out != Out::Finite {
            return out;
        }
        if let Some(p) = previous {
            let chord = to_t((r.position - p).norm());
            if chord > 1.5 * speed * ts + 1e-9 {
                return Out::Runaway;
            }
        }
        previous = Some(r.position);
    }
    Out::Finite
}

fn follower_ts<T: Float, const N: usize>(_: &ContourFollower<T, N>) -> f64 {
    1e-3
}

fn efd_probe<T: Float, const N: usize>(efd: &Efd<T, N>) -> Out {
    let mut out =
        finite(efd.coefficients().iter().flatten().copied()).and(finite(v2(&efd.centre())));
    for k in 0..16 {
        let s = efd.evaluate(re::<T>(k as f64 * 0.4));
        out = out.and(finite(
            v2(&s.position)
                .into_iter()
                .chain(v2(&s.d1))
                .chain(v2(&s.d2))
                .chain(v2(&s.d3)),
        ));
    }
    out
}

fn trajectory_sites<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "trajectory";
    let octagon = shapes::octagon();
    // Efd
    s.site(
        M,
        "Efd::from_polygon(point[3].x) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let mut p = octagon;
            p[3][0] = v;
            refused_or(Efd::<T, 10>::from_polygon(&p, 10), |e| efd_probe(&e))
        },
    );
    s.site(
        M,
        "Efd::from_polygon(points × v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let p = octagon.map(|[x, y]| [x * v, y * v]);
            refused_or(Efd::<T, 10>::from_polygon(&p, 10), |e| efd_probe(&e))
        },
    );
    s.site(
        M,
        "Efd::from_polygon(points + v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let p = octagon.map(|[x, y]| [x + v, y - v]);
            refused_or(Efd::<T, 10>::from_polygon(&p, 10), |e| efd_probe(&e))
        },
    );
    s.site(
        M,
        "Efd::from_coefficients(b1) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                Efd::<T, 4>::from_coefficients(
                    [0.0, 0.0],
                    &[[0.01, v, 0.0, 0.01], [1e-3, 0.0, 0.0, 0.0]],
                ),
                |e| efd_probe(&e),
            )
        },
    );
    s.site(
        M,
        "Efd::from_coefficients(centre) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                Efd::<T, 4>::from_coefficients([v, 0.0], &[[0.01, 0.0, 0.0, 0.01]]),
                |e| efd_probe(&e),
            )
        },
    );
    let efd = Efd::<T, 10>::from_polygon(&octagon, 10).unwrap();
    s.site(M, "Efd::evaluate(theta)", scalar, Kind::Kernel, |v| {
        let s = efd.evaluate(re::<T>(v));
        finite(
            v2(&s.position)
                .into_iter()
                .chain(v2(&s.d1))
                .chain(v2(&s.d2))
                .chain(v2(&s.d3)),
        )
    });
    s.site(
        M,
        "Efd::arc_length/curvature(theta)",
        scalar,
        Kind::Kernel,
        |v| {
            let t = re::<T>(v);
            finite([efd.arc_length(T::ZERO, t, 8), efd.curvature(t)])
        },
    );
    s.site(M, "max_speed_m_s(accel_limit)", scalar, Kind::Config, |v| {
        refused_or(max_speed_m_s(&efd, v), |speed| finite_f64([speed]))
    });
    // ContourFollower
    type Edit = fn(&mut FollowerConfig, f64);
    let edits: [(&str, Edit); 5] = [
        ("speed_m_s", |c, v| c.ramp.speed_m_s = v),
        ("accel_m_s2", |c, v| c.ramp.accel_m_s2 = v),
        ("jerk_m_s3", |c, v| c.ramp.jerk_m_s3 = v),
        ("ts_s", |c, v| c.ramp.ts_s = v),
        ("accel_limit_m_s2", |c, v| c.accel_limit_m_s2 = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("ContourFollower::new({field}) + step"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = follower_config();
                edit(&mut config, v);
                refused_or(ContourFollower::new(efd, &config, 0.0), |f| {
                    // Only the chord check needs the nominal period.
                    let mut f = f;
                    f.start();
                    let mut out = Out::Finite;
                    for _ in 0..300 {
                        let Ok(r) = f.step() else {
                            return Out::Refused;
                        };
                        out = out.and(finite(
                            v2(&r.position)
                                .into_iter()
                                .chain(v2(&r.velocity))
                                .chain(v2(&r.acceleration))
                                .chain(v2(&r.jerk))
                                .chain([r.speed, r.theta]),
                        ));
                    }
                    out
                })
            },
        );
    }
    s.site(
        M,
        "ContourFollower::new(theta0) + step",
        scalar,
        Kind::Config,
        |v| {
            refused_or(ContourFollower::new(efd, &follower_config(), v), |f| {
                follow(f, 300)
            })
        },
    );
    // SpeedRamp
    type RampEdit = fn(&mut SpeedRampConfig, f64);
    let ramp_edits: [(&str, RampEdit); 4] = [
        ("speed_m_s", |c, v| c.speed_m_s = v),
        ("accel_m_s2", |c, v| c.accel_m_s2 = v),
        ("jerk_m_s3", |c, v| c.jerk_m_s3 = v),
        ("ts_s", |c, v| c.ts_s = v),
    ];
    for (field, edit) in ramp_edits {
        s.site(
            M,
            &format!("SpeedRamp::new({field}) + step"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = follower_config().ramp;
                edit(&mut config, v);
                refused_or(SpeedRamp::<T>::new(&config), |mut r| {
                    r.start();
                    let mut out = Out::Finite;
                    for k in 0..400 {
                        if k == 200 {
                            r.stop();
                        }
                        let p = r.step();
                        out = out.and(finite([p.ds, p.v, p.a, p.j]));
                    }
                    out.and(finite_f64([r.ramp_distance_m()]))
                })
            },
        );
    }
    // Quintic
    type QuinticArgs = fn(f64) -> (f64, f64, f64);
    let quintic_args: [(&str, QuinticArgs); 3] = [
        ("start_m", |v| (v, 0.03, 0.4)),
        ("distance_m", |v| (0.0, v, 0.4)),
        ("duration_s", |v| (0.0, 0.03, v)),
    ];
    for (field, args) in quintic_args {
        s.site(
            M,
            &format!("Quintic::new({field}) + sample"),
            scalar,
            Kind::Config,
            |v| {
                let (start, distance, duration) = args(v);
                refused_or(Quintic::<T>::new(start, distance, duration), |q| {
                    let mut out = Out::Finite;
                    for k in 0..=10 {
                        let t = re::<T>(0.1 * k as f64) * re::<T>(duration.abs().min(1e30));
                        out = out.and(finite(reference_values(&q.sample(t))));
                    }
                    out
                })
            },
        );
    }
    let quintic = Quintic::<T>::new(0.0, 0.03, 0.4).unwrap();
    s.site(M, "Quintic::sample(t_s)", scalar, Kind::Kernel, |v| {
        finite(reference_values(&quintic.sample(re::<T>(v))))
    });
    // ArcResampler, resample, densify
    let open: Vec<[f64; 2]> = shapes::letter_s().to_vec();
    s.site(
        M,
        "ArcResampler::new(point[4].y) + advance",
        scalar,
        Kind::Config,
        |v| {
            let mut p: Vec<[T; 2]> = open.iter().map(|q| q.map(re::<T>)).collect();
            p[4][1] = re::<T>(v);
            refused_or(ArcResampler::new(&p), |mut walk| {
                let mut out = Out::Finite;
                for _ in 0..50 {
                    if let Some(s) = walk.advance(re::<T>(1e-3)) {
                        out = out.and(finite(v2(&s.position).into_iter().chain(v2(&s.direction))));
                    }
                }
                out
            })
        },
    );
    s.site(
        M,
        "ArcResampler::new(points × v) + advance",
        scalar,
        Kind::Config,
        |v| {
            let p: Vec<[T; 2]> = open.iter().map(|q| q.map(|c| re::<T>(c * v))).collect();
            refused_or(ArcResampler::new(&p), |mut walk| {
                let mut out = Out::Finite;
                for _ in 0..50 {
                    if let Some(s) = walk.advance(re::<T>(1e-3 * v.abs().min(1e30))) {
                        out = out.and(finite(v2(&s.position).into_iter().chain(v2(&s.direction))));
                    }
                }
                out
            })
        },
    );
    let open_t: Vec<[T; 2]> = open.iter().map(|q| q.map(re::<T>)).collect();
    s.site(M, "ArcResampler::advance(ds)", scalar, Kind::Step, |v| {
        let mut walk = ArcResampler::new(&open_t).unwrap();
        walk.advance(re::<T>(1e-3));
        let a = some_or(walk.advance(re::<T>(v)), |s| {
            finite(v2(&s.position).into_iter().chain(v2(&s.direction)))
        });
        let b = some_or(walk.current(), |s| {
            finite(v2(&s.position).into_iter().chain(v2(&s.direction)))
        });
        a.and(b)
    });
    s.site(M, "resample(step_m)", scalar, Kind::Config, |v| {
        refused_or(resample::resample::<T, 4096>(&open_t, v), |pts| {
            finite(pts.iter().flat_map(v2))
        })
    });
    s.site(M, "densify(point[2].x)", "-", Kind::Config, |v| {
        let mut p = open.clone();
        p[2][0] = v;
        refused_or(resample::densify::<4096>(&p, 3), |pts| {
            finite_f64(pts.iter().flatten().copied())
        })
    });
    // JointSpline
    let task: Vec<Vector3<f64>> = (0..12)
        .map(|k| Vector3::new(1e-3 * k as f64, 2e-3 * (k as f64 * 0.3).sin(), 0.05))
        .collect();
    let evaluate_all = |sp: &JointSpline<T, 32>| {
        let mut out = Out::Finite;
        for k in 0..=40 {
            let r = sp.evaluate(sp.periods() * k / 40);
            out = out.and(finite(
                v3(&r.q)
                    .into_iter()
                    .chain(v3(&r.qd))
                    .chain(v3(&r.qdd))
                    .chain(v3(&r.qddd)),
            ));
        }
        out
    };
    let id = |p: Vector3<f64>| Ok::<_, ()>(p);
    let z = Vector3::zeros();
    s.site(
        M,
        "JointSpline::fit(sample[5].y) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let mut t = task.clone();
            t[5].y = v;
            refused_or(
                JointSpline::<T, 32>::fit(&t, timing(1e-3), z, z, id),
                |sp| evaluate_all(&sp),
            )
        },
    );
    s.site(
        M,
        "JointSpline::fit(samples × v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let t: Vec<_> = task.iter().map(|p| p * v).collect();
            refused_or(
                JointSpline::<T, 32>::fit(&t, timing(1e-3), z, z, id),
                |sp| evaluate_all(&sp),
            )
        },
    );
    s.site(
        M,
        "JointSpline::fit(timing.period_s) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                JointSpline::<T, 32>::fit(&task, timing(v), z, z, id),
                |sp| evaluate_all(&sp),
            )
        },
    );
    s.site(
        M,
        "JointSpline::fit(start_velocity.x) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                JointSpline::<T, 32>::fit(&task, timing(1e-3), Vector3::new(v, 0.0, 0.0), z, id),
                |sp| evaluate_all(&sp),
            )
        },
    );
    s.site(
        M,
        "JointSpline::fit(joint map returns v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let map = |p: Vector3<f64>| Ok::<_, ()>(Vector3::new(p.x, v, p.z));
            refused_or(
                JointSpline::<T, 32>::fit(&task, timing(1e-3), z, z, map),
                |sp| evaluate_all(&sp),
            )
        },
    );
    let spline = JointSpline::<T, 32>::fit(&task, timing(1e-3), z, z, id).unwrap();
    s.site(
        M,
        "JointSpline::evaluate(period = v)",
        scalar,
        Kind::Step,
        |v| {
            let r = spline.evaluate(v as u64);
            finite(
                v3(&r.q)
                    .into_iter()
                    .chain(v3(&r.qd))
                    .chain(v3(&r.qdd))
                    .chain(v3(&r.qddd)),
            )
        },
    );
    s.site(
        M,
        "JointSpline::evaluate_at(knot 3, offset_s)",
        scalar,
        Kind::Step,
        |v| {
            let r = spline.evaluate_at(3, re::<T>(v));
            finite(
                v3(&r.q)
                    .into_iter()
                    .chain(v3(&r.qd))
                    .chain(v3(&r.qdd))
                    .chain(v3(&r.qddd)),
            )
        },
    );
    // MotionConstraint and the circle fits
    let cam = shapes::cam();
    let constraint_probe = |c: MotionConstraint<T, 512>, scale: f64| {
        let mut out = Out::Finite;
        for k in 0..8 {
            let a = k as f64 * PI / 4.0;
            let x = Vector3::new(0.01 * a.cos() * scale, 0.01 * a.sin() * scale, 0.0).map(re::<T>);
            let x = x + Vector3::new(c.origin().x, c.origin().y, T::ZERO);
            out = out.and(refused_or(c.evaluate(x, T::ZERO), |r| {
                finite(v2(&r.phi).into_iter().chain(r.jacobian.iter().copied()))
            }));
        }
        out
    };
    s.site(
        M,
        "MotionConstraint::new(point[7].x) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let mut p = cam;
            p[7][0] = v;
            refused_or(
                MotionConstraint::<T, 512>::new(&p, &ConstraintConfig::closed_contour()),
                |c| constraint_probe(c, 1.0),
            )
        },
    );
    s.site(
        M,
        "MotionConstraint::new(points × v) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let p = cam.map(|[x, y]| [x * v, y * v]);
            refused_or(
                MotionConstraint::<T, 512>::new(&p, &ConstraintConfig::closed_contour()),
                |c| constraint_probe(c, v.abs().min(1e30)),
            )
        },
    );
    s.site(
        M,
        "MotionConstraint::new(line_sagitta_m) + evaluate",
        scalar,
        Kind::Config,
        |v| {
            let config = ConstraintConfig {
                line_sagitta_m: v,
                ..ConstraintConfig::closed_contour()
            };
            refused_or(MotionConstraint::<T, 512>::new(&cam, &config), |c| {
                constraint_probe(c, 1.0)
            })
        },
    );
    let constraint =
        MotionConstraint::<T, 512>::new(&cam, &ConstraintConfig::closed_contour()).unwrap();
    for axis in 0..3 {
        s.site(
            M,
            &format!("MotionConstraint::evaluate(x[{axis}])"),
            scalar,
            Kind::Step,
            |v| {
                let mut x = Vector3::new(constraint.origin().x, constraint.origin().y, T::ZERO);
                x[axis] = re::<T>(v);
                refused_or(constraint.evaluate(x, T::ZERO), |r| {
                    finite(v2(&r.phi).into_iter().chain(r.jacobian.iter().copied()))
                })
            },
        );
    }
    s.site(
        M,
        "MotionConstraint::evaluate(z_ref)",
        scalar,
        Kind::Step,
        |v| {
            let x = Vector3::new(constraint.origin().x, constraint.origin().y, T::ZERO);
            refused_or(constraint.evaluate(x, re::<T>(v)), |r| {
                finite(v2(&r.phi).into_iter().chain(r.jacobian.iter().copied()))
            })
        },
    );
    let arc: Vec<Vector2<f64>> = (0..11)
        .map(|k| {
            let a = 0.1 * k as f64;
            Vector2::new(0.01 * a.cos(), 0.01 * a.sin())
        })
        .collect();
    s.site(
        M,
        "fit_kasa/taubin/geometric(point[3].x)",
        scalar,
        Kind::Step,
        |v| {
            let mut p: Vec<Vector2<T>> = arc.iter().map(|q| q.map(re::<T>)).collect();
            p[3].x = re::<T>(v);
            let a = some_or(fit_kasa(&p), |(c, r)| finite(v2(&c).into_iter().chain([r])));
            let b = some_or(fit_taubin(&p), |(c, e)| finite(v2(&c).into_iter().chain(e)));
            let start = (Vector2::new(T::ZERO, T::ZERO), re::<T>(0.01));
            let c = some_or(fit_geometric(&p, start, 10), |(c, r)| {
                finite(v2(&c).into_iter().chain([r]))
            });
            a.and(b).and(c)
        },
    );
    s.site(
        M,
        "fit_kasa/taubin/geometric(points × v)",
        scalar,
        Kind::Step,
        |v| {
            let p: Vec<Vector2<T>> = arc.iter().map(|q| (q * v).map(re::<T>)).collect();
            let a = some_or(fit_kasa(&p), |(c, r)| finite(v2(&c).into_iter().chain([r])));
            let b = some_or(fit_taubin(&p), |(c, e)| finite(v2(&c).into_iter().chain(e)));
            let start = (Vector2::new(T::ZERO, T::ZERO), re::<T>(0.01 * v));
            let c = some_or(fit_geometric(&p, start, 10), |(c, r)| {
                finite(v2(&c).into_iter().chain([r]))
            });
            a.and(b).and(c)
        },
    );
}

/// Knots every 10 control periods of `period_s`, from period 0.
fn timing(period_s: f64) -> KnotTiming {
    KnotTiming {
        period_s,
        periods_per_knot: 10,
        first_period: 0,
    }
}

/// Shapes are f64 test data (no scalar).
fn shape_sites(s: &mut Sweep) {
    const M: &str = "trajectory";
    s.site(
        M,
        "shapes::regular_polygon(radius_m)",
        "-",
        Kind::Kernel,
        |v| {
            let p: [[f64; 2]; 12] = shapes::regular_polygon(6, v);
            finite_f64(p.iter().flatten().copied())
        },
    );
    s.site(M, "shapes::ellipse(a_m)", "-", Kind::Kernel, |v| {
        let p: [[f64; 2]; 16] = shapes::ellipse(v, 0.01);
        finite_f64(p.iter().flatten().copied())
    });
    s.site(
        M,
        "shapes::regular_polygon(sides = v)",
        "-",
        Kind::Config,
        |v| {
            let p: [[f64; 2]; 12] = shapes::regular_polygon(v as usize, 0.01);
            finite_f64(p.iter().flatten().copied())
        },
    );
}

/// Degenerate closed contours: collinear, nearly collinear (flattened by `v`), a
/// back-and-forth stroke, and a contour whose follower must not run away.
fn degenerate_geometry<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "trajectory";
    let octagon = shapes::octagon();
    let config = FollowerConfig {
        accel_limit_m_s2: 1e12,
        newton_steps: 2,
        ..follower_config()
    };
    for flatten in [0.0, 1e-15, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2] {
        s.case(
            M,
            "octagon flattened (y × v): Efd + follower",
            scalar,
            Kind::Step,
            flatten,
            || {
                let p = octagon.map(|[x, y]| [x, y * flatten]);
                refused_or(Efd::<T, 30>::from_polygon(&p, 30), |e| {
                    efd_probe(&e).and(refused_or(ContourFollower::new(e, &config, 0.0), |f| {
                        follow(f, 4000)
                    }))
                })
            },
        );
    }
    for offset in [0.0, 1e-15, 1e-12, 1e-9, 1e-6] {
        s.case(
            M,
            "stroke out and back (offset v): Efd + follower",
            scalar,
            Kind::Step,
            offset,
            || {
                let mut p: Vec<[f64; 2]> = (0..16).map(|k| [k as f64 * 1e-3, 0.0]).collect();
                p.extend((1..15).rev().map(|k| [k as f64 * 1e-3, offset]));
                refused_or(Efd::<T, 30>::from_polygon(&p, 30), |e| {
                    efd_probe(&e).and(refused_or(ContourFollower::new(e, &config, 0.0), |f| {
                        follow(f, 4000)
                    }))
                })
            },
        );
    }
    // A figure of eight: σ = |C′| never vanishes but curvature is high near the centre.
    for n in [1usize, 2, 3] {
        s.case(
            M,
            "two-harmonic curve with a cusp (n = v)",
            scalar,
            Kind::Step,
            n as f64,
            || {
                // x = cos θ + cos 2θ / 4 ... chosen so that C′(θ) = 0 at θ = π (a cusp).
                let coefficients = [[0.01, 0.0, 0.0, 0.01], [0.0, 0.0, 0.0, 0.005 * n as f64]];
                refused_or(
                    Efd::<T, 4>::from_coefficients([0.0, 0.0], &coefficients),
                    |e| {
                        efd_probe(&e).and(refused_or(ContourFollower::new(e, &config, 0.0), |f| {
                            follow(f, 8000)
                        }))
                    },
                )
            },
        );
    }
    // Collinear, repeated and coincident open data.
    let cases: [(&str, Vec<[f64; 2]>); 4] = [
        (
            "open: collinear",
            (0..8).map(|k| [k as f64 * 1e-3, 0.0]).collect(),
        ),
        (
            "open: repeated point",
            vec![[0.0, 0.0], [1e-3, 0.0], [1e-3, 0.0], [2e-3, 1e-3]],
        ),
        ("open: all equal", vec![[1e-3, 1e-3]; 5]),
        (
            "open: 1e-40 apart",
            (0..8).map(|k| [k as f64 * 1e-40, 0.0]).collect(),
        ),
    ];
    for (name, p) in cases {
        s.case(M, name, scalar, Kind::Step, 0.0, || {
            let pt: Vec<[T; 2]> = p.iter().map(|q| q.map(re::<T>)).collect();
            let a = refused_or(ArcResampler::new(&pt), |mut walk| {
                some_or(walk.advance(re::<T>(1e-4)), |s| {
                    finite(v2(&s.position).into_iter().chain(v2(&s.direction)))
                })
            });
            let b = refused_or(resample::densify::<256>(&p, 2), |d| {
                finite_f64(d.iter().flatten().copied())
            });
            let c = refused_or(
                MotionConstraint::<T, 64>::new(
                    &p,
                    &ConstraintConfig {
                        half_window: 1,
                        closed: false,
                        ..ConstraintConfig::closed_contour()
                    },
                ),
                |c| {
                    let x = Vector3::new(c.origin().x, c.origin().y + re::<T>(1e-4), T::ZERO);
                    refused_or(c.evaluate(x, T::ZERO), |r| {
                        finite(v2(&r.phi).into_iter().chain(r.jacobian.iter().copied()))
                    })
                },
            );
            a.and(b).and(c)
        });
    }
}

// ---------------------------------------------------------------------------------
// control

fn control_sites<T: Real>(s: &mut Sweep, scalar: &str) {
    const M: &str = "control";
    let reference = Reference {
        position: re::<T>(0.01),
        velocity: re::<T>(0.1),
        acceleration: re::<T>(1.0),
    };
    let pd_probe = |pd: Pd<T>| finite([pd.acceleration(&reference, re::<T>(0.0101), T::ZERO)]);
    s.site(
        M,
        "Pd::new(kp_per_s2) + acceleration",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                Pd::<T>::new(&PdConfig {
                    kp_per_s2: v,
                    kd_per_s: 500.0,
                }),
                pd_probe,
            )
        },
    );
    s.site(
        M,
        "Pd::new(kd_per_s) + acceleration",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                Pd::<T>::new(&PdConfig {
                    kp_per_s2: 6e4,
                    kd_per_s: v,
                }),
                pd_probe,
            )
        },
    );
    s.site(
        M,
        "PdConfig::critically_damped(bandwidth) + Pd::new",
        scalar,
        Kind::Config,
        |v| refused_or(Pd::<T>::new(&PdConfig::critically_damped(v)), pd_probe),
    );
    let pd = Pd::<T>::new(&AxisConfig::LM1247_SLAVE.pd).unwrap();
    for (name, which) in [("reference", 0), ("position", 1), ("velocity", 2)] {
        s.site(
            M,
            &format!("Pd::acceleration({name})"),
            scalar,
            Kind::Kernel,
            |v| {
                let x = re::<T>(v);
                let mut r = reference;
                let (mut position, mut velocity) = (re::<T>(0.01), T::ZERO);
                match which {
                    0 => r.position = x,
                    1 => position = x,
                    _ => velocity = x,
                }
                finite([pd.acceleration(&r, position, velocity)])
            },
        );
    }
    let nominal = AxisConfig::LM1247_SLAVE.dob;
    let dob_probe = |dob: Dob<T>| {
        let mut state = DobState::at(T::ZERO);
        let mut values = Vec::new();
        for k in 0..20 {
            let out = dob.update(&mut state, re::<T>(1.0), re::<T>(1e-3 * k as f64));
            values.extend([
                out.force_n,
                out.disturbance_n,
                dob.applied_acceleration(&out),
            ]);
        }
        finite(values)
    };
    type Edit = fn(&mut DobConfig, f64);
    let edits: [(&str, Edit); 3] = [
        ("nominal_mass_kg", |c, v| c.nominal_mass_kg = v),
        ("bandwidth_rad_s", |c, v| c.bandwidth_rad_s = v),
        ("force_limit_n", |c, v| c.force_limit_n = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("Dob::new({field}) + update"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = nominal;
                edit(&mut config, v);
                refused_or(Dob::<T>::new(&config, 1e-4), dob_probe)
            },
        );
    }
    s.site(M, "Dob::new(ts_s) + update", scalar, Kind::Config, |v| {
        refused_or(Dob::<T>::new(&nominal, v), dob_probe)
    });
    let dob = Dob::<T>::new(&nominal, 1e-4).unwrap();
    s.site(
        M,
        "Dob::update(acceleration_des)",
        scalar,
        Kind::Kernel,
        |v| {
            let mut state = DobState::at(T::ZERO);
            let out = dob.update(&mut state, re::<T>(v), T::ZERO);
            finite([out.force_n, out.disturbance_n, state.estimate_n])
        },
    );
    s.site(M, "Dob::update(velocity)", scalar, Kind::Kernel, |v| {
        let mut state = DobState::at(T::ZERO);
        let out = dob.update(&mut state, T::ZERO, re::<T>(v));
        finite([out.force_n, out.disturbance_n, state.estimate_n])
    });
}

// ---------------------------------------------------------------------------------
// codec

#[derive(Default)]
struct Loopback {
    frames: std::collections::VecDeque<Vec<u8>>,
}

impl FrameLink for Loopback {
    fn send(&mut self, frame: &[u8]) -> Result<(), LinkBusy> {
        self.frames.push_back(frame.to_vec());
        Ok(())
    }
    fn receive(&mut self, buf: &mut [u8]) -> Option<usize> {
        let frame = self.frames.pop_front()?;
        let n = frame.len().min(buf.len());
        buf[..n].copy_from_slice(&frame[..n]);
        Some(n)
    }
}

fn signal(k: usize) -> f32 {
    (0.3 * k as f32).sin() * 0.01
}

fn codec_sites(s: &mut Sweep) {
    const M: &str = "codec";
    let dct = Dct::<32>::new().unwrap();
    s.site(M, "Dct::forward(x[5])", "f32", Kind::Kernel, |v| {
        let mut x: [f32; 32] = core::array::from_fn(signal);
        x[5] = v as f32;
        dct.forward(&mut x);
        finite(x)
    });
    s.site(M, "Dct::inverse(c[7])", "f32", Kind::Kernel, |v| {
        let mut c: [f32; 32] = core::array::from_fn(signal);
        c[7] = v as f32;
        dct.inverse(&mut c);
        finite(c)
    });
    s.site(
        M,
        "Dct::forward_q15/inverse_q15(x[5] saturated)",
        "-",
        Kind::Step,
        |v| {
            let mut x: [i16; 32] = core::array::from_fn(|k| (signal(k) * 3e6) as i16);
            x[5] = v as i16;
            let mut c = [0i32; 32];
            dct.forward_q15(&x, &mut c);
            c[9] = (v * 65536.0) as i32;
            let mut back = [0i16; 32];
            dct.inverse_q15(&c, &mut back);
            Out::Finite
        },
    );
    let encoder = SdctEncoder::<32>::new(&SdctConfig {
        m: 8,
        selection: Selection::Largest,
    })
    .unwrap();
    let decoder = SdctDecoder::<32>::new().unwrap();
    s.site(
        M,
        "SdctEncoder::encode(x[3]) + packet + decode",
        "f32",
        Kind::Step,
        |v| {
            let mut x: [f32; 32] = core::array::from_fn(signal);
            x[3] = v as f32;
            refused_or(encoder.encode(&x), |block| {
                let mut buf = [0u8; 256];
                refused_or(packet::encode(&block, 7, 123, &mut buf), |n| {
                    refused_or(packet::parse(&buf[..n]), |p| {
                        refused_or(p.to_block::<32>(), |b| {
                            let mut out = [0f32; 32];
                            decoder.decode(&b, &mut out);
                            finite(out)
                        })
                    })
                })
            })
        },
    );
    s.site(
        M,
        "packet::encode_parts(coefficient) + parse + decode",
        "f32",
        Kind::Step,
        |v| {
            let mut c: [f32; 32] = core::array::from_fn(signal);
            c[2] = v as f32;
            let mut buf = [0u8; 256];
            refused_or(packet::encode_parts(0b1111_0110, &c, 1, 2, &mut buf), |n| {
                refused_or(packet::parse(&buf[..n]), |p| {
                    refused_or(p.to_block::<32>(), |b| {
                        let mut out = [0f32; 32];
                        decoder.decode(&b, &mut out);
                        finite(out.into_iter().chain((0..32).map(|k| p.coefficient(k))))
                    })
                })
            })
        },
    );
    s.site(
        M,
        "SdctDecoder::decode(Block::from_parts(c[1]))",
        "f32",
        Kind::Kernel,
        |v| {
            let mut c = [0f32; 32];
            c[1] = v as f32;
            c[4] = 0.1;
            let mut out = [0f32; 32];
            decoder.decode(&Block::from_parts(0b10010, c), &mut out);
            finite(out)
        },
    );
    // Every single-byte corruption of a valid packet (by the value's bit pattern).
    let x: [f32; 32] = core::array::from_fn(signal);
    let block = encoder.encode(&x).unwrap();
    let mut valid = [0u8; 256];
    let len = packet::encode(&block, 9, 77, &mut valid).unwrap();
    for byte in 0..len {
        for pattern in [0x00u8, 0xff, 0x80, 0x7f] {
            s.case(
                M,
                "PacketDecoder::decode(one byte changed)",
                "-",
                Kind::Step,
                byte as f64,
                || {
                    let mut bytes = valid[..len].to_vec();
                    bytes[byte] = pattern;
                    let mut d = PacketDecoder::new();
                    refused_or(d.decode(&bytes), |r| {
                        refused_or(r.packet.to_block::<32>(), |b| {
                            let mut out = [0f32; 32];
                            decoder.decode(&b, &mut out);
                            finite(out)
                        })
                    })
                },
            );
        }
    }
    for cut in 0..=len {
        s.case(
            M,
            "packet::parse(truncated)",
            "-",
            Kind::Step,
            cut as f64,
            || {
                refused_or(packet::parse(&valid[..cut]), |p| {
                    finite((0..32).map(|k| p.coefficient(k)))
                })
            },
        );
    }
    s.site(
        M,
        "SignalSender::push(sample) + SignalReceiver::poll",
        "f32",
        Kind::Step,
        |v| {
            let mut sender = SignalSender::<32>::new(&SdctConfig {
                m: 8,
                selection: Selection::Largest,
            })
            .unwrap();
            let mut receiver = kerf::app::stream::SignalReceiver::<32>::new().unwrap();
            let mut link = Loopback::default();
            let mut out = Out::Finite;
            for k in 0..64 {
                let sample = if k == 10 { v as f32 } else { signal(k) };
                out = out.and(refused_or(sender.push(sample, &mut link), |_| Out::Finite));
            }
            let mut buf = [0f32; 32];
            while let Some(r) = receiver.poll(&mut link, &mut buf) {
                out = out.and(refused_or(r, |_| finite(buf)));
            }
            out
        },
    );
}

// ---------------------------------------------------------------------------------
// app

/// A machine's period result: a fault is refused (the supervisor writes the safe
/// outputs), outputs must be finite.
fn machine_step<T: Real, F, const N: usize>(r: Result<Step<[T; N]>, F>) -> Out {
    match r {
        Ok(Step::Continue(o)) | Ok(Step::Done(o)) => finite(o),
        Err(_) => Out::Refused,
    }
}

/// A slave period: forces finite and the laser's duty a number in [0, 1].
fn slave_step<T: Real, F>(r: Result<Step<SlaveOutputs<T>>, F>) -> Out {
    match r {
        Ok(Step::Continue(o)) | Ok(Step::Done(o)) => {
            let duty_ok = o.laser_duty >= T::ZERO && o.laser_duty <= T::from_f64(1.0);
            match finite(o.force_n) {
                Out::Finite if !duty_ok => Out::NonFinite,
                out => out,
            }
        }
        Err(_) => Out::Refused,
    }
}

fn axis_sites<T: Real>(s: &mut Sweep, scalar: &str) {
    const M: &str = "app";
    let law = AxisLaw::<T>::new(&AxisConfig::LM1247_SLAVE, 1e-4).unwrap();
    let sensor = HallAxis::<T>::new(&HallConfig::LM1247_16BIT).unwrap();
    let hold = Reference {
        position: re::<T>(0.004),
        velocity: T::ZERO,
        acceleration: T::ZERO,
    };
    // A step's output: a fault must come with zero force; otherwise all finite.
    let axis_out = |out: kerf::app::axis::AxisOutput<T>| match out.status {
        AxisStatus::Fault(_) if out.force_n == T::ZERO => {
            finite([out.position_m, out.velocity_m_s, out.disturbance_n]).and(Out::Refused)
        }
        AxisStatus::Fault(_) => Out::NonFinite,
        _ => finite([
            out.force_n,
            out.position_m,
            out.velocity_m_s,
            out.disturbance_n,
        ]),
    };
    type Edit = fn(&mut AxisConfig, f64);
    let edits: [(&str, Edit); 6] = [
        ("velocity.bandwidth_rad_s", |c, v| {
            c.velocity.bandwidth_rad_s = v
        }),
        ("pd.kp_per_s2", |c, v| c.pd.kp_per_s2 = v),
        ("pd.kd_per_s", |c, v| c.pd.kd_per_s = v),
        ("dob.nominal_mass_kg", |c, v| c.dob.nominal_mass_kg = v),
        ("dob.bandwidth_rad_s", |c, v| c.dob.bandwidth_rad_s = v),
        ("dob.force_limit_n", |c, v| c.dob.force_limit_n = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("AxisLaw::new({field}) + step"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = AxisConfig::LM1247_SLAVE;
                edit(&mut config, v);
                refused_or(AxisLaw::<T>::new(&config, 1e-4), |law| {
                    let mut state = AxisState::homed_at(re::<T>(0.004));
                    let mut out = Out::Finite;
                    for k in 0..10 {
                        out = out.and(axis_out(law.step(
                            &sensor,
                            &mut state,
                            counts(0.01 * k as f64),
                            &hold,
                        )));
                    }
                    out
                })
            },
        );
    }
    s.site(
        M,
        "AxisLaw::new(period_s) + step",
        scalar,
        Kind::Config,
        |v| {
            refused_or(AxisLaw::<T>::new(&AxisConfig::LM1247_SLAVE, v), |law| {
                let mut state = AxisState::homed_at(re::<T>(0.004));
                axis_out(law.step(&sensor, &mut state, counts(0.0), &hold))
            })
        },
    );
    s.site(
        M,
        "HallAxis::new(pitch_m) + step",
        scalar,
        Kind::Config,
        |v| {
            let config = HallConfig {
                pitch_m: v,
                ..HallConfig::LM1247_16BIT
            };
            refused_or(HallAxis::<T>::new(&config), |sensor| {
                let mut state = AxisState::homed_at(re::<T>(0.004));
                let mut out = Out::Finite;
                for k in 0..10 {
                    out = out.and(axis_out(law.step(
                        &sensor,
                        &mut state,
                        counts(0.3 * k as f64),
                        &hold,
                    )));
                }
                out
            })
        },
    );
    for (name, which) in [
        ("position", 0),
        ("velocity", 1),
        ("acceleration", 2),
        ("home", 3),
    ] {
        s.site(
            M,
            &format!("AxisLaw::step(reference.{name})"),
            scalar,
            Kind::Step,
            |v| {
                let x = re::<T>(v);
                let mut r = hold;
                let home = if which == 3 { x } else { re::<T>(0.004) };
                match which {
                    0 => r.position = x,
                    1 => r.velocity = x,
                    2 => r.acceleration = x,
                    _ => {}
                }
                let mut state = AxisState::homed_at(home);
                let mut out = Out::Finite;
                for k in 0..5 {
                    out = out.and(axis_out(law.step(
                        &sensor,
                        &mut state,
                        counts(0.01 * k as f64),
                        &r,
                    )));
                }
                out
            },
        );
    }
    s.site(
        M,
        "AxisLaw::step/monitor(counts)",
        scalar,
        Kind::Step,
        |v| {
            let mut state = AxisState::homed_at(re::<T>(0.004));
            let a = axis_out(law.step(&sensor, &mut state, counts(0.0), &hold));
            let b = axis_out(law.step(&sensor, &mut state, bad_counts(v), &hold));
            let mut monitored = AxisState::homed_at(re::<T>(0.004));
            let c = match law.monitor(&sensor, &mut monitored, bad_counts(v)) {
                Ok(()) => finite([monitored.position_m(), monitored.velocity_m_s()]),
                Err(_) => Out::Refused,
            };
            a.and(b).and(c)
        },
    );
}

fn joints_sites<T: Real>(s: &mut Sweep, scalar: &str) {
    const M: &str = "app";
    let nominal = JointsConfig::LM1247;
    let here = counts(0.3);
    let job = |target: f64, duration: f64| -> JointJob<1> {
        let mut j = JointJob::new();
        j.push(Segment {
            target_m: [target],
            duration_s: duration,
        })
        .unwrap();
        j
    };
    let run_job = |mut m: Joints<T, 1>, job: JointJob<1>, periods: usize| -> Out {
        let mut out = refused_or(m.monitor(&[here]), |_| Out::Finite);
        if out == Out::Refused {
            return out;
        }
        if m.check_job(&job).is_err() || m.begin_job(&job).is_err() {
            return Out::Refused;
        }
        for _ in 0..periods {
            let r = m.run(&job, &[here]);
            let refused = r.is_err();
            out = out.and(machine_step(r));
            if refused {
                break;
            }
        }
        m.begin_stop();
        for _ in 0..5 {
            out = out.and(machine_step(m.stop(&job, &[here])));
        }
        out
    };
    type Edit = fn(&mut JointsConfig<1>, f64);
    let edits: [(&str, Edit); 6] = [
        ("period_s", |c, v| c.period_s = v),
        ("home_m[0]", |c, v| c.home_m[0] = v),
        ("travel_m[0][0]", |c, v| c.travel_m[0][0] = v),
        ("travel_m[0][1]", |c, v| c.travel_m[0][1] = v),
        ("speed_limit_m_s", |c, v| c.speed_limit_m_s = v),
        ("accel_limit_m_s2", |c, v| c.accel_limit_m_s2 = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("Joints::new({field}) + job"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = nominal;
                edit(&mut config, v);
                refused_or(Joints::<T, 1>::new(&config), |m| {
                    run_job(m, job(0.0053, 0.05), 60)
                })
            },
        );
    }
    s.site(M, "Joints job(target_m)", scalar, Kind::Config, |v| {
        run_job(Joints::<T, 1>::new(&nominal).unwrap(), job(v, 0.05), 60)
    });
    s.site(M, "Joints job(duration_s)", scalar, Kind::Config, |v| {
        run_job(Joints::<T, 1>::new(&nominal).unwrap(), job(0.0053, v), 60)
    });
    s.site(M, "Joints::run(counts mid-job)", scalar, Kind::Step, |v| {
        let mut m = Joints::<T, 1>::new(&nominal).unwrap();
        if m.monitor(&[here]).is_err() {
            return Out::NonFinite;
        }
        let job = job(0.0053, 0.05);
        m.begin_job(&job).unwrap();
        let mut out = machine_step(m.run(&job, &[here]));
        out = out.and(machine_step(m.run(&job, &[bad_counts(v)])));
        out.and(machine_step(m.run(&job, &[here])))
    });
}

fn delta_slave_sites<T: Float>(s: &mut Sweep, scalar: &str) {
    const M: &str = "app";
    let config = DeltaSlaveConfig::KEOPS;
    let geometry = DeltaGeometry::<f64>::new(&config.delta).unwrap();
    let centre = geometry.forward(&Vector3::new(0.01, 0.01, 0.01)).unwrap();
    let here = [counts(0.3); 3];
    let plan = |config: &DeltaSlaveConfig,
                start: [f64; 3],
                approach_s: f64,
                target: [f64; 3],
                duration_s: f64| {
        DeltaJob::plan(
            config,
            start,
            approach_s,
            &[Segment {
                target_m: target,
                duration_s,
            }],
        )
    };
    let start = [centre.x, centre.y, centre.z + 0.002];
    let target = [centre.x + 0.003, centre.y, centre.z + 0.002];
    let run = |config: &DeltaSlaveConfig, job: DeltaJob, periods: usize| -> Out {
        refused_or(DeltaSlave::<T>::new(config), |mut m| {
            if m.monitor(&here).is_err() {
                return Out::Refused;
            }
            if m.check_job(&job).is_err() || m.begin_job(&job).is_err() {
                return Out::Refused;
            }
            let mut out = Out::Finite;
            for _ in 0..periods {
                let r = m.run(&job, &here);
                let refused = r.is_err();
                out = out.and(slave_step(r));
                if refused {
                    break;
                }
            }
            out
        })
    };
    for axis in 0..3 {
        s.site(
            M,
            &format!("DeltaJob::plan(start_m[{axis}]) + run"),
            scalar,
            Kind::Config,
            |v| {
                let mut st = start;
                st[axis] = v;
                refused_or(plan(&config, st, 0.05, target, 0.05), |job| {
                    run(&config, job, 20)
                })
            },
        );
        s.site(
            M,
            &format!("DeltaJob::plan(target_m[{axis}]) + run"),
            scalar,
            Kind::Config,
            |v| {
                let mut t = target;
                t[axis] = v;
                refused_or(plan(&config, start, 0.05, t, 0.05), |job| {
                    run(&config, job, 20)
                })
            },
        );
    }
    s.site(
        M,
        "DeltaJob::plan(approach_s) + run",
        scalar,
        Kind::Config,
        |v| {
            refused_or(plan(&config, start, v, target, 0.05), |job| {
                run(&config, job, 20)
            })
        },
    );
    s.site(
        M,
        "DeltaJob::plan(duration_s) + run",
        scalar,
        Kind::Config,
        |v| {
            refused_or(plan(&config, start, 0.05, target, v), |job| {
                run(&config, job, 20)
            })
        },
    );
    type Edit = fn(&mut DeltaSlaveConfig, f64);
    let edits: [(&str, Edit); 5] = [
        ("delta.actuators[0].arm_m", |c, v| {
            c.delta.actuators[0].arm_m = v
        }),
        ("delta.actuators[2].travel_max_m", |c, v| {
            c.delta.actuators[2].travel_max_m = v
        }),
        ("joints.home_m[1]", |c, v| c.joints.home_m[1] = v),
        ("joints.period_s", |c, v| c.joints.period_s = v),
        ("joints.speed_limit_m_s", |c, v| {
            c.joints.speed_limit_m_s = v
        }),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("DeltaSlave::new({field}) + plan + run"),
            scalar,
            Kind::Config,
            |v| {
                let mut c = config;
                edit(&mut c, v);
                refused_or(plan(&c, start, 0.05, target, 0.05), |job| run(&c, job, 20))
            },
        );
    }
    s.site(
        M,
        "DeltaSlave::run(counts mid-move)",
        scalar,
        Kind::Step,
        |v| {
            // The approach (0.05 s = 500 periods) ends before the bad sample.
            let job = plan(&config, start, 0.05, target, 0.05).unwrap();
            let mut m = DeltaSlave::<T>::new(&config).unwrap();
            m.monitor(&here).unwrap();
            m.begin_job(&job).unwrap();
            let mut out = Out::Finite;
            for k in 0..560 {
                let inputs = if k == 520 {
                    [here[0], bad_counts(v), here[2]]
                } else {
                    here
                };
                let r = m.run(&job, &inputs);
                let refused = r.is_err();
                out = out.and(slave_step(r));
                if refused {
                    break;
                }
            }
            out
        },
    );
}

fn clock_sites(s: &mut Sweep) {
    const M: &str = "app";
    s.site(
        M,
        "PeriodClock::new(period_s) + start",
        "-",
        Kind::Config,
        |v| {
            refused_or(PeriodClock::new(v, 170_000_000), |mut c| {
                c.start(0);
                c.start(u64::MAX);
                c.start(5);
                Out::Finite
            })
        },
    );
    s.site(M, "PeriodClock::new(tick_hz = v)", "-", Kind::Config, |v| {
        refused_or(PeriodClock::new(1e-4, v as u64), |_| Out::Finite)
    });
}

#[test]
fn bad_input_sweep() {
    std::panic::set_hook(Box::new(|info| {
        let message = info.to_string();
        PANIC_MESSAGE.with(|m| *m.borrow_mut() = message);
    }));
    let mut s = Sweep::new();
    hall_sites(&mut s);
    delta_sites::<f32>(&mut s, "f32");
    delta_sites::<f64>(&mut s, "f64");
    trajectory_sites::<f32>(&mut s, "f32");
    trajectory_sites::<f64>(&mut s, "f64");
    shape_sites(&mut s);
    degenerate_geometry::<f32>(&mut s, "f32");
    degenerate_geometry::<f64>(&mut s, "f64");
    control_sites::<f32>(&mut s, "f32");
    control_sites::<f64>(&mut s, "f64");
    codec_sites(&mut s);
    axis_sites::<f32>(&mut s, "f32");
    axis_sites::<f64>(&mut s, "f64");
    joints_sites::<f32>(&mut s, "f32");
    joints_sites::<f64>(&mut s, "f64");
    delta_slave_sites::<f32>(&mut s, "f32");
    delta_slave_sites::<f64>(&mut s, "f64");
    clock_sites(&mut s);
    let _ = std::panic::take_hook();
    s.print();
    let non_finite: usize = s.tallies.values().map(|t| t.non_finite).sum();
    let panics: usize = s.tallies.values().map(|t| t.panics).sum();
    assert_eq!((non_finite, panics), (0, 0), "see the FAIL lines above");
}
