//! The master's configuration checks, its conversions and its faults in words (its
//! behaviour against simulated drives is in host-tests' `drive_set` tests).

use super::*;
use std::format;

fn config() -> DriveSetConfig<4> {
    let a = |bus, node| DriveAddress { bus, node };
    DriveSetConfig {
        drives: [a(0, 1), a(0, 2), a(1, 3), a(2, 3)],
        increment_m: 50e-9,
        max_force_n: 2500.0,
        heartbeat_ms: 0,
        boot_timeout_periods: 10,
        sdo_timeout_periods: 10,
        enable_timeout_periods: 10,
        silent_periods: 2,
    }
}

#[test]
fn slots_and_rpdo_ids() {
    let set = DriveSet::<f64, 4>::new(&config()).unwrap();
    let slots: std::vec::Vec<u8> = set.drives.iter().map(|d| d.slot).collect();
    assert_eq!(slots, [0, 1, 0, 0]);
    assert_eq!(set.rpdo_id(0), Some(0x201));
    assert_eq!(set.rpdo_id(2), Some(0x203));
    assert_eq!(set.rpdo_id(3), None);
    assert_eq!(set.phase(), Phase::BringingUp(BringUpStep::BootUp));
}

#[test]
fn bad_configs_are_named() {
    let mut c = config();
    c.drives[2].bus = 0;
    let e = DriveSet::<f64, 4>::new(&c).unwrap_err();
    assert_eq!(format!("{e}"), "drives[2].bus: out of the supported range");
    let mut c = config();
    c.drives[1].node = 1;
    let e = DriveSet::<f64, 4>::new(&c).unwrap_err();
    assert_eq!(format!("{e}"), "drives[1].node: out of the supported range");
    let mut c = config();
    c.drives[3].node = 0;
    assert!(DriveSet::<f64, 4>::new(&c).is_err());
    let mut c = config();
    c.drives[3].bus = MAX_BUSES as u8;
    assert!(DriveSet::<f64, 4>::new(&c).is_err());
    let mut c = config();
    c.increment_m = f64::NAN;
    assert_eq!(
        DriveSet::<f64, 4>::new(&c).unwrap_err(),
        ConfigError::not_finite("increment_m")
    );
    let mut c = config();
    c.silent_periods = 0;
    assert_eq!(
        DriveSet::<f64, 4>::new(&c).unwrap_err(),
        ConfigError::not_positive("silent_periods")
    );
}

/// 1,250 N rated: 0.8 per mille per newton; 2,000 per mille is the 2,500 N limit.
#[test]
fn forces_to_per_mille() {
    let k = 1e6 / 1_250_000.0;
    assert_eq!(to_permille(100.0, k, 2000), (80, false));
    assert_eq!(to_permille(-100.6, k, 2000), (-80, false));
    assert_eq!(to_permille(100.7, k, 2000), (81, false));
    assert_eq!(to_permille(2500.0, k, 2000), (2000, false));
    assert_eq!(to_permille(2501.0, k, 2000), (2000, true));
    assert_eq!(to_permille(-1e9, k, 2000), (-2000, true));
    assert_eq!(to_permille(f64::NAN, k, 2000), (0, false));
    assert_eq!(to_permille(f64::INFINITY, k, 2000), (0, true));
    assert_eq!(to_permille(1e12, 1.0, u16::MAX), (i16::MAX, true));
}

#[test]
fn faults_in_words() {
    let cases = [
        (
            DriveFault::InFault {
                drive: 3,
                emcy: Some(Emergency {
                    code: 0x2310,
                    register: 0x03,
                }),
            },
            "drive 3 in Fault: EMCY 0x2310 continuous over-current (error register 0x03)",
        ),
        (
            DriveFault::LeftOperation {
                drive: 1,
                statusword: 0x0007,
            },
            "drive 1 left Operation enabled: Quick stop active (statusword 0x0007)",
        ),
        (
            DriveFault::Silent {
                drive: 5,
                periods: 2,
            },
            "drive 5 silent: no TPDO for 2 periods",
        ),
        (
            DriveFault::SdoAbort {
                drive: 0,
                od: Od::at(0x6060),
                code: SdoAbort(0x0609_0030),
            },
            "drive 0 aborted SDO 0x6060.00: 0x06090030 invalid value for parameter (value range exceeded)",
        ),
        (
            DriveFault::BringUpTimeout {
                drive: 4,
                step: BringUpStep::BootUp,
            },
            "drive 4: bring-up timed out at waiting for the boot-up message after NMT reset node",
        ),
    ];
    for (fault, words) in cases {
        assert_eq!(format!("{fault}"), words);
    }
}

/// Before bring-up ends nothing but the bring-up's frames go out, no forces are
/// taken, and a stop latches the safe command.
#[test]
fn commands_wait_for_operation_and_stop_is_safe() {
    let mut set = DriveSet::<f64, 4>::new(&config()).unwrap();
    let mut sent = std::vec::Vec::new();
    set.start_period(&mut |bus, f| sent.push((bus, *f)));
    // NMT reset node to each of the four drives, nothing cyclic.
    assert_eq!(sent.len(), 4);
    assert!(sent.iter().all(|(_, f)| f.id == 0 && f.data[0] == 0x81));
    assert!(!set.command(&[1.0; 4]));
    assert_eq!(set.feedback(), Ok(None));
    set.stop();
    assert_eq!(set.feedback(), Err(DriveFault::Stopped));
    sent.clear();
    set.start_period(&mut |bus, f| sent.push((bus, *f)));
    // Per bus: SYNC, then the RPDO with Quick stop (0x0002) and zero torque in
    // both slots.
    let rpdo: std::vec::Vec<_> = sent.iter().filter(|(_, f)| f.id & 0x780 == 0x200).collect();
    assert_eq!(rpdo.len(), 3);
    assert_eq!(rpdo[0].1.data, [0x02, 0, 0, 0, 0x02, 0, 0, 0]);
    assert_eq!(sent[0].1, sync(Some(1)));
}
