//! ARROW's CiA 402 master (`kerf::app::drive_set`, `machines::arrow::drives`)
//! bringing up six simulated drives (`hal_mock::cia402`) on three buses, and its
//! refusals: a drive that aborts the write of mode 10, one that never boots, one in
//! Fault at start.

use hal_mock::arrow::ArrowPlant;
use hal_mock::cia402::Injection;
use kerf::app::drive_set::{BringUpStep, DriveFault, Phase};
use kerf::codec::canopen::{Od, SdoAbort};
use kerf::codec::cia402::{DriveState, MODE_CST};
use kerf::kinematics::arrow::Pose;
use kerf::machines::arrow::drives::ARROW_DRIVES;
use kerf_sim::arrow::ArrowScenario;
use kerf_sim::arrow_drives::DriveIo;

fn plant(scenario: &ArrowScenario) -> ArrowPlant<f64> {
    ArrowPlant::new(&scenario.plant, Pose::new(0.0, 0.5, 0.0, 0.0), 0.0).unwrap()
}

/// Brings up ARROW's drives with `injection` on drive `i`; the IO afterwards.
fn bring_up(
    injection: Option<(usize, Injection)>,
    check: impl FnOnce(Result<u32, DriveFault>, &mut DriveIo<'_>),
) {
    let scenario = ArrowScenario::published();
    let mut none = |_: u64, _: &mut hal_mock::cia402::SimDriveSet<6>| {};
    let mut io = DriveIo::new(&scenario, plant(&scenario), &mut none).unwrap();
    if let Some((i, injection)) = injection {
        io.drives.inject(i, injection);
    }
    let result = io.bring_up(20_000);
    check(result, &mut io);
}

#[test]
fn six_drives_reach_operation_enabled() {
    bring_up(None, |result, io| {
        let periods = result.unwrap();
        println!(
            "bring-up of 6 drives on 3 buses: {periods} periods ({:.1} ms), {} frames from the master",
            f64::from(periods) * 0.2,
            io.frames_sent
        );
        // Reset, boot-up heard, five SDO exchanges of a period each, NMT start, and
        // the walk: each controlword acts at the SYNC after its RPDO and its
        // statusword is read in the period after that.
        assert!(periods < 30, "{periods}");
        assert_eq!(io.master.phase(), Phase::Operational);
        for i in 0..6 {
            assert_eq!(
                io.drives.state(i),
                Some(DriveState::OperationEnabled),
                "{i}"
            );
            let mode = io.drives.read(i, Od::at(0x6061));
            assert!(
                matches!(mode, Some(kerf::codec::canopen::SdoResponse::Uploaded { value, .. }) if value as i8 == MODE_CST)
            );
            // Max torque 0x6072 = 2,500 N over the 1,250 N rated force.
            let max = io.drives.read(i, Od::at(0x6072));
            assert!(
                matches!(
                    max,
                    Some(kerf::codec::canopen::SdoResponse::Uploaded { value: 2000, .. })
                ),
                "{max:?}"
            );
        }
        assert_eq!(io.drives.dropped, 0);
        // Never more than the two a bus the period's timing counts (SYNC + RPDO, or
        // one bring-up frame a drive), within the FDCAN's three transmit buffers.
        assert_eq!(io.most_frames_per_bus, 2);
    });
}

#[test]
fn a_drive_that_refuses_cst_stops_bring_up_with_its_abort() {
    bring_up(Some((3, Injection::RefuseCst)), |result, io| {
        let fault = result.unwrap_err();
        assert_eq!(
            fault,
            DriveFault::SdoAbort {
                drive: 3,
                od: Od::at(0x6060),
                code: SdoAbort(0x0609_0030)
            }
        );
        println!("{fault}");
        assert_eq!(
            format!("{fault}"),
            "drive 3 aborted SDO 0x6060.00: 0x06090030 invalid value for parameter (value range exceeded)"
        );
        // No drive was enabled.
        assert!((0..6).all(|i| io.drives.state(i) != Some(DriveState::OperationEnabled)));
        assert_eq!(io.drives.forces_n(), [0.0; 6]);
    });
}

#[test]
fn a_drive_that_never_boots_times_out_by_name() {
    bring_up(Some((5, Injection::NeverBoots)), |result, io| {
        assert_eq!(
            result,
            Err(DriveFault::BringUpTimeout {
                drive: 5,
                step: BringUpStep::BootUp
            })
        );
        // After the boot-up timeout of 1 s, not before.
        assert!(io.frames_sent > 0);
        println!("{}", result.unwrap_err());
    });
    // The timeout is counted: one period fewer would still be waiting.
    let scenario = ArrowScenario::published();
    let mut none = |_: u64, _: &mut hal_mock::cia402::SimDriveSet<6>| {};
    let mut io = DriveIo::new(&scenario, plant(&scenario), &mut none).unwrap();
    io.drives.inject(5, Injection::NeverBoots);
    assert_eq!(
        io.bring_up(ARROW_DRIVES.boot_timeout_periods + 1),
        Err(DriveFault::Stopped),
        "still waiting"
    );
    assert_eq!(io.master.phase(), Phase::BringingUp(BringUpStep::BootUp));
    assert!(matches!(
        io.bring_up(1),
        Err(DriveFault::BringUpTimeout { drive: 5, .. })
    ));
}

#[test]
fn a_drive_in_fault_at_start_is_reset_once() {
    bring_up(Some((1, Injection::StartInFault)), |result, io| {
        assert!(result.is_ok(), "{result:?}");
        assert_eq!(io.drives.state(1), Some(DriveState::OperationEnabled));
    });
    // An encoder fault persists through the reset: drive 2 stays in Fault, named
    // with its EMCY.
    bring_up(Some((2, Injection::EncoderFault)), |result, _| {
        let fault = result.unwrap_err();
        assert!(
            matches!(fault, DriveFault::InFault { drive: 2, emcy: Some(e) } if e.code == 0x7305),
            "{fault:?}"
        );
        assert_eq!(
            format!("{fault}"),
            "drive 2 in Fault: EMCY 0x7305 incremental sensor 1 fault (error register 0x01)"
        );
    });
}

/// A drive whose safety circuit takes its torque off (EMCY 0x5441, back to Switch
/// on disabled) has left Operation enabled: the master names it with its state in
/// the period its TPDO shows it and sends Quick stop with zero torque to all.
#[test]
fn a_drive_that_leaves_operation_is_named() {
    use kerf::machines::arrow::machine::ArrowOutputs;
    use kerf_sim::arrow::ArrowIo;
    bring_up(None, |result, io| {
        result.unwrap();
        let zero = ArrowOutputs {
            forces_n: kerf::kinematics::arrow::ActuatorVector::zeros(),
            torques_n_m: [0.0; 2],
        };
        for k in 0..3 {
            let inputs = io.read(k).unwrap();
            assert_eq!(inputs.drive_fault, None, "{k}");
            io.step(&zero).unwrap();
        }
        io.drives.inject(0, Injection::SafeTorqueOff);
        let inputs = io.read(3).unwrap();
        let fault = inputs.drive_fault.unwrap();
        assert!(
            matches!(fault, DriveFault::LeftOperation { drive: 0, statusword } if statusword & 0x4F == 0x40),
            "{fault:?}"
        );
        assert_eq!(
            format!("{fault}"),
            "drive 0 left Operation enabled: Switch on disabled (statusword 0x0240)"
        );
        for i in 0..6 {
            let c = io.master.drive_command(i).unwrap();
            assert_eq!((c.controlword, c.target_torque), (0x0002, 0));
        }
    });
}
