//! ARROW's six linear actuators as CiA 402 drives in cyclic synchronous torque
//! mode ([`crate::app::drive_set`]) on three CAN FD buses of the STM32G474's
//! FDCAN, two drives a bus (docs/drives.md). The turntable motors stay local.
//!
//! | bus | drives (actuator, node) | RPDO COB-ID |
//! |---|---|---|
//! | 0 (FDCAN1) | q1 node 1, q2 node 2 | 0x201 |
//! | 1 (FDCAN2) | q3 node 3, q4 node 4 | 0x203 |
//! | 2 (FDCAN3) | q5 node 5, q6 node 6 | 0x205 |
//!
//! Per period and bus: SYNC with counter (1 byte), the pair RPDO (8 bytes:
//! controlword and target torque of both drives), one TPDO per drive (6 bytes:
//! statusword, position actual). At 1 Mbit/s nominal and 8 Mbit/s data that is
//! [`bus_cycle_ns`] = 178.75 µs of the 200 µs period, worst-case stuffing: 21.25 µs
//! (10.6 %) to spare. At 5 Mbit/s data it does not fit (204.4 µs, 212.4 µs with
//! torque actual 0x6077 in the TPDOs), so the buses run their data phase at
//! 8 Mbit/s (within the FDCAN's and an 8 Mbit/s transceiver's range), and torque
//! actual is left out: it would fit (183.75 µs) but halve what is left over,
//! and the master does not need it.
//!
//! No heartbeat runs in operation (0x1017 = 0): a heartbeat frame (39.4 µs) does
//! not fit the 21.25 µs left, and each drive's TPDO, checked every period by the
//! master, is the better life sign; the drives watch the SYNC in turn.

use crate::app::drive_set::{DriveAddress, DriveSet, DriveSetConfig};
use crate::codec::canfd_timing::FdBitRates;
use crate::codec::cia402::{RPDO_LEN, TPDO_LEN};
use crate::kinematics::arrow::{ActuatorVector, ArrowMasses, ACTUATORS};
use crate::scalar::Float;

/// The drive set of ARROW's actuators.
pub type ArrowDrives<T> = DriveSet<T, ACTUATORS>;

/// The payloads of one period on one bus: SYNC with counter, the pair RPDO, the two
/// drives' TPDOs.
pub const BUS_PERIOD_FRAMES: [u8; 4] = [1, RPDO_LEN, TPDO_LEN, TPDO_LEN];

/// The worst-case bus time of a period on each bus at [`FdBitRates::ARROW`], ns.
pub fn bus_cycle_ns() -> Option<u32> {
    FdBitRates::ARROW.frames_ns(&BUS_PERIOD_FRAMES)
}

/// Periods without a drive's TPDO that stop ARROW: 2. One late TPDO (a frame
/// repeated after a bus error lands after the period's deadline) is bridged with
/// the drive's last position, at most 5 µm old at the pyramid's 25 mm/s; a second
/// is a fault, 400 µs after the last TPDO.
pub const SILENT_PERIODS: u8 = 2;

/// ARROW's drive set: nodes 1–6 as the table above, the encoders' 50 nm increment,
/// the actuators' force limit ([`ArrowMasses::ARROW`]) as max torque, bring-up
/// timeouts of 1 s for the boot-up (a drive's power stage self-test), 50 ms per SDO
/// and 0.5 s for the controlword walk (in periods of 200 µs).
pub const ARROW_DRIVES: DriveSetConfig<ACTUATORS> = DriveSetConfig {
    drives: [
        DriveAddress { bus: 0, node: 1 },
        DriveAddress { bus: 0, node: 2 },
        DriveAddress { bus: 1, node: 3 },
        DriveAddress { bus: 1, node: 4 },
        DriveAddress { bus: 2, node: 5 },
        DriveAddress { bus: 2, node: 6 },
    ],
    increment_m: 50e-9,
    max_force_n: ArrowMasses::ARROW.actuator_force_limit_n,
    heartbeat_ms: 0,
    boot_timeout_periods: 5_000,
    sdo_timeout_periods: 250,
    enable_timeout_periods: 2_500,
    silent_periods: SILENT_PERIODS,
};

/// The drives' positions as the machine's joint vector, m.
pub fn joints<T: Float>(positions_m: &[T; ACTUATORS]) -> ActuatorVector<T> {
    ActuatorVector::from_column_slice(positions_m)
}

/// The machine's actuator forces as the drives' array, N.
pub fn forces<T: Float>(forces_n: &ActuatorVector<T>) -> [T; ACTUATORS] {
    core::array::from_fn(|i| forces_n.get(i).copied().unwrap_or_else(T::zero))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The period's four frames fit 200 µs at 1/8 Mbit/s with 21.25 µs to spare;
    /// at 1/5 Mbit/s they do not, with or without torque actual in the TPDOs.
    #[test]
    fn the_bus_cycle_fits_the_period() {
        let period_ns = (crate::machines::arrow::product::PERIOD_S * 1e9) as u32;
        assert_eq!(period_ns, 200_000);
        let cycle = bus_cycle_ns().unwrap();
        assert_eq!(cycle, 178_750);
        assert!(cycle < period_ns);
        let five = FdBitRates {
            nominal_bps: 1_000_000,
            data_bps: 5_000_000,
        };
        assert_eq!(five.frames_ns(&BUS_PERIOD_FRAMES), Some(204_400));
        assert_eq!(five.frames_ns(&[1, 8, 8, 8]), Some(212_400));
        assert_eq!(FdBitRates::ARROW.frames_ns(&[1, 8, 8, 8]), Some(183_750));
        // A heartbeat does not fit what is left.
        let heartbeat = FdBitRates::ARROW.frame_ns(1).unwrap();
        assert!(cycle + heartbeat > period_ns);
    }

    #[test]
    fn arrow_drive_set_is_valid() {
        let set = ArrowDrives::<f32>::new(&ARROW_DRIVES).unwrap();
        assert_eq!(set.rpdo_id(1), Some(0x203));
        let v = ActuatorVector::<f64>::from_fn(|i, _| i as f64);
        assert_eq!(joints(&forces(&v)), v);
    }
}
