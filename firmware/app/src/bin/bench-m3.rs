//! Benchmarks on an FPU-less core: instructions per call of the single-axis loop in
//! fixed point against the same generic code in `f32` (software floating point on
//! this core), in the same image on the same inputs, on QEMU's Cortex-M3
//! (`mps2-an385`). Prints BENCHMARKS.md rows; `scripts/bench` runs it under `-icount`
//! beside the Cortex-M4 image. The estimated-cycle columns are "—": `scripts/cycles`
//! models the Cortex-M4's timings.
//!
//! The error columns are the largest force difference against the same code in
//! `f64`, each run from the same fresh state on the same inputs: PD + DOB over the 64
//! inputs, the axis step over periods 64 to 256 of its ramp (after the start-up).
//!
//! The Keops slave joint row is one of the slave's three carriages: the same
//! `AxisLaw::step` with the slave's configuration (`DeltaSlaveConfig::KEOPS.joints`:
//! its law, its first carriage's Hall decoder, homed at its 10 mm home), on the same
//! Hall inputs and the same ramp, started from that home. The `Joints<T, 3>` row is
//! the slave's three carriages (`DeltaSlaveConfig::KEOPS.joints`) in one period of a
//! job that holds them at home (a dwell: the reference's sample, then three axis
//! steps), each carriage's Hall inputs dithering ±0.7 µm about its home; its errors
//! are over the three carriages' forces, periods 64 to 256 of the hold.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_semihosting::hprintln;
use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, HallAxis};
use kerf::app::joints::{JointJob, Joints, Segment};
use kerf::app::supervisor::{Machine, Step};
use kerf::control::dob::{Dob, DobState};
use kerf::control::pd::Pd;
use kerf::machines::delta_slave::DeltaSlaveConfig;
use kerf::sensing::hall::HallConfig;
use kerf::trajectory::Reference;
use kerf::{Real, Q31_32, Q6_25};
use kerf_app::bench::Counter;
use kerf_app::exit;
use kerf_app::inputs::{counts_at_phase, references, INPUTS};

const TS_S: f64 = 1e-4;
const MASK: u32 = INPUTS as u32 - 1;

/// Hall samples of an axis that follows the benchmark's reference ramp (0.1 m/s from
/// the 4 mm home) 1 µm behind: the loop's forces stay off the limit after the
/// observer's start-up (the Cortex-M4 image's `hall_inputs` move 2.8 m/s and saturate
/// them, which makes a poor error check). The wrap from the last input to the first
/// is a 0.63 mm jump, well inside the decoder's quarter pitch.
fn hall_inputs() -> [[u16; 3]; INPUTS] {
    core::array::from_fn(hall_at)
}

/// Hall counts of the ramp-following axis in period `k` (from its home, on the
/// nominal LM1247 sensor of both setups).
fn hall_at(k: usize) -> [u16; 3] {
    let travel = 1e-5 * k as f64 - 1e-6;
    let phase = 2.0 * core::f64::consts::PI * travel / HallConfig::LM1247_16BIT.pitch_m;
    counts_at_phase(libm::fmod(phase, 2.0 * core::f64::consts::PI) as f32)
}

/// Periods of the error check: the first [`INPUTS`] are the observer's start-up from
/// rest (the force at its limit in many), the rest are compared.
const ERROR_PERIODS: usize = 4 * INPUTS;

/// One row: kernel and reference net of the same baseline, the errors in N.
fn row(
    counter: &mut Counter,
    name: &str,
    kernel: impl FnMut(u32),
    reference_name: &str,
    reference: impl FnMut(u32),
    baseline: impl FnMut(u32) + Copy,
    errors_n: (f64, f64),
) {
    let n = counter.per_call(name, kernel, baseline);
    let r = counter.per_call(reference_name, reference, baseline);
    hprintln!(
        "| {} | {:.0} | {} | {:.0} | — | — | {:.1e} N | {:.1e} N |",
        name,
        n,
        reference_name,
        r,
        errors_n.0,
        errors_n.1
    );
}

/// What the axis step runs with: the law, the Hall decoder and the home.
#[derive(Copy, Clone)]
struct Setup {
    /// What the comment line before the row calls it (`scripts/bench` reads it).
    label: &'static str,
    law: AxisConfig,
    hall: HallConfig,
    home_m: f64,
}

/// The single axis of the M4 bench: the LM1247 law, homed at 4 mm.
const SINGLE_AXIS: Setup = Setup {
    label: "axis step",
    law: AxisConfig::LM1247_SLAVE,
    hall: HallConfig::LM1247_16BIT,
    home_m: 0.004,
};

/// One Keops slave carriage: the slave's law, its first carriage's decoder and home.
const KEOPS_JOINT: Setup = Setup {
    label: "Keops slave joint step",
    law: DeltaSlaveConfig::KEOPS.joints.axis,
    hall: DeltaSlaveConfig::KEOPS.joints.hall[0],
    home_m: DeltaSlaveConfig::KEOPS.joints.home_m[0],
};

/// The references in scalar `T` (the ramp from 4 mm), shifted by `offset_m`.
fn references_in<T: Real>(offset_m: f64) -> [Reference<T>; INPUTS] {
    references().map(|r| Reference {
        position: T::from_f64(f64::from(r.position) + offset_m),
        velocity: T::from_f64(f64::from(r.velocity)),
        acceleration: T::from_f64(f64::from(r.acceleration)),
    })
}

/// The axis law, its sensor and a fresh state at its home in scalar `T`.
fn axis<T: Real>(setup: &Setup) -> Option<(AxisLaw<T>, HallAxis<T>, AxisState<T>)> {
    Some((
        AxisLaw::new(&setup.law, TS_S).ok()?,
        HallAxis::new(&setup.hall).ok()?,
        AxisState::homed_at(T::from_f64(setup.home_m)),
    ))
}

/// Forces of [`ERROR_PERIODS`] periods of the ramp (continued past the 64 inputs, so
/// without their wrap) from a fresh state, after the start-up's [`INPUTS`].
fn axis_forces<T: Real>(setup: &Setup) -> Option<[f64; ERROR_PERIODS - INPUTS]> {
    let (law, sensor, mut state) = axis::<T>(setup)?;
    let mut out = [0.0; ERROR_PERIODS - INPUTS];
    for k in 0..ERROR_PERIODS {
        let r = Reference {
            position: T::from_f64(setup.home_m + 1e-5 * k as f64),
            velocity: T::from_f64(0.1),
            acceleration: T::from_f64(0.5),
        };
        let force = law.step(&sensor, &mut state, hall_at(k), &r).force_n;
        if let Some(f) = k.checked_sub(INPUTS).and_then(|i| out.get_mut(i)) {
            *f = force.to_f64();
        }
    }
    Some(out)
}

/// Hall counts of carriage `axis` held at home in period `k`: 0.2 µm steps in a
/// ±0.7 µm cycle of 8 periods, each carriage at another point of it.
fn hold_hall_at(axis: usize, k: usize) -> [u16; 3] {
    let travel = (((k + 3 * axis) % 8) as f64 - 3.5) * 2e-7;
    let phase = 2.0 * core::f64::consts::PI * travel / HallConfig::LM1247_16BIT.pitch_m;
    counts_at_phase(libm::fmod(
        phase + 2.0 * core::f64::consts::PI,
        2.0 * core::f64::consts::PI,
    ) as f32)
}

/// The three carriages' Hall inputs of the hold, for the counted calls.
fn hold_inputs() -> [[[u16; 3]; 3]; INPUTS] {
    core::array::from_fn(|k| core::array::from_fn(|axis| hold_hall_at(axis, k)))
}

/// The job of the `Joints` row: every carriage held at its home for 60 s (longer
/// than every counted run).
fn hold_job() -> Option<JointJob<3>> {
    JointJob::from_slice(&[Segment {
        target_m: DeltaSlaveConfig::KEOPS.joints.home_m,
        // Below the 64 s a Q6.25 machine holds as a move's time (`Real::RANGE`).
        duration_s: 60.0,
    }])
}

/// The slave's carriages with the hold job begun, in scalar `T`.
fn joints_holding<T: Real>(job: &JointJob<3>) -> Option<Joints<T, 3>> {
    let mut joints = Joints::<T, 3>::new(&DeltaSlaveConfig::KEOPS.joints).ok()?;
    joints.check_job(job).ok()?;
    joints.begin_job(job).ok()?;
    Some(joints)
}

/// One period of the held carriages: their forces, `None` on a fault.
fn joints_period<T: Real>(
    joints: &mut Joints<T, 3>,
    job: &JointJob<3>,
    inputs: &[[u16; 3]; 3],
) -> Option<[T; 3]> {
    match joints.run(job, inputs).ok()? {
        Step::Continue(forces) | Step::Done(forces) => Some(forces),
    }
}

/// The three carriages' forces over [`ERROR_PERIODS`] periods of the hold from a
/// fresh machine, after the start-up's [`INPUTS`].
fn joints_forces<T: Real>() -> Option<[f64; 3 * (ERROR_PERIODS - INPUTS)]> {
    let job = hold_job()?;
    let mut joints = joints_holding::<T>(&job)?;
    let mut out = [0.0; 3 * (ERROR_PERIODS - INPUTS)];
    for k in 0..ERROR_PERIODS {
        let inputs = core::array::from_fn(|axis| hold_hall_at(axis, k));
        let forces = joints_period(&mut joints, &job, &inputs)?;
        if let Some(i) = k.checked_sub(INPUTS) {
            for (o, f) in out.iter_mut().skip(3 * i).zip(forces) {
                *o = f.to_f64();
            }
        }
    }
    Some(out)
}

/// Forces of one pass of PD + DOB over the inputs (position and velocity as the M4
/// bench feeds them) from a fresh state.
fn pd_dob_forces<T: Real>() -> Option<[f64; INPUTS]> {
    let config = AxisConfig::LM1247_SLAVE;
    let (pd, dob) = (
        Pd::<T>::new(&config.pd).ok()?,
        Dob::<T>::new(&config.dob, TS_S).ok()?,
    );
    let mut state = DobState::at(T::ZERO);
    let refs = references_in::<T>(0.0);
    let mut out = [0.0; INPUTS];
    for (k, (f, r)) in out.iter_mut().zip(&refs).enumerate() {
        let (p, v) = pd_dob_input::<T>(k);
        *f = dob
            .update(&mut state, pd.acceleration(r, p, v), v)
            .force_n
            .to_f64();
    }
    Some(out)
}

fn pd_dob_input<T: Real>(k: usize) -> (T, T) {
    (T::from_f64(0.004 + 1.1e-5 * k as f64), T::from_f64(0.099))
}

fn worst(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| libm::fabs(x - y))
        .fold(0.0, f64::max)
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        exit(false)
    };
    let mut counter = Counter::new(peripherals.SYST);
    hprintln!(
        "# calibration (Cortex-M3): {:.3} instructions per SysTick tick (40 expected at -icount shift=0)",
        counter.instructions_per_tick()
    );
    let single = "app::axis::AxisLaw::step <Q6_25> (decode + observer + PD + DOB), Cortex-M3";
    let joint = "app::axis::AxisLaw::step <Q6_25>, Keops slave joint (LM1247_SLAVE), Cortex-M3";
    if !(axis_rows(&mut counter, single, &SINGLE_AXIS).is_some()
        && axis_rows(&mut counter, joint, &KEOPS_JOINT).is_some()
        && joints_rows(&mut counter).is_some()
        && pd_dob_rows(&mut counter).is_some())
    {
        exit(false)
    }
    exit(true)
}

#[inline(never)]
fn axis_rows(counter: &mut Counter, name: &str, setup: &Setup) -> Option<()> {
    let hall = hall_inputs();
    let (law_q, sensor_q, mut state_q) = axis::<Q6_25>(setup)?;
    let (law_f, sensor_f, mut state_f) = axis::<f32>(setup)?;
    let offset = setup.home_m - SINGLE_AXIS.home_m;
    let (refs_q, refs_f) = (references_in::<Q6_25>(offset), references_in::<f32>(offset));
    let reference = axis_forces::<f64>(setup)?;
    let limit = setup.law.dob.force_limit_n;
    let saturated = reference
        .iter()
        .filter(|f| libm::fabs(**f) >= limit)
        .count();
    hprintln!(
        "# Cortex-M3 {}: errors over periods {} to {} of the ramp (after the start-up from rest), {} of them at the force limit in f64",
        setup.label,
        INPUTS,
        ERROR_PERIODS,
        saturated
    );
    let errors = (
        worst(&axis_forces::<Q6_25>(setup)?, &reference),
        worst(&axis_forces::<f32>(setup)?, &reference),
    );
    row(
        counter,
        name,
        |i| {
            let k = (i & MASK) as usize;
            black_box(law_q.step(&sensor_q, &mut state_q, black_box(hall[k]), &refs_q[k]));
        },
        "same loop <f32>, Cortex-M3 (software float)",
        |i| {
            let k = (i & MASK) as usize;
            black_box(law_f.step(&sensor_f, &mut state_f, black_box(hall[k]), &refs_f[k]));
        },
        |i| {
            black_box(black_box(hall[(i & MASK) as usize]));
        },
        errors,
    );
    Some(())
}

#[inline(never)]
fn joints_rows(counter: &mut Counter) -> Option<()> {
    let hold = hold_inputs();
    let job = hold_job()?;
    let mut joints_q = joints_holding::<Q6_25>(&job)?;
    let mut joints_f = joints_holding::<f32>(&job)?;
    let reference = joints_forces::<f64>()?;
    let limit = DeltaSlaveConfig::KEOPS.joints.axis.dob.force_limit_n;
    let saturated = reference
        .iter()
        .filter(|f| libm::fabs(**f) >= limit)
        .count();
    hprintln!(
        "# Cortex-M3 Keops slave joints: errors over periods {} to {} of the hold (after the start-up from rest), {} forces at the limit in f64",
        INPUTS,
        ERROR_PERIODS,
        saturated
    );
    let errors = (
        worst(&joints_forces::<Q6_25>()?, &reference),
        worst(&joints_forces::<f32>()?, &reference),
    );
    // A fault (none on these inputs) fails the image: non-zero exit after the row.
    let (mut faults_q, mut faults_f) = (0u32, 0u32);
    row(
        counter,
        "app::joints::Joints<Q6_25, 3>::run, Keops slave's three carriages holding, Cortex-M3",
        |i| {
            let k = (i & MASK) as usize;
            let r = joints_period(&mut joints_q, &job, black_box(&hold[k]));
            faults_q += u32::from(black_box(r).is_none());
        },
        "same period <f32>, Cortex-M3 (software float)",
        |i| {
            let k = (i & MASK) as usize;
            let r = joints_period(&mut joints_f, &job, black_box(&hold[k]));
            faults_f += u32::from(black_box(r).is_none());
        },
        |i| {
            black_box(black_box(&hold[(i & MASK) as usize]));
        },
        errors,
    );
    (faults_q == 0 && faults_f == 0).then_some(())
}

#[inline(never)]
fn pd_dob_rows(counter: &mut Counter) -> Option<()> {
    let config = AxisConfig::LM1247_SLAVE;
    let pd_q = Pd::<Q6_25>::new(&config.pd).ok()?;
    let dob_q = Dob::<Q6_25>::new(&config.dob, TS_S).ok()?;
    let pd_w = Pd::<Q31_32>::new(&config.pd).ok()?;
    let dob_w = Dob::<Q31_32>::new(&config.dob, TS_S).ok()?;
    let pd_f = Pd::<f32>::new(&config.pd).ok()?;
    let dob_f = Dob::<f32>::new(&config.dob, TS_S).ok()?;
    let (refs_q, refs_w, refs_f) = (
        references_in::<Q6_25>(0.0),
        references_in::<Q31_32>(0.0),
        references_in::<f32>(0.0),
    );
    let inputs_q: [(Q6_25, Q6_25); INPUTS] = core::array::from_fn(pd_dob_input);
    let inputs_w: [(Q31_32, Q31_32); INPUTS] = core::array::from_fn(pd_dob_input);
    let inputs_f: [(f32, f32); INPUTS] = core::array::from_fn(pd_dob_input);
    let (mut state_q, mut state_w, mut state_f) = (
        DobState::at(Q6_25::ZERO),
        DobState::at(Q31_32::ZERO),
        DobState::at(0.0f32),
    );
    let reference = pd_dob_forces::<f64>()?;
    let error_f = worst(&pd_dob_forces::<f32>()?, &reference);
    let soft_float = |i: u32| {
        let k = (i & MASK) as usize;
        let (p, v) = black_box(inputs_f[k]);
        black_box(dob_f.update(&mut state_f, pd_f.acceleration(&refs_f[k], p, v), v));
    };
    let baseline = |i: u32| {
        black_box(i);
    };
    row(
        counter,
        "control::{pd,dob} one period <Q6_25>, Cortex-M3",
        |i| {
            let k = (i & MASK) as usize;
            let (p, v) = black_box(inputs_q[k]);
            black_box(dob_q.update(&mut state_q, pd_q.acceleration(&refs_q[k], p, v), v));
        },
        "same law <f32>, Cortex-M3 (software float)",
        soft_float,
        baseline,
        (worst(&pd_dob_forces::<Q6_25>()?, &reference), error_f),
    );
    let mut state_f = DobState::at(0.0f32);
    row(
        counter,
        "control::{pd,dob} one period <Q31_32> (64-bit), Cortex-M3",
        |i| {
            let k = (i & MASK) as usize;
            let (p, v) = black_box(inputs_w[k]);
            black_box(dob_w.update(&mut state_w, pd_w.acceleration(&refs_w[k], p, v), v));
        },
        "same law <f32>, Cortex-M3 (software float)",
        |i| {
            let k = (i & MASK) as usize;
            let (p, v) = black_box(inputs_f[k]);
            black_box(dob_f.update(&mut state_f, pd_f.acceleration(&refs_f[k], p, v), v));
        },
        baseline,
        (worst(&pd_dob_forces::<Q31_32>()?, &reference), error_f),
    );
    Some(())
}
