//! Panic-free, proven at link time.
//!
//! This image calls every control-period entry point of kerf — each machine's
//! per-period methods and its supervisor step (the joints, the delta slave, ARROW, the
//! remote master, the remote slave and the grinding cell), the axis law, Hall decoding,
//! velocity observation, image sharpness and the autofocus law, delta kinematics,
//! ARROW's machine and its CiA 402 drive master, the contour and joint references, the DCT/SDCT codec and the packet
//! format with its stream ends — and the constructors and planners that feed them, on
//! inputs the optimiser cannot see through (`core::hint::black_box`).
//! Its panic handler calls a symbol that no object defines, so the image links only if
//! the optimised, LTO-linked code contains no path to a panic: a bounds check, an
//! `unwrap`, an arithmetic overflow check or a `panic!` that survives optimisation
//! anywhere below these calls is a link error naming `kerf_panic_is_reachable`. It is
//! built in the `panic-check` profile, which turns overflow checks on in kerf's own
//! code: an add, multiply, shift or negation that may wrap without saying so (by
//! `wrapping_*`, `saturating_*` or `checked_*`) fails the link too.
//!
//! It is linked for the board (thumbv7em-none-eabihf, `memory.x`) by `scripts/test`
//! and never run. To find the call that still panics, build it with
//! `KERF_PANIC_CHECK_FIND=1 scripts/panic-check`, which defines the symbol and
//! disassembles the callers. The decoders of outside data and the calibration fit are
//! in the sibling image `panic-check-decoders` (`src/decoders.rs`).
#![no_std]
#![no_main]

mod common;

use common::{opaque, sink, OpaqueLink};
use cortex_m_rt::entry;
use heapless::spsc::Queue;
use kerf::app::axis::{AxisConfig, AxisLaw, AxisState, HallAxis};
use kerf::app::drive_set::DriveFault;
use kerf::app::jobs::{JobSlot, JobSlots};
use kerf::app::joints::{JointJob, Joints, JointsConfig, Segment};
use kerf::app::remote_link::RemoteCommand;
use kerf::app::remote_link::SlaveReport;
use kerf::app::stream::{SignalReceiver, SignalSender};
use kerf::app::supervisor::{Command, Machine, Report, Supervisor};
use kerf::codec::canopen::CanFrame;
use kerf::codec::dct::Dct;
use kerf::codec::packet::{self, PacketDecoder, MAX_PACKET_LEN};
use kerf::codec::sdct::{SdctConfig, SdctDecoder, SdctEncoder, Selection};
use kerf::control::autofocus::{Autofocus, AutofocusConfig, AutofocusState};
use kerf::control::bilateral::BilateralConfig;
use kerf::control::constraint::FixtureConfig;
use kerf::control::dob::DobConfig;
use kerf::control::dob::{Dob, DobState};
use kerf::control::pd::Pd;
use kerf::control::preview::PreviewConfig;
use kerf::control::redundant_pid::{RedundantPid, RedundantPidConfig};
use kerf::kinematics::arrow::{
    ActuatorVector, ArrowConfig, ArrowDynamics, ArrowGeometry, ArrowMasses,
};
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry};
use kerf::kinematics::Vector3;
use kerf::machines::arrow::drives::{ArrowDrives, ARROW_DRIVES};
use kerf::machines::arrow::job::ArrowJob;
use kerf::machines::arrow::machine::{ArrowInputs, ArrowLimits, ArrowMachine};
use kerf::machines::arrow::ArrowLaw;
use kerf::machines::delta_slave::remote::session::{SessionJob, SessionSlave};
use kerf::machines::delta_slave::remote::{
    FollowJob, RemoteSlave, RemoteSlaveConfig, RemoteSlaveInputs,
};
use kerf::machines::delta_slave::{DeltaJob, DeltaSlave, DeltaSlaveConfig};
use kerf::machines::grinding::{GrindingCalibration, GrindingCell, GrindingConfig, GrindingInputs};
use kerf::machines::remote_master::{
    FixtureJob, RemoteMaster, RemoteMasterConfig, RemoteMasterInputs, SlaveEstimate,
};
use kerf::sensing::encoder::EncoderConfig;
use kerf::sensing::force::Eccentricity;
use kerf::sensing::hall::{HallConfig, HallDecoder, HallState};
use kerf::sensing::sharpness::{normalized_variance, window_moments, Window};
use kerf::sensing::velocity::{TrackingObserver, TrackingObserverConfig, TrackingObserverState};
use kerf::trajectory::constraint::{ConstraintConfig, MotionConstraint};
use kerf::trajectory::efd::Efd;
use kerf::trajectory::resample::ArcResampler;
use kerf::trajectory::spline::{JointSpline, KnotTiming};
use kerf::trajectory::tangential::{ContourFollower, FollowerConfig, SpeedRamp, SpeedRampConfig};
use kerf::trajectory::Reference;
use kerf::{Real, Q31_32, Q6_25};

#[entry]
fn main() -> ! {
    loop {
        match opaque(0u8) {
            0 => joints_machine(),
            1 => delta_machine(),
            2 => axis_law::<f32>(),
            3 => axis_law::<Q31_32>(),
            4 => axis_law::<Q6_25>(),
            5 => hall_and_observer(),
            6 => kinematics(),
            7 => contours(),
            8 => codec::<32>(),
            9 => codec::<64>(),
            10 => arrow_machine(),
            11 => autofocus(),
            12 => remote_master(),
            13 => remote_slave(),
            14 => grinding_cell(),
            15 => session_slave(),
            16 => drive_set(),
            _ => stream(),
        }
    }
}

/// Every per-period method of a machine, and a supervisor stepping it with a command.
fn periods<M: Machine>(machine: M, inputs: M::Inputs, job: M::Job, calibration: M::Calibration)
where
    M::Job: Clone,
    M::Coefficients: Clone,
    M::Calibration: Clone,
{
    let mut machine = opaque(machine);
    let inputs = opaque(inputs);
    match opaque(0u8) {
        0 => sink(machine.monitor(&inputs)),
        1 => machine.begin_calibration(),
        2 => sink(machine.calibrate(&inputs, &mut |sample| sink(sample))),
        3 => machine.finish_calibration(&opaque(calibration.clone())),
        4 => sink(machine.check_job(&opaque(job.clone()))),
        5 => sink(machine.begin_job(&opaque(job.clone()))),
        6 => sink(machine.run(&opaque(job.clone()), &inputs)),
        7 => machine.begin_stop(),
        8 => sink(machine.stop(&opaque(job.clone()), &inputs)),
        9 => machine.reset(),
        10 => sink(machine.safe_outputs()),
        _ => sink(machine.telemetry()),
    }
    let jobs = JobSlots::new(opaque(job), M::Job::default());
    let mut commands = Queue::<Command<M>, 4>::new();
    let mut reports = Queue::<Report<M>, 8>::new();
    let (mut command_in, command_out) = commands.split();
    let (report_in, mut report_out) = reports.split();
    let command = match opaque(0u8) {
        0 => Command::Calibrate,
        1 => Command::FinishCalibration(opaque(calibration)),
        2 => Command::LoadJob(opaque(JobSlot::First)),
        3 => Command::Start,
        4 => Command::Stop,
        _ => Command::ResetFault,
    };
    sink(command_in.enqueue(command).is_ok());
    let mut supervisor = opaque(Supervisor::new(machine, command_out, report_in, &jobs));
    sink(supervisor.step(&inputs));
    sink(supervisor.mode());
    sink(report_out.dequeue());
}

fn joints_machine() {
    let config = opaque(JointsConfig::LM1247);
    let (Ok(machine), Ok(axis)) = (
        Joints::<f32, 1>::new(&config),
        HallAxis::<f32>::new(&opaque(HallConfig::LM1247_16BIT)),
    ) else {
        return;
    };
    let mut job = JointJob::<1>::new();
    sink(job.push(opaque(Segment {
        target_m: [0.01],
        duration_s: 0.5,
    })));
    if let Ok(law) = AxisLaw::<f32>::new(&config.axis, config.period_s) {
        let mut changed = opaque(machine.clone());
        changed.set_coefficients(&law);
        sink(changed);
    }
    periods(machine, [[0u16; 3]; 1], job, [axis]);
}

fn arrow_machine() {
    let model = opaque(ArrowConfig::ARROW);
    let masses = opaque(ArrowMasses::ARROW);
    let ts = opaque(2e-4);
    let (Ok(geometry), Ok(dynamics), Ok(parallel), Ok(turntable)) = (
        ArrowGeometry::<f32>::new(&model),
        ArrowDynamics::<f32>::new(&masses, model.arms[0].length_m, model.arms[2].length_m),
        RedundantPid::<f32>::new(&opaque(RedundantPidConfig::ARROW_PARALLEL), ts),
        RedundantPid::<f32>::new(&opaque(RedundantPidConfig::ARROW_TURNTABLE), ts),
    ) else {
        return;
    };
    let law = ArrowLaw {
        geometry,
        dynamics,
        parallel,
        turntable,
        feedforward: opaque(true),
    };
    let Ok(machine) = ArrowMachine::<f32, 16, 2>::new(law, ts, &opaque(ArrowLimits::ARROW)) else {
        return;
    };
    // The load-time loader (f64, the slower context) is not part of the period; the
    // machine's per-period methods see a job the optimiser cannot see through.
    let job = opaque(ArrowJob::<f32, 16, 2>::default());
    let inputs = ArrowInputs {
        joints_m: opaque(ActuatorVector::zeros()),
        table_rad: opaque([0.0; 2]),
        drive_fault: None,
    };
    periods(machine, inputs, job, ());
}

/// ARROW's CiA 402 master: bring-up and cyclic periods on frames the optimiser
/// cannot predict, with the frame codecs and the drive state decode under them.
fn drive_set() {
    let Ok(mut set) = ArrowDrives::<f32>::new(&opaque(ARROW_DRIVES)) else {
        return;
    };
    for _ in 0..opaque(4u32) {
        set.start_period(&mut |bus, frame| sink((bus, *frame)));
        let bus = opaque(0u8);
        let frame = opaque(CanFrame::default());
        set.receive(bus, &frame);
        sink(set.feedback());
        sink(set.command(&opaque([0.0f32; 6])));
        sink(set.fault().map(|f| f == DriveFault::Stopped));
    }
    set.stop();
    sink(set.phase());
}

/// The remote master on the horizontal master delta (the host's remote scenario's
/// settings), following a square fixture and answering the slave's reports.
fn remote_master() {
    let row = PreviewConfig {
        surface_slope_per_s: 125.0,
        reaching_rate_per_s: 250.0,
    };
    let config = opaque(RemoteMasterConfig {
        period_s: 1e-4,
        delta: DeltaConfig::MASTER_HORIZONTAL,
        encoders: [EncoderConfig::MASTER_0_5_UM; 3],
        home_m: [0.0; 3],
        velocity: TrackingObserverConfig {
            bandwidth_rad_s: 1885.0,
        },
        dob: DobConfig {
            nominal_mass_kg: 0.335,
            bandwidth_rad_s: 250.0,
            force_limit_n: 10.0,
            compensate: true,
        },
        fixture: FixtureConfig {
            normal: row,
            vertical: row,
        },
        constraint: ConstraintConfig::closed_contour(),
        tracking: BilateralConfig::critically_damped(0.5, [0.0; 3], [0.0; 3], 31.4),
        observer_bandwidth_rad_s: 62.8,
        slave_estimate: SlaveEstimate::EchoedTicks,
        samples_per_command: 10,
        haptic: None,
    });
    let Ok(machine) = RemoteMaster::<f32>::new(&config) else {
        return;
    };
    let square = opaque([[0.0, 0.0], [0.01, 0.0], [0.01, 0.01], [0.0, 0.01]]);
    let Ok(job) = FixtureJob::new(&square, &config.constraint, opaque(0.1), opaque(true)) else {
        return;
    };
    let inputs = RemoteMasterInputs {
        encoder_counts: opaque([0u16; 3]),
        report: opaque(Some(SlaveReport {
            echo_tick: Some(0),
            position_m: [0.0; 3],
            velocity_m_s: [0.0; 3],
        })),
    };
    periods(machine, inputs, job, ());
}

/// The remote slave following the master's commands.
fn remote_slave() {
    let config = opaque(RemoteSlaveConfig::KEOPS);
    let (Ok(machine), Ok(axis)) = (
        RemoteSlave::<f32>::new(&config),
        HallAxis::<f32>::new(&opaque(HallConfig::LM1247_16BIT)),
    ) else {
        return;
    };
    let inputs = RemoteSlaveInputs {
        hall: opaque([[0u16; 3]; 3]),
        command: opaque(Some(RemoteCommand::default())),
        fresh: opaque(true),
    };
    periods(
        machine,
        inputs,
        opaque(FollowJob::default()),
        [axis, axis, axis],
    );
}

/// The remote slave playing a recorded session (the host link's remote slave): its
/// session's frames fed to its own end of the link each period.
fn session_slave() {
    let config = opaque(RemoteSlaveConfig::KEOPS);
    let (Ok(machine), Ok(axis)) = (
        SessionSlave::<f32>::new(&config),
        HallAxis::<f32>::new(&opaque(HallConfig::LM1247_16BIT)),
    ) else {
        return;
    };
    periods(
        machine,
        opaque([[0u16; 3]; 3]),
        opaque(SessionJob::default()),
        [axis, axis, axis],
    );
}

/// The grinding cell's force laws on its force/torque sensor.
fn grinding_cell() {
    let Ok(machine) = GrindingCell::<f32>::new(&opaque(GrindingConfig::PUBLISHED)) else {
        return;
    };
    let inputs = GrindingInputs {
        ft_raw_v: opaque([0.0f32; 6]),
        device_fault: None,
    };
    let calibration = GrindingCalibration {
        eccentricity: opaque(Eccentricity {
            dx_m: 0.0,
            dy_m: 0.0,
        }),
    };
    periods(machine, inputs, opaque(Default::default()), calibration);
}

fn delta_machine() {
    let config = opaque(DeltaSlaveConfig::KEOPS);
    let (Ok(machine), Ok(axis)) = (
        DeltaSlave::<f32>::new(&config),
        HallAxis::<f32>::new(&opaque(HallConfig::LM1247_16BIT)),
    ) else {
        return;
    };
    let moves = [opaque(Segment {
        target_m: [0.0, 0.005, 0.05],
        duration_s: 0.5,
    })];
    let Ok(job) = DeltaJob::plan(&config, opaque([0.0; 3]), opaque(0.5), &moves) else {
        return;
    };
    periods(machine, [[0u16; 3]; 3], job, [axis, axis, axis]);
}

fn axis_law<T: Real>() {
    let config = opaque(AxisConfig::LM1247_SLAVE);
    let (Ok(law), Ok(sensor)) = (
        AxisLaw::<T>::new(&config, opaque(1e-4)),
        HallAxis::<T>::new(&opaque(HallConfig::LM1247_16BIT)),
    ) else {
        return;
    };
    let mut state = opaque(AxisState::homed_at(T::from_f64(opaque(0.004))));
    let reference = opaque(Reference {
        position: T::from_f64(opaque(0.005)),
        velocity: T::from_f64(opaque(0.1)),
        acceleration: T::from_f64(opaque(1.0)),
    });
    sink(law.step(&sensor, &mut state, opaque([0u16; 3]), &reference));
    sink(state.position_m());
    // The laws on their own (the fixed-point constructors included).
    if let (Ok(pd), Ok(dob)) = (
        Pd::<T>::new(&config.pd),
        Dob::<T>::new(&config.dob, opaque(1e-4)),
    ) {
        let mut dob_state = opaque(DobState::at(T::from_f64(opaque(0.0))));
        let a = pd.acceleration(
            &reference,
            opaque(reference.position),
            opaque(reference.velocity),
        );
        sink(dob.update(&mut dob_state, a, opaque(reference.velocity)));
    }
}

fn hall_and_observer() {
    let Ok(decoder) = HallDecoder::new(&opaque(HallConfig::LM1247_16BIT)) else {
        return;
    };
    let mut state = opaque(HallState::default());
    sink(decoder.update(&mut state, opaque([0u16; 3]), opaque(0i64)));
    let Ok(observer) = TrackingObserver::<f32>::new(
        &opaque(TrackingObserverConfig {
            bandwidth_rad_s: 2000.0,
        }),
        opaque(1e-4),
    ) else {
        return;
    };
    let mut observed = opaque(TrackingObserverState::at_rest(opaque(0.0f32)));
    sink(observer.predicted_step(&observed, opaque(0.0)));
    sink(observer.update(&mut observed, opaque(0.001), opaque(0.0)));
}

/// The sharpness of a frame window and the autofocus law's frame and period.
fn autofocus() {
    let frame: &[u8] = opaque(&[0u8; 64 * 64][..]);
    let window = opaque(Window {
        x_px: 0,
        y_px: 0,
        width_px: 64,
        height_px: 64,
    });
    let sharpness = normalized_variance(frame, opaque(64), &window);
    sink(window_moments(frame, opaque(64), &window).map(|m| m.normalized_variance_f64()));
    let config = opaque(AutofocusConfig::FOCUS_10MM_100FPS);
    let Ok(law) = Autofocus::<f32, 32>::new(&config, opaque(1e-3)) else {
        return;
    };
    let mut state = opaque(AutofocusState::<f32, 32>::default());
    sink(law.frame(&mut state, opaque(1e-3), sharpness.unwrap_or(0.0)));
    sink(law.step(&mut state, opaque(1e-3), opaque(0.0)));
    sink(law.gradient(&state));
}

fn kinematics() {
    let Ok(geometry) = DeltaGeometry::<f32>::new(&opaque(DeltaConfig::SLAVE_KEOPS)) else {
        return;
    };
    let q = opaque(Vector3::new(0.02f32, 0.02, 0.02));
    let p = opaque(Vector3::new(0.0f32, 0.0, -0.2));
    let q_dot = opaque(Vector3::new(0.01f32, -0.02, 0.0));
    sink(geometry.forward(&q));
    sink(geometry.inverse(&p));
    sink(geometry.jacobian(&q, &p));
    sink(geometry.jacobian_inverse(&q, &p));
    sink(geometry.jacobian_derivative(&q, &p, &q_dot));
}

fn contours() {
    let polygon = opaque([[0.0, 0.0], [0.01, 0.0], [0.01, 0.01], [0.0, 0.01]]);
    if let Ok(efd) = Efd::<f32, 10>::from_polygon(&polygon, opaque(10)) {
        sink(efd.evaluate(opaque(0.3)));
        let config = opaque(FollowerConfig {
            ramp: SpeedRampConfig {
                speed_m_s: 0.01,
                accel_m_s2: 0.1,
                jerk_m_s3: 10.0,
                ts_s: 1e-4,
            },
            accel_limit_m_s2: 1.0,
            newton_steps: 2,
        });
        if let Ok(follower) = ContourFollower::new(efd, &config, opaque(0.0)) {
            let mut follower = opaque(follower);
            follower.start();
            sink(follower.step());
        }
        if let Ok(ramp) = SpeedRamp::<f32>::new(&config.ramp) {
            let mut ramp = opaque(ramp);
            sink(ramp.step());
        }
    }
    if let Ok(constraint) =
        MotionConstraint::<f32, 8>::new(&polygon, &opaque(ConstraintConfig::closed_contour()))
    {
        sink(constraint.evaluate(opaque(Vector3::new(0.0, 0.0, 0.0)), opaque(0.0)));
    }
    let task = opaque([
        Vector3::new(0.0, 0.0, 0.05),
        Vector3::new(0.001, 0.0, 0.05),
        Vector3::new(0.002, 0.001, 0.05),
    ]);
    let timing = opaque(KnotTiming {
        period_s: 1e-4,
        periods_per_knot: 10,
        first_period: 0,
    });
    let zero = Vector3::zeros();
    if let Ok(spline) = JointSpline::<f32, 8>::fit(&task, timing, zero, zero, Ok::<_, ()>) {
        sink(spline.evaluate(opaque(0u64)));
        sink(spline.evaluate_at(opaque(0usize), opaque(0.0)));
    }
    let points = opaque([[0.0f32, 0.0], [0.01, 0.0], [0.01, 0.01]]);
    if let Ok(resampler) = ArcResampler::new(&points) {
        let mut resampler = opaque(resampler);
        sink(resampler.advance(opaque(0.001)));
    }
}

fn codec<const N: usize>() {
    let config = opaque(SdctConfig {
        m: 8,
        selection: Selection::Largest,
    });
    let (Ok(dct), Ok(encoder), Ok(decoder)) = (
        Dct::<N>::new(),
        SdctEncoder::<N>::new(&config),
        SdctDecoder::<N>::new(),
    ) else {
        return;
    };
    let mut x = opaque([0.0f32; N]);
    dct.forward(&mut x);
    dct.inverse(&mut x);
    let mut q = [0i32; N];
    dct.forward_q15(&opaque([0i16; N]), &mut q);
    let mut back = [0i16; N];
    dct.inverse_q15(&opaque(q), &mut back);
    sink(back);
    let mut bytes = [0u8; MAX_PACKET_LEN];
    if let Ok(block) = encoder.encode(&x) {
        decoder.decode(&block, &mut x);
        sink(packet::encode(&block, opaque(0), opaque(0), &mut bytes));
    }
    let bytes = opaque(bytes);
    let len = opaque(0usize);
    if let Some(frame) = bytes.get(..len) {
        sink(packet::parse(frame));
        let mut packets = opaque(PacketDecoder::new());
        if let Ok(received) = packets.decode(frame) {
            sink(received.packet.to_block::<N>());
        }
    }
    sink(x);
}

fn stream() {
    let config = opaque(SdctConfig {
        m: 8,
        selection: Selection::Largest,
    });
    if let Ok(sender) = SignalSender::<32>::new(&config) {
        let mut sender = opaque(sender);
        sink(sender.push(opaque(0.0), &mut OpaqueLink));
    }
    if let Ok(receiver) = SignalReceiver::<32>::new() {
        let mut receiver = opaque(receiver);
        let mut out = [0.0f32; 32];
        sink(receiver.poll(&mut OpaqueLink, &mut out));
        sink(out);
    }
}
