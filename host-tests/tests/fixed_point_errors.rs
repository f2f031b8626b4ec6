//! Errors of each scalar of the single-axis loop and of a Keops slave joint (the same
//! law with the slave's configuration, `Scenario::keops_joint`) against f64, per
//! scenario, side by side with the bound its quantization implies. Run with
//! `cargo test -p host-tests --test fixed_point_errors -- --nocapture` for the tables.
//!
//! Two comparisons per scenario:
//! - the machine (`Joints<T, 1>` under the supervisor) on the simulated axis in f32,
//!   Q31_32, Q6_25 and f64, with the same plant, noise and job: RMS and maximum
//!   tracking error, and the period-by-period differences from the f64 run. The Hall
//!   ADC and the plant's Coulomb friction are not linear, so these differences have
//!   no closed-form bound; the test holds them to the goal (RMS tracking error
//!   within 10 % of f64's);
//! - the law's kernels (tracking observer, PD, DOB: the same generic code the axis
//!   runs after its integer Hall decode) in closed loop with a linear plant (the
//!   payload's mass and viscous friction) and a measurement with deterministic noise
//!   in f64, identical for every scalar. There every rounding is an injection of at
//!   most b (half a step of the fixed-point format, or half an ulp of the value for
//!   f32) into a stable linear system (the force clamp never acts, which the test
//!   checks), so the difference from f64 is bounded: |Δ| ≤ Σ ‖h_i‖₁ b_i over the
//!   injection points i, with h_i the impulse response from point i to the force or
//!   to the plant's position. The h_i are computed here from the equations (DOB and
//!   PD: docs/control.md §17; velocity observer: docs/equations.md §3), not from the
//!   library's code; an injection
//!   whose rounding carries its remainder to the next period (Q6_25's observer
//!   position update) enters as r_k − r_{k−1} with |r| ≤ b, so it counts
//!   ‖h_i(k) − h_i(k−1)‖₁ b instead.

use host_tests::fixed_point::{axis_scenarios, joint_scenarios};
use kerf::app::axis::AxisConfig;
use kerf::control::dob::{Dob, DobState};
use kerf::control::pd::Pd;
use kerf::sensing::velocity::{TrackingObserver, TrackingObserverState};
use kerf::trajectory::Reference;
use kerf::{Real, Q31_32, Q6_25};
use kerf_sim::scenario::{profile, run_with, Motion, Outcome, Period, Scenario, START_M, TS_S};

/// Periods over which the impulse responses are summed; the test checks that the
/// response has decayed by then.
const RESPONSE_PERIODS: usize = 20_000;
/// The plant of the kernel comparison: LM1247 slider with payload (hal-mock's
/// `LM1247_WITH_PAYLOAD`) without its Coulomb friction, which is not linear.
const PLANT_MASS_KG: f64 = 0.121;
const PLANT_VISCOUS_N_S_PER_M: f64 = 0.5;
/// Measurement noise of the kernel comparison: uniform, ±0.3 µm (the Hall noise's
/// 0.18 µm RMS), the same sequence for every scalar.
const NOISE_M: f64 = 0.3e-6;

/// The machine comparison's scenarios: the single axis' and one Keops slave carriage's
/// (tracking and hold under its gravity load).
fn machine_scenarios() -> impl Iterator<Item = (&'static str, Scenario)> {
    axis_scenarios().into_iter().chain(joint_scenarios())
}

fn trace<T: Real>(s: &Scenario) -> (Outcome, Vec<Period>) {
    let mut periods = Vec::new();
    let (o, _) = run_with::<T>(s, Outcome::default(), |p| {
        if p.in_job() {
            periods.push(*p)
        }
    })
    .unwrap();
    (o, periods)
}

fn reference_at(s: &Scenario, t_s: f64) -> Reference<f64> {
    match s.motion {
        Motion::Profile => profile(t_s),
        Motion::Hold => Reference {
            position: START_M,
            velocity: 0.0,
            acceleration: 0.0,
        },
    }
}

/// One period of the linear plant under `force_n` (ZOH), ten semi-implicit Euler
/// substeps: linear and homogeneous in (position, velocity, force), so the deviation
/// model below steps deviations with the same function.
fn plant_step(position: &mut f64, velocity: &mut f64, force_n: f64) {
    let h = TS_S / 10.0;
    for _ in 0..10 {
        *velocity += h * (force_n - PLANT_VISCOUS_N_S_PER_M * *velocity) / PLANT_MASS_KG;
        *position += h * *velocity;
    }
}

/// One kernel-loop period's record.
#[derive(Copy, Clone)]
struct Kernel {
    position_m: f64,
    error_m: f64,
    force_n: f64,
    estimate_n: f64,
    velocity_m_s: f64,
}

/// The axis law's kernels in scalar `T` (observer → PD → DOB, wired as
/// `AxisLaw::actuate` wires them) against the linear plant, over the scenario's
/// reference and load.
fn kernel_loop<T: Real>(s: &Scenario) -> Vec<Kernel> {
    let config = s.machine.axis;
    let observer = TrackingObserver::<T>::new(&config.velocity, TS_S).unwrap();
    let pd = Pd::<T>::new(&config.pd).unwrap();
    let dob = Dob::<T>::new(&config.dob, TS_S).unwrap();
    let (mut x, mut v) = (START_M, 0.0);
    let mut tracking = TrackingObserverState::at_rest(T::from_f64(x));
    let mut estimate = DobState::at(T::ZERO);
    let mut applied = T::ZERO;
    let mut noise = 0x2545_f491_4f6c_dd1du64;
    (0..s.periods)
        .map(|k| {
            let t = f64::from(k) * TS_S;
            noise ^= noise << 13;
            noise ^= noise >> 7;
            noise ^= noise << 17;
            let n = ((noise >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * NOISE_M;
            let measured = T::from_f64(x + n);
            let velocity = observer.update(&mut tracking, measured, applied);
            let r64 = reference_at(s, t);
            let r = Reference {
                position: T::from_f64(r64.position),
                velocity: T::from_f64(r64.velocity),
                acceleration: T::from_f64(r64.acceleration),
            };
            let out = dob.update(
                &mut estimate,
                pd.acceleration(&r, measured, velocity),
                velocity,
            );
            applied = dob.applied_acceleration(&out);
            let record = Kernel {
                position_m: x,
                error_m: r64.position - x,
                force_n: out.force_n.to_f64(),
                estimate_n: estimate.estimate_n.to_f64(),
                velocity_m_s: velocity.to_f64(),
            };
            let load = match s.load_step {
                Some((at, f)) if t + TS_S >= at => f,
                _ => 0.0,
            };
            plant_step(&mut x, &mut v, out.force_n.to_f64() - load);
            record
        })
        .collect()
}

/// Where a rounding enters the loop (see `Deviation::period`).
#[derive(Copy, Clone, Debug, PartialEq)]
enum Point {
    /// The measured position in the scalar.
    Measured,
    /// The observer's predicted step v̂·Ts + a·Ts²/2 (and the sum x̂ + step).
    Step,
    /// The observer's correction α·e (and the sum).
    Correction,
    /// The velocity update (a·Ts, β/Ts·e and the sums).
    Velocity,
    /// The reference's position, velocity and acceleration in the scalar.
    ReferencePosition,
    ReferenceVelocity,
    ReferenceAcceleration,
    /// The PD's acceleration command.
    Command,
    /// The force An·q̈des + F̂.
    Force,
    /// The DOB's estimate update.
    Estimate,
    /// The applied acceleration (F − F̂)/An the observer predicts with.
    Applied,
}

const POINTS: [Point; 11] = [
    Point::Measured,
    Point::Step,
    Point::Correction,
    Point::Velocity,
    Point::ReferencePosition,
    Point::ReferenceVelocity,
    Point::ReferenceAcceleration,
    Point::Command,
    Point::Force,
    Point::Estimate,
    Point::Applied,
];

/// The loop's coefficients, from the configuration as the docs define them.
struct Coefficients {
    alpha: f64,
    beta_over_ts: f64,
    kp: f64,
    kd: f64,
    mass: f64,
    k: f64,
    decay_g_mass: f64,
}

impl Coefficients {
    fn of(config: &AxisConfig) -> Self {
        let p = (-config.velocity.bandwidth_rad_s * TS_S).exp();
        let g = config.dob.bandwidth_rad_s;
        let k = 1.0 - (-g * TS_S).exp();
        Self {
            alpha: 1.0 - p * p,
            beta_over_ts: (1.0 - p) * (1.0 - p) / TS_S,
            kp: config.pd.kp_per_s2,
            kd: config.pd.kd_per_s,
            mass: config.dob.nominal_mass_kg,
            k,
            decay_g_mass: (1.0 - k) * g * config.dob.nominal_mass_kg,
        }
    }
}

/// The closed loop's deviation dynamics (observer, PD, DOB, plant) from the equations.
#[derive(Default)]
struct Deviation {
    x: f64,
    v: f64,
    estimate: f64,
    v_last: f64,
    applied: f64,
    plant_x: f64,
    plant_v: f64,
}

impl Deviation {
    /// One period with `u` injected at `at`; returns the force's and the plant
    /// position's deviations.
    fn period(&mut self, c: &Coefficients, at: Option<Point>, u: f64) -> (f64, f64) {
        let inj = |p: Point| if at == Some(p) { u } else { 0.0 };
        let plant_x = self.plant_x;
        let measured = plant_x + inj(Point::Measured);
        let step = self.v * TS_S + self.applied * TS_S * TS_S / 2.0 + inj(Point::Step);
        let predicted = self.x + step;
        let innovation = measured - predicted;
        self.x = predicted + c.alpha * innovation + inj(Point::Correction);
        self.v = self.v + self.applied * TS_S + c.beta_over_ts * innovation + inj(Point::Velocity);
        let command = inj(Point::ReferenceAcceleration)
            + c.kd * (inj(Point::ReferenceVelocity) - self.v)
            + c.kp * (inj(Point::ReferencePosition) - measured)
            + inj(Point::Command);
        let old = self.estimate;
        let force = c.mass * command + old + inj(Point::Force);
        self.estimate = old
            + c.k * (force - old)
            + c.decay_g_mass * (self.v_last - self.v)
            + inj(Point::Estimate);
        self.v_last = self.v;
        self.applied = (force - old) / c.mass + inj(Point::Applied);
        plant_step(&mut self.plant_x, &mut self.plant_v, force);
        (force, plant_x)
    }
}

/// ‖h‖₁ and ‖h(k) − h(k−1)‖₁ of the force's and the plant position's responses to a
/// unit impulse at `at`: `[force, position]`, each `(plain, differenced)`.
fn response_norms(c: &Coefficients, at: Point) -> [(f64, f64); 2] {
    let mut d = Deviation::default();
    let mut norms = [(0.0, 0.0); 2];
    let mut last = [0.0; 2];
    let mut peak = [0.0f64; 2];
    for k in 0..RESPONSE_PERIODS {
        let (f, x) = d.period(c, (k == 0).then_some(at), 1.0);
        for ((h, (norm, diff)), (last, peak)) in [f, x]
            .into_iter()
            .zip(norms.iter_mut())
            .zip(last.iter_mut().zip(peak.iter_mut()))
        {
            *norm += h.abs();
            *diff += (h - *last).abs();
            *last = h;
            *peak = peak.max(h.abs());
        }
    }
    for (k, norm) in norms.iter_mut().enumerate() {
        // Decayed: the rest of the response adds nothing that matters.
        assert!(last[k].abs() < 1e-12 * peak[k], "{at:?}: {}", last[k]);
        norm.1 += last[k].abs();
    }
    norms
}

/// Largest magnitudes of the loop's signals in the f64 run (for f32's ulps).
struct Peaks {
    position: f64,
    velocity: f64,
    force: f64,
}

/// The most one period's roundings of the scalar put in at `point`, and whether
/// they carry.
fn injection(scalar: &str, point: Point, peaks: &Peaks, c: &Coefficients) -> (f64, bool) {
    // The command's and the applied acceleration's magnitude: at most the force
    // limit over An (the clamp does not act).
    let acceleration = 3.6 / c.mass;
    match scalar {
        "Q6_25" => {
            let half = Q6_25::RESOLUTION / 2.0;
            // A product's rounding plus its Gain's relative error (2^-31) times the
            // product (every product here is below 8 in magnitude). Sums are exact.
            let product = half + 8.0 * 2f64.powi(-31);
            match point {
                Point::Measured
                | Point::ReferencePosition
                | Point::ReferenceVelocity
                | Point::ReferenceAcceleration => (half, false),
                // Both carried (Real::mul_add_carry, Real::scale_carry).
                Point::Step | Point::Correction => (product, true),
                // a·Ts and β/Ts·e; Kd·ė and Kp·e; k·(F − F̂) and (1 − k)·g·An·Δv.
                Point::Velocity | Point::Command | Point::Estimate => (2.0 * product, false),
                Point::Force | Point::Applied => (product, false),
            }
        }
        "Q31_32" => {
            // `fixed`'s products may truncate: a whole step each; no carry.
            let step = 2f64.powi(-32);
            let count = match point {
                Point::Measured
                | Point::ReferencePosition
                | Point::ReferenceVelocity
                | Point::ReferenceAcceleration => 0.5,
                Point::Step | Point::Velocity | Point::Command | Point::Estimate => 2.0,
                _ => 1.0,
            };
            (count * step, false)
        }
        "f32" => {
            // Half an ulp (2^-24 relative) of every operation's result, counted per
            // point with the largest value it handles.
            let u = 2f64.powi(-24);
            let bound = match point {
                Point::Measured | Point::ReferencePosition => u * peaks.position,
                // v·Ts, a·Ts²/2, their sum, + x̂.
                Point::Step => u * (3.0 * peaks.velocity * TS_S + peaks.position),
                // e (below 1e-4 m here), α·e, + predicted.
                Point::Correction => u * (2.0 * 1e-4 + peaks.position),
                // a·Ts, β/Ts·e, two sums.
                Point::Velocity => 4.0 * u * peaks.velocity,
                Point::ReferenceVelocity => u * peaks.velocity,
                Point::ReferenceAcceleration => u * acceleration,
                // Two differences, two products, two sums.
                Point::Command => 6.0 * u * acceleration,
                Point::Force => 2.0 * u * peaks.force,
                // F − F̂, k·(…), v₋ − v (in force: (1 − k)·g·An·…), the product, two sums.
                Point::Estimate => 6.0 * u * peaks.force,
                Point::Applied => 2.0 * u * acceleration,
            };
            (bound, false)
        }
        _ => (0.0, false),
    }
}

/// Bounds on |ΔF| and |Δx| against f64: `[force, position]`.
fn bounds(scalar: &str, peaks: &Peaks, c: &Coefficients) -> [f64; 2] {
    let mut total = [0.0; 2];
    for &point in &POINTS {
        let (b, carried) = injection(scalar, point, peaks, c);
        for (t, (norm, diff)) in total.iter_mut().zip(response_norms(c, point)) {
            *t += b * if carried { diff } else { norm };
        }
    }
    // The observer starts at the first measurement (x̂ = m, v̂ = 0), where the
    // recursion would take x̂ = α m, v̂ = β/Ts m: once, a further difference of at
    // most b_m in x̂ and β/Ts·b_m in v̂.
    let (measured, _) = injection(scalar, Point::Measured, peaks, c);
    let x0 = response_norms(c, Point::Correction);
    let v0 = response_norms(c, Point::Velocity);
    for (k, t) in total.iter_mut().enumerate() {
        *t += measured * (x0[k].0 + c.beta_over_ts * v0[k].0);
    }
    total
}

fn rms(v: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = v.clone().count().max(1) as f64;
    (v.map(|x| x * x).sum::<f64>() / n).sqrt()
}

fn worst(v: impl Iterator<Item = f64>) -> f64 {
    v.map(f64::abs).fold(0.0, f64::max)
}

/// The machine on the simulated axis (Hall ADC, Coulomb friction), the single axis and
/// a Keops slave joint: the tracking errors side by side and against f64, held to the
/// issue's goal.
#[test]
fn machine_errors_against_f64() {
    println!("| scenario | scalar | RMS error µm | max error µm | vs f64: max Δe µm | RMS Δe µm | max ΔF mN |");
    println!("|---|---|---|---|---|---|---|");
    for (name, s) in machine_scenarios() {
        let (o64, p64) = trace::<f64>(&s);
        for (scalar, (o, p)) in [
            ("f64", (o64, p64.clone())),
            ("f32", trace::<f32>(&s)),
            ("Q31_32", trace::<Q31_32>(&s)),
            ("Q6_25", trace::<Q6_25>(&s)),
        ] {
            assert_eq!(p.len(), p64.len(), "{name} {scalar}");
            let de = p.iter().zip(&p64).map(|(a, b)| a.error_m - b.error_m);
            println!(
                "| {name} | {scalar} | {:.3} | {:.3} | {:.3} | {:.3} | {:.2} |",
                o.rms_error_m * 1e6,
                o.max_error_m * 1e6,
                worst(de.clone()) * 1e6,
                rms(de) * 1e6,
                worst(p.iter().zip(&p64).map(|(a, b)| a.force_n - b.force_n)) * 1e3,
            );
            assert!(o.fault_period.is_none(), "{name} {scalar}");
            // The goal: tracking error within 10 % of the f64 reference.
            assert!(
                (o.rms_error_m / o64.rms_error_m - 1.0).abs() <= 0.10,
                "{name} {scalar}: {} against {}",
                o.rms_error_m,
                o64.rms_error_m
            );
        }
    }
}

/// The law's kernels in closed loop with the linear plant: each scalar's force and
/// position differences from f64 within the bound its roundings imply.
#[test]
fn kernel_errors_against_f64_within_their_quantization_bounds() {
    let c = Coefficients::of(&AxisConfig::LM1247_SLAVE);
    println!("| scenario | scalar | RMS error µm | max error µm | max Δx nm (bound) | RMS Δx nm | max ΔF µN (bound) |");
    println!("|---|---|---|---|---|---|---|");
    for (name, s) in axis_scenarios() {
        let k64 = kernel_loop::<f64>(&s);
        let limit = s.machine.axis.dob.force_limit_n;
        // The clamp never acts, so the deviation dynamics are linear.
        assert!(k64.iter().all(|r| r.force_n.abs() < 0.9 * limit));
        let peaks = Peaks {
            position: worst(k64.iter().map(|r| r.position_m)),
            velocity: worst(k64.iter().map(|r| r.velocity_m_s)),
            force: worst(k64.iter().flat_map(|r| [r.force_n, r.estimate_n])),
        };
        for (scalar, run) in [
            ("f64", k64.clone()),
            ("f32", kernel_loop::<f32>(&s)),
            ("Q31_32", kernel_loop::<Q31_32>(&s)),
            ("Q6_25", kernel_loop::<Q6_25>(&s)),
        ] {
            let [force_bound, position_bound] = bounds(scalar, &peaks, &c);
            let dx = run
                .iter()
                .zip(&k64)
                .map(|(a, b)| a.position_m - b.position_m);
            let df = worst(run.iter().zip(&k64).map(|(a, b)| a.force_n - b.force_n));
            let errors = run.iter().map(|r| r.error_m);
            println!(
                "| {name} | {scalar} | {:.3} | {:.3} | {:.2} ({:.2}) | {:.2} | {:.2} ({:.2}) |",
                rms(errors.clone()) * 1e6,
                worst(errors) * 1e6,
                worst(dx.clone()) * 1e9,
                position_bound * 1e9,
                rms(dx.clone()) * 1e9,
                df * 1e6,
                force_bound * 1e6
            );
            assert!(
                df <= force_bound,
                "{name} {scalar}: ΔF {df} > {force_bound}"
            );
            assert!(
                worst(dx.clone()) <= position_bound,
                "{name} {scalar}: Δx beyond {position_bound}"
            );
        }
    }
}
