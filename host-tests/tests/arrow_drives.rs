//! ARROW's pyramid (A §5) with the six actuators behind CiA 402 drives: master →
//! three simulated CAN FD buses → simulated drives → plant, against the plant wired
//! directly; a drive's over-current and a silent drive stop the machine.

use hal_mock::arrow::ArrowReading;
use hal_mock::cia402::{Injection, SimDriveSet};
use kerf::app::drive_set::DriveFault;
use kerf::app::supervisor::Mode;
use kerf::codec::cia402::DriveState;
use kerf::kinematics::arrow::{ActuatorVector, ArrowConfig, ArrowError, ArrowGeometry, Pose};
use kerf::machines::arrow::drives::SILENT_PERIODS;
use kerf::machines::arrow::machine::{ArrowFault, ArrowInputs, ArrowOutputs};
use kerf::machines::arrow::product::Job;
use kerf_sim::arrow::{
    run_job, run_job_on, start_plant, ArrowIo, ArrowRunEnd, ArrowScenario, PlantIo, TrackingRms,
    TrackingSums, ARROW_SMOKE_BOUNDS, PYRAMID_GCODE,
};
use kerf_sim::arrow_drives::DriveIo;
use std::collections::VecDeque;

fn job() -> Box<Job<f64>> {
    host_tests::arrow::job_from_gcode(PYRAMID_GCODE).unwrap()
}

/// The plant wired directly, its actuator forces acting `delay` periods late.
struct Delayed {
    plant: PlantIo<'static, f64>,
    queue: VecDeque<ActuatorVector<f64>>,
}

impl ArrowIo<f64> for Delayed {
    fn read(&mut self, k: u64) -> Result<ArrowInputs<f64>, ArrowError> {
        self.plant.read(k)
    }
    fn step(&mut self, outputs: &ArrowOutputs<f64>) -> Result<ArrowReading<f64>, ArrowError> {
        self.queue.push_back(outputs.forces_n);
        let forces = self.queue.pop_front().unwrap_or_else(ActuatorVector::zeros);
        self.plant.step(&ArrowOutputs {
            forces_n: forces,
            torques_n_m: outputs.torques_n_m,
        })
    }
    fn pose(&self) -> Pose<f64> {
        self.plant.pose()
    }
}

fn direct(scenario: &ArrowScenario, delay: usize) -> (ArrowRunEnd<f64>, TrackingRms) {
    let job = job();
    let mut sums = TrackingSums::default();
    let end = if delay == 0 {
        run_job(scenario, &job, u64::MAX, &mut |_, _| {}, &mut |p| {
            sums.push(p)
        })
        .unwrap()
    } else {
        let disturb: &'static mut dyn FnMut(u64, &mut ArrowReading) =
            Box::leak(Box::new(|_, _| {}));
        let mut io = Delayed {
            plant: PlantIo {
                plant: start_plant(scenario, &job).unwrap(),
                disturb,
            },
            queue: VecDeque::from(vec![ActuatorVector::zeros(); delay]),
        };
        run_job_on(scenario, &job, u64::MAX, &mut io, &mut |p| sums.push(p)).unwrap()
    };
    (end, sums.rms())
}

/// The run through the drives; `inject(k, drives)` at each period's start.
fn on_drives(
    rpdo_before_sync: bool,
    max_periods: u64,
    inject: &mut dyn FnMut(u64, &mut SimDriveSet<6>),
    after: impl FnOnce(&mut DriveIo<'_>),
) -> (ArrowRunEnd<f64>, TrackingRms, u32) {
    let scenario = ArrowScenario::published();
    let job = job();
    let mut io = DriveIo::new(&scenario, start_plant(&scenario, &job).unwrap(), inject).unwrap();
    io.rpdo_before_sync = rpdo_before_sync;
    let bring_up = io.bring_up(10_000).unwrap();
    let mut sums = TrackingSums::default();
    let end = run_job_on(&scenario, &job, max_periods, &mut io, &mut |p| sums.push(p)).unwrap();
    after(&mut io);
    (end, sums.rms(), bring_up)
}

fn show(name: &str, r: &TrackingRms) {
    println!(
        "{name:44} eq. 55 {:.3} µm, eq. 56 {:.5}°, Rm q̃ {:.3} µm, eq. 58 {:.5}°, true pose {:.2} µm",
        r.cartesian_m * 1e6,
        r.cartesian_deg,
        r.joint_consistent_m * 1e6,
        r.joint_deg,
        r.true_cartesian_m * 1e6
    );
}

/// The RMS that a joint encoder's rounding to `increment_m` (uniform, q²/12 a
/// joint, independent between joints) adds to X̃ = Jm⁺ q̃ along the pyramid:
/// q/√12 · √(mean ‖rows‖²) of Jm⁺'s translation rows (eq. 55, m) and of its θz row
/// (eq. 56's share from the actuators, rad).
fn quantization_rms(increment_m: f64) -> (f64, f64) {
    let geometry = ArrowGeometry::<f64>::new(&ArrowConfig::ARROW).unwrap();
    let scenario = ArrowScenario::published();
    let (mut sum, mut rot, mut n) = (0.0, 0.0, 0.0);
    let mut k = 0u64;
    run_job(&scenario, &job(), u64::MAX, &mut |_, _| {}, &mut |p| {
        k += 1;
        if k % 50 == 0 {
            let (_, jm) = geometry.jacobian(&p.desired).unwrap();
            let pinv = ArrowGeometry::pseudo_inverse(&jm).unwrap();
            sum += pinv.fixed_rows::<3>(0).norm_squared();
            rot += pinv.row(3).norm_squared();
            n += 1.0;
        }
    })
    .unwrap();
    let q = increment_m / 12f64.sqrt();
    (q * (sum / n).sqrt(), q * (rot / n).sqrt())
}

/// The pyramid through the drives against the plant wired directly, its figures
/// taken apart: the encoders' increment (1 µm scales directly, the drives' 50 nm),
/// the bus's latency (the forces act two periods after their positions were
/// sampled: docs/drives.md), and the target torque's quantization (1 per mille =
/// 1.25 N).
#[test]
fn the_pyramid_through_the_drives() {
    let published = ArrowScenario::published();
    let mut fine = ArrowScenario::published();
    fine.plant.encoder_resolution_m = 50e-9;
    let ([a, f, d, b], [c, e]) = std::thread::scope(|s| {
        let a = s.spawn(|| direct(&published, 0));
        let f = s.spawn(|| direct(&fine, 0));
        let d = s.spawn(|| direct(&fine, 1));
        let b = s.spawn(|| direct(&fine, 2));
        let c = s.spawn(|| on_drives(false, u64::MAX, &mut |_, _| {}, |_| {}));
        let e = s.spawn(|| on_drives(true, u64::MAX, &mut |_, _| {}, |_| {}));
        (
            [a, f, d, b].map(|h| h.join().unwrap()),
            [c, e].map(|h| h.join().unwrap()),
        )
    });
    println!("bring-up {} periods", c.2);
    show("direct (1 µm encoders, no delay)", &a.1);
    show("direct, 50 nm, no delay", &f.1);
    show("direct, 50 nm, forces 1 period late", &d.1);
    show("direct, 50 nm, forces 2 periods late", &b.1);
    show("through the drives (RPDO after SYNC)", &c.1);
    show("through the drives (RPDO before SYNC)", &e.1);
    for end in [&a.0, &f.0, &d.0, &b.0, &c.0, &e.0] {
        assert_eq!(end.mode, Mode::Ready, "the job ran to its end");
        assert_eq!(end.periods, a.0.periods);
    }
    let gap = |x: &TrackingRms, y: &TrackingRms| {
        (
            (x.cartesian_m - y.cartesian_m).abs(),
            (x.cartesian_deg - y.cartesian_deg).abs(),
        )
    };
    // The torque's quantization alone (same latency, same encoders): at most 0.625 N
    // an actuator, which the loop's stiffness K_P = 5.9 MN/m (A table 2) turns
    // into 0.1 nm; what shows beyond it is the 50 nm readings that such a motion
    // flips: a 1 nm difference flips some 2 % of them (1 nm / 50 nm), each a 50 nm
    // change of one joint, 50 nm · √0.02 = 7 nm in the RMS at most. Bound: 10 nm,
    // and for eq. 56 the same 10 nm over the 0.1 m lever of the plate's θz
    // (1e-7 rad = 6e-6°).
    for ((_, drives, _), (_, direct), latency) in [(&c, &b, 2), (&e, &d, 1)] {
        let (m, deg) = gap(drives, direct);
        println!(
            "drives − direct, forces {latency} periods late: eq. 55 {:.2} nm, eq. 56 {:.2e}°",
            m * 1e9,
            deg
        );
        assert!(m < 10e-9 && deg < 6e-6, "{m} {deg}");
    }
    // Against today's direct run. Its 1 µm scales add their rounding to the figure:
    // independent of the motion, it adds σ² (below) to eq. 55's mean square, and
    // the loop, acting on it, moves the plate by at most as much again, which the
    // encoders see too: F²(1 µm) − F²(50 nm) lies in [σ² − σ²₅₀, 2 (σ² − σ²₅₀)]
    // (0.8 at the bottom for σ's estimate from every 50th pose).
    let (sigma, sigma_rot) = quantization_rms(1e-6);
    let (sigma_fine, sigma_rot_fine) = quantization_rms(50e-9);
    let added = sigma * sigma - sigma_fine * sigma_fine;
    let added_rot = sigma_rot * sigma_rot - sigma_rot_fine * sigma_rot_fine;
    let ratio = (a.1.cartesian_m.powi(2) - f.1.cartesian_m.powi(2)) / added;
    let (m, deg) = gap(&c.1, &a.1);
    let (late, late_deg) = gap(&b.1, &f.1);
    println!(
        "drives − direct (1 µm, no delay): eq. 55 {:.1} nm, eq. 56 {:.2e}°; rounding σ {:.1} nm (1 µm), {:.1} nm (50 nm), mean-square ratio {ratio:.2}; latency of 2 periods {:.1} nm, {:.2e}°",
        m * 1e9,
        deg,
        sigma * 1e9,
        sigma_fine * 1e9,
        late * 1e9,
        late_deg
    );
    assert!((0.8..=2.0).contains(&ratio), "{ratio}");
    // The latency is no quantization: it is held to 1 % of each figure, a
    // requirement on the bus layout rather than a derived bound.
    let (late_55, late_56) = (0.01 * f.1.cartesian_m, 0.01 * f.1.cartesian_deg);
    assert!(late < late_55 && late_deg < late_56, "{late} {late_deg}");
    // So the drive run lies within the encoders' share, the torque's 10 nm and the
    // latency's 1 % of the direct run.
    let encoders = (c.1.cartesian_m.powi(2) + 2.0 * added).sqrt() - c.1.cartesian_m;
    assert!(m < encoders + 10e-9 + late_55, "{m} {encoders}");
    // Eq. 56 the same way on Jm⁺'s θz row (θx is the table's, not on the bus).
    let f56 = c.1.cartesian_deg.to_radians();
    let rotation = ((f56 * f56 + 2.0 * added_rot).sqrt() - f56).to_degrees();
    println!("eq. 56 bound {rotation:.2e}°");
    assert!(deg < rotation + 6e-6 + late_56, "{deg} {rotation}");
    // Through the drives ARROW still meets A table 3's Cartesian figures.
    assert!(ARROW_SMOKE_BOUNDS.holds(&c.1), "{:?}", c.1);
    assert!(ARROW_SMOKE_BOUNDS.holds(&e.1), "{:?}", e.1);
}

/// A drive's over-current mid-run: EMCY 0x2310, the drive in Fault; the machine
/// stops in the same period with zero outputs and the fault in words, and the
/// master sends Quick stop with zero torque to every drive from then on.
#[test]
fn an_overcurrent_stops_arrow_with_outputs_safe() {
    const K: u64 = 3000;
    let mut inject = |k, drives: &mut SimDriveSet<6>| {
        if k == K {
            drives.inject(4, Injection::Overcurrent);
        }
    };
    let (end, _, _) = on_drives(false, 10_000, &mut inject, |io| {
        let fault = io.master.fault().unwrap();
        for i in 0..6 {
            let c = io.master.drive_command(i).unwrap();
            assert_eq!((c.controlword, c.target_torque), (0x0002, 0), "{i}");
        }
        // Two periods more: the quick stop acts at the SYNC after its RPDO; then
        // no drive applies a force.
        for k in 0..2 {
            io.read(K + 1 + k).unwrap();
            io.step(&ArrowOutputs {
                forces_n: ActuatorVector::zeros(),
                torques_n_m: [0.0; 2],
            })
            .unwrap();
        }
        assert_eq!(io.drives.forces_n(), [0.0; 6]);
        assert_eq!(io.drives.state(4), Some(DriveState::Fault));
        assert_eq!(io.drives.state(0), Some(DriveState::QuickStopActive));
        println!("{fault}");
    });
    let Mode::Fault(ArrowFault::Drive(fault)) = end.mode else {
        panic!("{:?}", end.mode);
    };
    assert_eq!(end.periods, K + 1, "stopped in the period the EMCY came");
    assert_eq!(
        format!("{fault}"),
        "drive 4 in Fault: EMCY 0x2310 continuous over-current (error register 0x03)"
    );
    assert_eq!(end.last_outputs.forces_n, ActuatorVector::zeros());
    assert_eq!(end.last_outputs.torques_n_m, [0.0; 2]);
}

/// A drive that falls silent (its bus cable cut) is named in the
/// [`SILENT_PERIODS`]-th period without its TPDO; its own watchdog takes its force
/// off three periods after its last SYNC.
#[test]
fn a_silent_drive_is_detected_within_the_stated_periods() {
    const K: u64 = 2000;
    let mut inject = |k, drives: &mut SimDriveSet<6>| {
        if k == K {
            drives.inject(2, Injection::Silent);
        }
    };
    let (end, _, _) = on_drives(false, 10_000, &mut inject, |io| {
        for k in 0..3 {
            io.read(K + 2 + k).unwrap();
            io.step(&ArrowOutputs {
                forces_n: ActuatorVector::zeros(),
                torques_n_m: [0.0; 2],
            })
            .unwrap();
        }
        assert_eq!(io.drives.state(2), Some(DriveState::Fault));
        assert_eq!(io.drives.forces_n(), [0.0; 6]);
    });
    assert_eq!(
        end.mode,
        Mode::Fault(ArrowFault::Drive(DriveFault::Silent {
            drive: 2,
            periods: SILENT_PERIODS
        }))
    );
    // Period K had no TPDO from it; period K + SILENT_PERIODS − 1 is the fault.
    assert_eq!(end.periods, K + u64::from(SILENT_PERIODS));
    assert_eq!(end.last_outputs.forces_n, ActuatorVector::zeros());
}
