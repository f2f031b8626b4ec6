//! The drive set's bring-up, one step per period, driven by the frames received
//! (see the parent module for the sequence; docs/drives.md for the objects).

use super::{DriveFault, DriveSet, Phase};
use crate::codec::canopen::{NmtCommand, SdoRequest, SdoResponse};
use crate::codec::cia402::{cw, od, DriveState, MODE_CST};
use crate::scalar::Float;

/// A bring-up step.
#[derive(Copy, Clone, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BringUpStep {
    /// NMT reset node sent, waiting for the boot-up message.
    BootUp,
    /// SDO download 0x6060 = 10.
    SetMode,
    /// SDO upload 0x6061 (must read 10).
    ReadMode,
    /// SDO upload 0x6076 (the rated force the torques are per mille of).
    ReadRatedForce,
    /// SDO download 0x6072.
    SetMaxTorque,
    /// SDO download 0x1017.
    SetHeartbeat,
    /// NMT start sent; controlword walk to Operation enabled.
    Enable,
}

impl BringUpStep {
    /// The step in words.
    pub fn words(self) -> &'static str {
        match self {
            Self::BootUp => "waiting for the boot-up message after NMT reset node",
            Self::SetMode => "SDO write of mode of operation 0x6060 = 10",
            Self::ReadMode => "SDO read of mode of operation display 0x6061",
            Self::ReadRatedForce => "SDO read of rated torque (force) 0x6076",
            Self::SetMaxTorque => "SDO write of max torque 0x6072",
            Self::SetHeartbeat => "SDO write of producer heartbeat time 0x1017",
            Self::Enable => "controlword walk to Operation enabled",
        }
    }
}

/// The SDO steps, in order.
const SDO_STEPS: [BringUpStep; 5] = [
    BringUpStep::SetMode,
    BringUpStep::ReadMode,
    BringUpStep::ReadRatedForce,
    BringUpStep::SetMaxTorque,
    BringUpStep::SetHeartbeat,
];

/// Periods a drive in Fault may take to leave it after the fault reset edge (the
/// controlword acts at the SYNC after the RPDO, its statusword comes a period later).
const RESET_WAIT_PERIODS: u8 = 4;

/// Bring-up progress of the whole set.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct BringUp {
    /// Periods in the present phase step (boot-up, enable).
    periods: u32,
    reset_sent: bool,
}

/// One drive's bring-up progress.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct DriveProgress {
    /// Index into the SDO steps (their count when done).
    step: u8,
    /// A request is out.
    pending: bool,
    /// Periods it has been out.
    waited: u32,
    /// Fault reset: 0 not begun, 1 bit 7 low sent, 2 the edge sent.
    reset: u8,
    /// Periods since the edge.
    reset_wait: u8,
}

impl<T: Float, const N: usize> DriveSet<T, N> {
    pub(super) fn bring_up_period(
        &mut self,
        step: BringUpStep,
        tx: &mut impl FnMut(u8, &crate::codec::canopen::CanFrame),
    ) {
        match step {
            BringUpStep::BootUp => self.boot_up(tx),
            BringUpStep::Enable => self.enable(),
            _ => self.configure(tx),
        }
    }

    fn boot_up(&mut self, tx: &mut impl FnMut(u8, &crate::codec::canopen::CanFrame)) {
        if !self.bring_up.reset_sent {
            for a in self.drives.iter().filter_map(|d| d.address) {
                tx(a.bus, &NmtCommand::ResetNode.frame(a.node));
            }
            self.bring_up = BringUp {
                periods: 0,
                reset_sent: true,
            };
            return;
        }
        self.bring_up.periods = self.bring_up.periods.saturating_add(1);
        if let Some(i) = self.drives.iter().position(|d| !d.booted) {
            if self.bring_up.periods > self.config().boot_timeout_periods {
                self.latch(DriveFault::BringUpTimeout {
                    drive: i as u8,
                    step: BringUpStep::BootUp,
                });
            }
            return;
        }
        self.enter(Phase::BringingUp(BringUpStep::SetMode));
        self.configure(tx);
    }

    fn request(&self, i: usize, step: BringUpStep) -> Option<SdoRequest> {
        let d = self.drives.get(i)?;
        Some(match step {
            BringUpStep::SetMode => SdoRequest::Download {
                od: od::MODES_OF_OPERATION,
                value: u32::from(MODE_CST as u8),
                size: 1,
            },
            BringUpStep::ReadMode => SdoRequest::Upload {
                od: od::MODES_DISPLAY,
            },
            BringUpStep::ReadRatedForce => SdoRequest::Upload {
                od: od::RATED_TORQUE,
            },
            BringUpStep::SetMaxTorque => SdoRequest::Download {
                od: od::MAX_TORQUE,
                value: u32::from(d.max_permille),
                size: 2,
            },
            BringUpStep::SetHeartbeat => SdoRequest::Download {
                od: od::HEARTBEAT_PRODUCER,
                value: u32::from(self.config().heartbeat_ms),
                size: 2,
            },
            BringUpStep::BootUp | BringUpStep::Enable => return None,
        })
    }

    fn configure(&mut self, tx: &mut impl FnMut(u8, &crate::codec::canopen::CanFrame)) {
        let timeout = self.config().sdo_timeout_periods;
        let mut least = None;
        for i in 0..N {
            let Some(d) = self.drives.get(i).copied() else {
                continue;
            };
            let Some(&step) = SDO_STEPS.get(usize::from(d.progress.step)) else {
                continue;
            };
            least = Some(least.map_or(step, |l: BringUpStep| l.min(step)));
            if d.progress.pending {
                let waited = d.progress.waited.saturating_add(1);
                if let Some(d) = self.drives.get_mut(i) {
                    d.progress.waited = waited;
                }
                if waited > timeout {
                    self.latch(DriveFault::BringUpTimeout {
                        drive: i as u8,
                        step,
                    });
                    return;
                }
                continue;
            }
            let (Some(request), Some(a)) = (self.request(i, step), d.address) else {
                continue;
            };
            if let Ok(frame) = request.frame(a.node) {
                tx(a.bus, &frame);
            }
            if let Some(d) = self.drives.get_mut(i) {
                d.progress.pending = true;
                d.progress.waited = 0;
            }
        }
        match least {
            Some(step) => self.enter(Phase::BringingUp(step)),
            None => {
                for a in self.drives.iter().filter_map(|d| d.address) {
                    tx(a.bus, &NmtCommand::Start.frame(a.node));
                }
                self.bring_up.periods = 0;
                for d in self.drives.iter_mut() {
                    d.command.controlword = cw::DISABLE_VOLTAGE;
                }
                self.enter(Phase::BringingUp(BringUpStep::Enable));
            }
        }
    }

    /// An SDO response of drive `i` (ignored unless it awaits one).
    pub(super) fn sdo_response(&mut self, i: usize, response: SdoResponse) {
        let Some(d) = self.drives.get(i).copied() else {
            return;
        };
        let Some(&step) = SDO_STEPS.get(usize::from(d.progress.step)) else {
            return;
        };
        if !d.progress.pending {
            return;
        }
        let drive = i as u8;
        let expected = match self.request(i, step) {
            Some(SdoRequest::Download { od, .. } | SdoRequest::Upload { od }) => od,
            None => return,
        };
        let max_force_n = self.config().max_force_n;
        let Some(d) = self.drives.get_mut(i) else {
            return;
        };
        let fault = match response {
            SdoResponse::Abort { od, code } => Some(DriveFault::SdoAbort { drive, od, code }),
            SdoResponse::Downloaded { od } if od == expected => match step {
                BringUpStep::SetMode | BringUpStep::SetMaxTorque | BringUpStep::SetHeartbeat => {
                    None
                }
                _ => Some(DriveFault::SdoProtocol { drive, od }),
            },
            SdoResponse::Uploaded { od, value, .. } if od == expected => match step {
                BringUpStep::ReadMode if value as u8 as i8 == MODE_CST => None,
                BringUpStep::ReadMode => Some(DriveFault::ModeRefused {
                    drive,
                    displayed: value as u8 as i8,
                }),
                BringUpStep::ReadRatedForce => {
                    let max = libm::round(max_force_n * 1e6 / f64::from(value));
                    if value == 0 || !(1.0..=f64::from(u16::MAX)).contains(&max) {
                        Some(DriveFault::RatedForce {
                            drive,
                            rated_mn: value,
                        })
                    } else {
                        d.rated_mn = value;
                        d.permille_per_n = 1e6 / f64::from(value);
                        d.max_permille = max as u16;
                        None
                    }
                }
                _ => Some(DriveFault::SdoProtocol { drive, od }),
            },
            SdoResponse::Downloaded { od } | SdoResponse::Uploaded { od, .. } => {
                Some(DriveFault::SdoProtocol { drive, od })
            }
        };
        d.progress.pending = false;
        d.progress.step = d.progress.step.saturating_add(1);
        if let Some(f) = fault {
            self.latch(f);
        }
    }

    /// The controlword walk: each drive's next controlword from its last statusword.
    fn enable(&mut self) {
        self.bring_up.periods = self.bring_up.periods.saturating_add(1);
        let timed_out = self.bring_up.periods > self.config().enable_timeout_periods;
        let mut all = true;
        let mut fault = None;
        for (i, d) in self.drives.iter_mut().enumerate() {
            let state = d.statusword.and_then(DriveState::from_statusword);
            let drive = i as u8;
            let controlword = match state {
                Some(DriveState::OperationEnabled) => cw::ENABLE_OPERATION_CMD,
                Some(DriveState::SwitchedOn) => cw::ENABLE_OPERATION_CMD,
                Some(DriveState::ReadyToSwitchOn) => cw::SWITCH_ON_CMD,
                Some(DriveState::SwitchOnDisabled) => cw::SHUTDOWN,
                Some(DriveState::Fault) => {
                    let p = &mut d.progress;
                    match p.reset {
                        0 => {
                            p.reset = 1;
                            cw::DISABLE_VOLTAGE
                        }
                        1 => {
                            p.reset = 2;
                            cw::FAULT_RESET
                        }
                        _ => {
                            p.reset_wait = p.reset_wait.saturating_add(1);
                            if p.reset_wait > RESET_WAIT_PERIODS {
                                fault = fault.or(Some(DriveFault::InFault {
                                    drive,
                                    emcy: d.emcy,
                                }));
                            }
                            cw::DISABLE_VOLTAGE
                        }
                    }
                }
                _ => cw::DISABLE_VOLTAGE,
            };
            all &= state == Some(DriveState::OperationEnabled);
            if timed_out && state != Some(DriveState::OperationEnabled) {
                fault = fault.or(Some(DriveFault::BringUpTimeout {
                    drive,
                    step: BringUpStep::Enable,
                }));
            }
            d.command.controlword = controlword;
            d.command.target_torque = 0;
        }
        if let Some(f) = fault {
            self.latch(f);
        } else if all {
            self.enter(Phase::Operational);
        }
    }
}
