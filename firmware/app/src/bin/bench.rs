//! Benchmarks: instructions per call of each kernel and of its reference, in the same
//! run, on QEMU's emulated Cortex-M4. Prints the rows of the BENCHMARKS.md table;
//! `scripts/bench` runs it under `-icount` and rewrites the table.
#![no_std]
#![no_main]

use core::f32::consts::PI;
use core::hint::black_box;
use cortex_m_semihosting::hprintln;
use hal_mock::hall_sensor::{calibration_coast_m, HallSensor, HallSensorParams, COAST_PITCHES};
use heapless::spsc::Queue;
use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, HallAxis};
use kerf::app::calibrate::{
    CalibrationFit, HallMachine, HallSample, SAMPLES_PER_COAST, SEGMENT_BREAK,
};
use kerf::app::jobs::{JobSlot, JobSlots};
use kerf::app::joints::{JointJob, Joints, JointsConfig, Segment};
use kerf::app::supervisor::{Command, Machine, Report, Supervisor};
use kerf::control::contouring::Contouring;
use kerf::control::dob::{Dob, DobState};
use kerf::control::pd::Pd;
use kerf::kinematics::delta::DeltaGeometry;
use kerf::machines::delta_slave::{ContourLaw, DeltaJob, DeltaSlave, DeltaSlaveConfig};
use kerf::sensing::hall::{HallArithmetic, HallConfig, HallDecoder, HallState};
use kerf::trajectory::Reference;
use kerf::{Real, Q31_32};
use kerf_app::bench::Counter;
use kerf_app::exit;
use kerf_app::inputs::{counts_at_phase, hall_inputs, references, INPUTS};
use kerf_app::stack::Painted;
use kerf_sim::contour::octagon_job;

#[path = "bench/checks.rs"]
mod checks;
#[path = "bench/kernels.rs"]
mod kernels;
#[path = "bench/peers.rs"]
mod peers;
#[path = "bench/stages.rs"]
mod stages;

fn row(
    counter: &mut Counter,
    name: &str,
    kernel: impl FnMut(u32),
    reference_name: &str,
    reference: impl FnMut(u32),
    baseline: impl FnMut(u32) + Copy,
) {
    row_with_errors(
        counter,
        name,
        kernel,
        reference_name,
        reference,
        (baseline, baseline),
        None,
    );
}

/// One row of the table: `kernel` and `reference` per call, each net of `baseline`
/// (the same loop with the same input and output moves, without either), then their
/// errors against an f64 reference when given ("—" otherwise); `baselines` are the
/// kernel's and the reference's, when their moves differ. The traced run keys
/// the reference by the row's name, since reference names repeat.
fn row_with_errors(
    counter: &mut Counter,
    name: &str,
    kernel: impl FnMut(u32),
    reference_name: &str,
    reference: impl FnMut(u32),
    baselines: (impl FnMut(u32), impl FnMut(u32)),
    errors: Option<(f64, f64, &str)>,
) {
    let n = counter.per_call(name, kernel, baselines.0);
    let mut key = heapless::String::<128>::new();
    let _ = core::fmt::write(&mut key, format_args!("{name} :: reference"));
    let r = counter.per_call(&key, reference, baselines.1);
    match errors {
        Some((e, er, unit)) => hprintln!(
            "| {} | {:.0} | {} | {:.0} | {:.1e}{} | {:.1e}{} |",
            name,
            n,
            reference_name,
            r,
            e,
            unit,
            er,
            unit
        ),
        None => hprintln!(
            "| {} | {:.0} | {} | {:.0} | — | — |",
            name,
            n,
            reference_name,
            r
        ),
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        exit(false)
    };
    let mut counter = Counter::new(peripherals.SYST);
    hprintln!(
        "# calibration: {:.3} instructions per SysTick tick (40 expected at -icount shift=0)",
        counter.instructions_per_tick()
    );

    checks::run(&mut counter);
    kernel_rows(&mut counter);
    slave_period_rows(&mut counter);
    if counter.is_traced() {
        // The traced run is for the timed loops only.
        exit(true)
    }
    state_sizes();
    machine_stacks();
    fit_stack::<Joints<f32, 1>, 1>("Joints<f32, 1>");
    fit_stack::<DeltaSlave<f32>, 3>("DeltaSlave<f32>");
    exit(true)
}

/// Every kernel's row of the table, each beside its reference. Out of line, so that
/// its inputs are off the stack before the stack measurements.
#[inline(never)]
fn kernel_rows(counter: &mut Counter) {
    let hall = hall_inputs();
    let axis = AxisConfig::LM1247_SLAVE;
    let hall_config = HallConfig::LM1247_16BIT;
    let ts = 1e-4;
    let (
        Ok(decoder),
        Ok(pd32),
        Ok(dob32),
        Ok(pdq),
        Ok(dobq),
        Ok(law32),
        Ok(law64),
        Ok(sensor32),
        Ok(sensor64),
    ) = (
        HallDecoder::new(&hall_config),
        Pd::<f32>::new(&axis.pd),
        Dob::<f32>::new(&axis.dob, ts),
        Pd::<Q31_32>::new(&axis.pd),
        Dob::<Q31_32>::new(&axis.dob, ts),
        AxisLaw::<f32>::new(&axis, ts),
        AxisLaw::<f64>::new(&axis, ts),
        HallAxis::<f32>::new(&hall_config),
        HallAxis::<f64>::new(&hall_config),
    )
    else {
        exit(false)
    };
    let (mut hall_state, mut hall_state_f32) = (HallState::default(), HallState::default());
    let (mut dob32_state, mut dobq_state) = (DobState::at(0.0f32), DobState::at(Q31_32::ZERO));
    let (mut axis32, mut axis64) = (AxisState::homed_at(0.004f32), AxisState::homed_at(0.004f64));
    let mut f32_hall = hall_config;
    f32_hall.arithmetic = HallArithmetic::F32;
    let Ok(decoder_f32) = HallDecoder::new(&f32_hall) else {
        exit(false)
    };
    let mask = INPUTS as u32 - 1;
    let vectors: [(i32, i32); INPUTS] = core::array::from_fn(|k| {
        let phi = 2.0 * PI * (k as f32 + 0.3) / INPUTS as f32;
        (
            (78642.0 * libm::sinf(phi)) as i32,
            (78642.0 * libm::cosf(phi)) as i32,
        )
    });
    row(
        counter,
        "sensing::hall::atan2_turns (integer, table)",
        |i| {
            let (y, x) = black_box(vectors[(i & mask) as usize]);
            black_box(kerf::sensing::hall::atan2_turns(y, x));
        },
        "libm::atan2f",
        |i| {
            let (y, x) = black_box(vectors[(i & mask) as usize]);
            black_box(libm::atan2f(y as f32, x as f32));
        },
        |i| {
            black_box(black_box(vectors[(i & mask) as usize]));
        },
    );
    row(
        counter,
        "sensing::hall::HallDecoder::update (integer path, per axis)",
        |i| {
            black_box(
                decoder
                    .update(&mut hall_state, black_box(hall[(i & mask) as usize]), 0)
                    .ok(),
            );
        },
        "same decoder, HallArithmetic::F32 (f32 + libm::atan2f)",
        |i| {
            black_box(
                decoder_f32
                    .update(&mut hall_state_f32, black_box(hall[(i & mask) as usize]), 0)
                    .ok(),
            );
        },
        |i| {
            black_box(black_box(hall[(i & mask) as usize]));
        },
    );

    let refs = references();
    let refs_q: [Reference<Q31_32>; INPUTS] = core::array::from_fn(|k| Reference {
        position: Q31_32::from_f64(f64::from(refs[k].position)),
        velocity: Q31_32::from_f64(f64::from(refs[k].velocity)),
        acceleration: Q31_32::from_f64(f64::from(refs[k].acceleration)),
    });
    let positions: [f32; INPUTS] = core::array::from_fn(|k| 0.004 + 1.1e-5 * k as f32);
    let positions_q: [Q31_32; INPUTS] =
        core::array::from_fn(|k| Q31_32::from_f64(f64::from(positions[k])));
    row(
        counter,
        "control::{pd,dob} one period <f32>",
        |i| {
            let k = (i & mask) as usize;
            let a = pd32.acceleration(&refs[k], black_box(positions[k]), black_box(0.099));
            black_box(dob32.update(&mut dob32_state, a, 0.099));
        },
        "same law <Q31_32> (Q31.32 fixed point)",
        |i| {
            let k = (i & mask) as usize;
            let a = pdq.acceleration(
                &refs_q[k],
                black_box(positions_q[k]),
                black_box(Q31_32::from_q32(425_201_762)),
            );
            black_box(dobq.update(&mut dobq_state, a, Q31_32::from_q32(425_201_762)));
        },
        |i| {
            black_box(i);
        },
    );

    let refs64: [Reference<f64>; INPUTS] = core::array::from_fn(|k| Reference {
        position: f64::from(refs[k].position),
        velocity: f64::from(refs[k].velocity),
        acceleration: f64::from(refs[k].acceleration),
    });
    row(
        counter,
        "app::axis::AxisLaw::step <f32> (decode + observer + PD + DOB)",
        |i| {
            let k = (i & mask) as usize;
            black_box(law32.step(&sensor32, &mut axis32, black_box(hall[k]), &refs[k]));
        },
        "same loop <f64> (software double)",
        |i| {
            let k = (i & mask) as usize;
            black_box(law64.step(&sensor64, &mut axis64, black_box(hall[k]), &refs64[k]));
        },
        |i| {
            black_box(black_box(hall[(i & mask) as usize]));
        },
    );
    peers::rows(counter, &vectors);
    kernels::kinematics_rows(counter);
    kernels::arrow_rows(counter);
    peers::efd_rows(counter);
    kernels::codec_rows::<32>(counter, 8);
    kernels::codec_rows::<64>(counter, 16);
    kernels::sharpness_rows(counter);
    kernels::foc_rows(counter);
}

/// Sizes of the slave machine's state and of its per-axis parts, printed as `= ` lines
/// for the Memory section of BENCHMARKS.md.
fn state_sizes() {
    use core::mem::size_of;
    let sizes = [
        (
            "DeltaSlave<f32> (whole slave machine: 3 axes, geometry, contour run)",
            size_of::<DeltaSlave<f32>>(),
        ),
        (
            "Joints<f32, 3> (the three carriages)",
            size_of::<Joints<f32, 3>>(),
        ),
        (
            "AxisState<f32> (per axis: Hall tracking, observer, DOB)",
            size_of::<AxisState<f32>>(),
        ),
        (
            "HallState (per axis, inside AxisState)",
            size_of::<HallState>(),
        ),
        (
            "DobState<f32> (per axis, inside AxisState)",
            size_of::<DobState<f32>>(),
        ),
        (
            "HallAxis<f32> (per axis coefficients: decoder with its phase table)",
            size_of::<HallAxis<f32>>(),
        ),
        (
            "AxisLaw<f32> (coefficients shared by the axes)",
            size_of::<AxisLaw<f32>>(),
        ),
        ("DeltaJob (a planned job)", size_of::<DeltaJob>()),
    ];
    for (name, bytes) in sizes {
        hprintln!("= {}: {} bytes", name, bytes);
    }
}

/// Control-period stack of each machine: one supervisor step per command and mode, from
/// Idle through calibration, a job and its stop, measured by painting. Printed as list
/// lines for the Stack section of BENCHMARKS.md.
#[inline(never)]
fn machine_stacks() {
    joints_stack();
    delta_stack();
}

/// The session's coefficients: the slave law at 10 kHz.
fn session_law() -> AxisLaw<f32> {
    match AxisLaw::<f32>::new(&AxisConfig::LM1247_SLAVE, 1e-4) {
        Ok(law) => law,
        Err(_) => exit(false),
    }
}

/// A nominal (uncalibrated) Hall axis for the session's `FinishCalibration`.
fn session_axis() -> HallAxis<f32> {
    match HallAxis::<f32>::new(&HallConfig::LM1247_16BIT) {
        Ok(axis) => axis,
        Err(_) => exit(false),
    }
}

#[inline(never)]
fn joints_stack() {
    let Ok(joints) = Joints::<f32, 1>::new(&JointsConfig::LM1247) else {
        exit(false)
    };
    let mut joint_job = JointJob::<1>::new();
    let segment = Segment {
        target_m: [0.01],
        duration_s: 0.5,
    };
    if joint_job.push(segment).is_err() {
        exit(false)
    }
    let counts = hall_inputs()[0];
    let session = (session_law(), joint_job);
    machine_stack(
        "Joints<f32, 1>",
        joints,
        [counts],
        [session_axis()],
        session,
    );
}

#[inline(never)]
fn delta_stack() {
    let delta_config = DeltaSlaveConfig::KEOPS;
    let Ok(delta) = DeltaSlave::<f32>::new(&delta_config) else {
        exit(false)
    };
    let move_ = Segment {
        target_m: [0.0, 0.005, 0.05],
        duration_s: 0.5,
    };
    let delta_job = match DeltaJob::plan(&delta_config, [0.0, 0.0, 0.05], 0.5, &[move_]) {
        Ok(job) => job,
        Err(e) => {
            hprintln!("delta job rejected: {:?}", e);
            exit(false)
        }
    };
    let counts = hall_inputs()[0];
    let axis = session_axis();
    let session = (session_law(), delta_job);
    machine_stack("DeltaSlave<f32>", delta, [counts; 3], [axis; 3], session);
}

/// Stack of the slower context's calibration fit (`HallMachine::fit`: the harmonic
/// fit of every axis and its decoders) on the samples of two simulated coasts per axis
/// over the worst sensors of the model, 16 bits.
#[inline(never)]
fn fit_stack<M: HallMachine<N>, const N: usize>(name: &str) {
    let config = HallConfig::LM1247_16BIT;
    let mut samples = CalibrationFit::<N>::default();
    let mut sensor = HallSensor::new(HallSensorParams::lm1247_worst(16, 4.0), 5);
    let pitch_m = config.pitch_m;
    for axis in 0..N as u8 {
        for (start_m, direction) in [(0.0, 1.0), (COAST_PITCHES * pitch_m, -1.0)] {
            let sample = |counts| HallSample { axis, counts };
            let mut ok = samples.push(sample(SEGMENT_BREAK)).is_ok();
            for x in calibration_coast_m(start_m, direction, pitch_m, SAMPLES_PER_COAST) {
                ok &= samples.push(sample(sensor.sample(x))).is_ok();
            }
            if !ok {
                exit(false)
            }
        }
    }
    let hall = [config; N];
    let mut fitted = false;
    let mut fit = || fitted = M::fit(black_box(&hall), black_box(&samples)).is_ok();
    let used = stack_of(&mut fit);
    if !fitted {
        hprintln!("{}: the fit failed", name);
        exit(false)
    }
    let Some(used) = used else {
        hprintln!(
            "{}: the fit went deeper than the {} bytes painted",
            name,
            STACK_PAINT
        );
        exit(false)
    };
    hprintln!(
        "- {} calibration fit (slower context): {} bytes",
        name,
        used
    );
}

/// The control interrupt's stack budget, bytes: the supervisor's period plus the
/// 104-byte exception frame with FPU context must fit; the bench fails otherwise.
const CONTROL_STACK_BUDGET: usize = 2048;
/// Exception entry with FPU context: 8 core and 18 FPU words.
const EXCEPTION_FRAME: usize = 104;

/// Peak stack of one supervisor step after each command of a whole session (each
/// machine's coefficients and job in `session`); fails the run above the budget.
#[inline(never)]
fn machine_stack<M: Machine>(
    name: &str,
    machine: M,
    inputs: M::Inputs,
    calibration: M::Calibration,
    session: (M::Coefficients, M::Job),
) {
    let (coefficients, job) = session;
    let jobs = JobSlots::new(job, M::Job::default());
    // One command in flight per phase (capacity 1).
    let mut commands = Queue::<Command<M>, 2>::new();
    let mut reports = Queue::<Report<M>, 16>::new();
    let (mut send, command_out) = commands.split();
    let (report_in, mut receive) = reports.split();
    let mut supervisor = Supervisor::new(machine, command_out, report_in, &jobs);
    let mut calibration = Some(calibration);
    let mut coefficients = Some(coefficients);
    let mut deepest = 0;
    for phase in 0..10 {
        let command = match phase {
            0 => Some(Command::Calibrate),
            2 => calibration.take().map(Command::FinishCalibration),
            3 => Some(Command::LoadJob(JobSlot::First)),
            4 => Some(Command::Start),
            5 => coefficients.take().map(Command::ChangeSettings),
            7 => Some(Command::Stop),
            9 => Some(Command::ResetFault),
            _ => None,
        };
        if let Some(command) = command {
            if send.enqueue(command).is_err() {
                exit(false)
            }
        }
        let mut period = || {
            black_box(supervisor.step(black_box(&inputs)));
        };
        deepest = deepest.max(stack_of(&mut period).unwrap_or(usize::MAX));
        while receive.dequeue().is_some() {}
    }
    hprintln!(
        "- {} control period, deepest over a session: {} bytes",
        name,
        deepest
    );
    if deepest.saturating_add(EXCEPTION_FRAME) > CONTROL_STACK_BUDGET {
        hprintln!("{}: the control period is over its stack budget", name);
        exit(false)
    }
}

/// Stack painted below a measured call, bytes (the calibration fit of three axes takes
/// about 50 KB; the image's RAM is the G474's 128 KB).
const STACK_PAINT: usize = 72 * 1024;

/// Peak stack of one call of `body`, bytes, measured by painting; `None` if it used the
/// whole painted stretch.
fn stack_of(body: &mut dyn FnMut()) -> Option<usize> {
    // Through an opaque trait object, so that none of `body` is inlined into this frame
    // (which exists before the painting and would not be counted).
    let body: &mut dyn FnMut() = black_box(body);
    let painted = Painted::below_sp(STACK_PAINT);
    body();
    painted.used()
}

/// Hall counts of the nominal 16-bit sensor at carriage position `q_m`.
fn nominal_counts(q_m: f32) -> [u16; 3] {
    counts_at_phase(2.0 * PI * q_m / HallConfig::LM1247_16BIT.pitch_m as f32)
}

/// Periods of a contour measured one by one for the slave-period rows.
const SLAVE_PERIODS: usize = 256;

/// Mean instructions of one supervisor period of the slave cutting the ±6 mm octagon
/// (n harmonics) under `law`, each period measured alone; the carriages follow their
/// references exactly (nominal sensors fed the last period's joint references), so
/// every measured period runs the whole law.
#[inline(never)]
fn slave_period(
    counter: &mut Counter,
    key: &str,
    harmonics: usize,
    law: ContourLaw,
    mut stages: Option<&mut stages::Stages>,
) -> f64 {
    let config = DeltaSlaveConfig::KEOPS;
    let (Ok(machine), Ok(job), Ok(sensor)) = (
        DeltaSlave::<f32>::new(&config),
        octagon_job(&config, 1.0, harmonics, law),
        HallAxis::<f32>::new(&HallConfig::LM1247_16BIT),
    ) else {
        exit(false)
    };
    let (Ok(geometry), Ok(contouring), Ok(law32)) = (
        DeltaGeometry::<f32>::new(&config.delta),
        Contouring::<f32>::new(&config.contour.contouring),
        AxisLaw::<f32>::new(&config.joints.axis, config.joints.period_s),
    ) else {
        exit(false)
    };
    let jobs = JobSlots::new(job, DeltaJob::default());
    let mut commands = Queue::<Command<DeltaSlave<f32>>, 2>::new();
    let mut reports = Queue::<Report<DeltaSlave<f32>>, 16>::new();
    let (mut send, command_out) = commands.split();
    let (report_in, mut receive) = reports.split();
    let mut supervisor = Supervisor::new(machine, command_out, report_in, &jobs);
    let mut inputs = config.joints.home_m.map(|q| nominal_counts(q as f32));
    let commands = [
        Command::FinishCalibration([sensor; 3]),
        Command::LoadJob(JobSlot::First),
        Command::Start,
    ];
    // The stack of a contour session (n = 30, contouring law; not in the traced run):
    // the periods that take the commands (the job's load checks it where it was built)
    // and a contour period at cruise.
    let session_stack = harmonics == 30 && law == ContourLaw::Contouring && !counter.is_traced();
    let mut deepest = 0;
    for command in commands {
        if send.enqueue(command).is_err() {
            exit(false)
        }
        let mut step = || {
            black_box(supervisor.step(black_box(&inputs)));
        };
        if session_stack {
            let used = stack_of(&mut step).unwrap_or(usize::MAX);
            deepest = deepest.max(used);
        } else {
            step();
        }
        while receive.dequeue().is_some() {}
    }
    let mut total = 0.0;
    let mut measured = 0;
    // The approach (3 000 periods), the start ramp, then cruise.
    for period in 0..(4_000 + SLAVE_PERIODS) {
        let axes = *supervisor.machine().joints().axes();
        let mut step = || {
            black_box(supervisor.step(black_box(&inputs)));
        };
        if period >= 4_000 {
            total += counter.once(key, &mut step);
            measured += 1;
        } else {
            step();
        }
        if let (Some(stages), Some(effector)) = (
            stages.as_deref_mut(),
            supervisor.machine().telemetry().effector_reference_m,
        ) {
            if period >= 4_000 - 3 {
                stages.measure(
                    counter,
                    &law32,
                    &sensor,
                    &geometry,
                    &contouring,
                    &inputs,
                    &axes,
                    effector,
                    config.joints.period_s as f32,
                );
            }
        }
        while receive.dequeue().is_some() {}
        let reference = supervisor.machine().joints().reference();
        inputs = core::array::from_fn(|k| nominal_counts(reference[k].position));
        if supervisor.machine().telemetry().contour.is_none() && period >= 4_000 {
            hprintln!(
                "slave period: not in the contour at period {} ({:?})",
                period,
                supervisor.mode()
            );
            exit(false)
        }
    }
    if session_stack {
        let mut step = || {
            black_box(supervisor.step(black_box(&inputs)));
        };
        let used = stack_of(&mut step).unwrap_or(usize::MAX);
        deepest = deepest.max(used);
        hprintln!(
            "- DeltaSlave<f32> contour session (EFD n=30, contouring law: load, start, a period at cruise), deepest period: {} bytes",
            deepest
        );
        if deepest.saturating_add(EXCEPTION_FRAME) > CONTROL_STACK_BUDGET {
            hprintln!("DeltaSlave<f32> contour session: over the control period's stack budget");
            exit(false)
        }
    }
    total / f64::from(measured)
}

/// The full slave period (three Hall decodes, the reference, kinematics, the law, three
/// DOBs, supervision) with the contouring law, beside the baseline joint PD's period.
#[inline(never)]
fn slave_period_rows(counter: &mut Counter) {
    for harmonics in [10, 30] {
        let mut name = heapless::String::<96>::new();
        let _ = core::fmt::write(
            &mut name,
            format_args!(
                "machines::delta_slave contour period <f32>, EFD n={harmonics}, contouring law"
            ),
        );
        let mut reference = name.clone();
        let _ = reference.push_str(" :: reference");
        if counter.is_traced() && harmonics != 10 {
            // Each row needs its own 4 000-period approach; the traced run (about ten
            // times slower per instruction) estimates the cycles of the n = 10 rows only.
            hprintln!("@ skip 0 {}", name);
            hprintln!("@ skip 0 {}", reference);
            continue;
        }
        let mut stages = stages::Stages::default();
        let contouring = slave_period(
            counter,
            &name,
            harmonics,
            ContourLaw::Contouring,
            (harmonics == 10).then_some(&mut stages),
        );
        let joint = slave_period(counter, &reference, harmonics, ContourLaw::Joint, None);
        hprintln!(
            "| {} | {:.0} | same period, independent joint PD law | {:.0} | — | — |",
            name,
            contouring,
            joint
        );
        if stages.periods > 0 {
            let periods = f64::from(stages.periods);
            for (stage, total) in stages::STAGES.iter().zip(stages.totals) {
                hprintln!(
                    "| {} | {:.0} | — | — | — | — |",
                    stages::key(stage),
                    total / periods
                );
            }
        }
    }
}
