//! Simulated CiA 402 servo drives on simulated CAN FD buses (docs/drives.md): each
//! answers as a drive in cyclic synchronous torque mode does.
//!
//! - NMT: reset node / communication sends the boot-up message and enters
//!   pre-operational with the defaults; start, stop and pre-operational as CiA 301.
//! - SDO server (expedited) for 0x6060 (modes 8, 9, 10 accepted), 0x6061, 0x6072
//!   (up to [`SimDriveConfig::peak_permille`]), 0x6076, 0x1017, 0x6041, 0x6064,
//!   0x603F, 0x1001; a sub-index other than 0 is aborted 0x06090011, another object
//!   0x06020000, a value out of range 0x06090030, a write to a read-only object
//!   0x06010002, a wrong size 0x06070010.
//! - The CiA 402 state machine driven by the controlword; commands that are no
//!   transition from the present state are ignored, as drives do (Enable operation
//!   in Switch on disabled stays there).
//! - CST: the RPDO (transmission type 1) is latched and acts at the next SYNC; the
//!   target torque is clipped at max torque 0x6072; the force acts only in Operation
//!   enabled with mode 10. At each SYNC in Operational the TPDO goes out:
//!   statusword and the position sampled at that SYNC in increments.
//! - Heartbeat producer (0x1017, timed by [`SimDriveSet::tick`]).
//! - Communication watchdog: no SYNC for [`SimDriveConfig::watchdog_periods`] ticks
//!   while enabled → Fault, EMCY 0x8130.
//! - Injectable faults ([`Injection`]).
//!
//! The PDO mappings are the drives' stored parameters, not written by the master:
//! RPDO1 (COB-ID [`SimDriveConfig::rpdo_id`]) mapped as [`cia402::rpdo_mapping`] of
//! the drive's slot, TPDO1 as [`cia402::TPDO_MAPPING`], both transmission type 1.

use heapless::Deque;
use kerf::codec::canopen::DriveAddress;
use kerf::codec::canopen::{
    CanFrame, Emergency, NmtCommand, NmtState, Od, Received, SdoAbort, SdoRequest, SdoResponse,
};
use kerf::codec::cia402::{self, cw, sw, CstCommand, CstFeedback, DriveCommand, DriveState};
use kerf::kinematics::arrow::ArrowMasses;

/// A simulated drive's parameters.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SimDriveConfig {
    /// Bus index.
    pub bus: u8,
    /// Node id.
    pub node: u8,
    /// COB-ID of the RPDO it maps (0x1400 sub 1).
    pub rpdo_id: u16,
    /// Its slot in that RPDO (0 or 1; the other is dummy-mapped).
    pub slot: u8,
    /// Rated force 0x6076, mN.
    pub rated_mn: u32,
    /// The highest max torque 0x6072 it accepts, per mille (its peak force).
    pub peak_permille: u16,
    /// The encoder's increment, m.
    pub increment_m: f64,
    /// Ticks without a SYNC that trip the watchdog.
    pub watchdog_periods: u32,
}

/// What a drive model brings (the same for every drive of a set).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SimDriveModel {
    /// Rated force 0x6076, mN.
    pub rated_mn: u32,
    /// The highest max torque 0x6072 it accepts, per mille.
    pub peak_permille: u16,
    /// Ticks without a SYNC that trip the watchdog.
    pub watchdog_periods: u32,
}

impl SimDriveModel {
    /// ARROW's actuator drives: rated at half the actuators' 2,500 N limit
    /// ([`ArrowMasses::ARROW`]; linear motors' peak force is commonly twice their
    /// continuous one), so the limit is 2,000 per mille and one per mille of target
    /// torque is 1.25 N; peak 2,000 per mille. The watchdog allows three periods
    /// without SYNC (600 µs at 5 kHz).
    pub const ARROW: Self = Self {
        rated_mn: (ArrowMasses::ARROW.actuator_force_limit_n * 500.0) as u32,
        peak_permille: 2000,
        watchdog_periods: 3,
    };

    /// The drives at `addresses` (a master's buses and node ids), with the RPDO
    /// COB-ID and slot each maps and the encoder increment `increment_m`.
    pub fn drives<const N: usize>(
        &self,
        addresses: &[DriveAddress; N],
        increment_m: f64,
    ) -> [SimDriveConfig; N] {
        core::array::from_fn(|i| {
            let a = addresses
                .get(i)
                .copied()
                .unwrap_or(DriveAddress { bus: 0, node: 0 });
            let on_bus = addresses.iter().take(i).filter(|b| b.bus == a.bus);
            let first = addresses.iter().find(|b| b.bus == a.bus).unwrap_or(&a);
            SimDriveConfig {
                bus: a.bus,
                node: a.node,
                rpdo_id: kerf::codec::canopen::cob::RPDO1 | u16::from(first.node),
                slot: on_bus.count() as u8,
                rated_mn: self.rated_mn,
                peak_permille: self.peak_permille,
                increment_m,
                watchdog_periods: self.watchdog_periods,
            }
        })
    }
}

/// A fault to inject into a drive.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Injection {
    /// Continuous over-current: EMCY 0x2310 and Fault at once.
    Overcurrent,
    /// The encoder fails: EMCY 0x7305 and Fault at the next SYNC.
    EncoderFault,
    /// The drive falls silent (its bus cable cut): it neither sends nor hears a frame
    /// from now on, and its watchdog, hearing no SYNC, takes its force off.
    Silent,
    /// It answers the write of mode 10 with abort 0x06090030.
    RefuseCst,
    /// It never sends its boot-up message (nor anything else after a reset).
    NeverBoots,
    /// It is in Fault (EMCY 0x3210 on entry) when brought up; a fault reset clears it.
    StartInFault,
    /// Safe torque off from the machine's safety circuit: EMCY 0x5441, the power
    /// stage off, the drive back in Switch on disabled (no Fault).
    SafeTorqueOff,
}

/// One simulated drive.
#[derive(Clone, Debug)]
struct SimDrive {
    config: SimDriveConfig,
    nmt: Option<NmtState>,
    state: DriveState,
    mode: i8,
    max_permille: u16,
    heartbeat_ms: u16,
    heartbeat_s: f64,
    latched: CstCommand,
    applied_cw: u16,
    torque_permille: i16,
    position: i32,
    periods_since_sync: u32,
    error_code: u16,
    silent: bool,
    refuse_cst: bool,
    never_boots: bool,
    start_in_fault: bool,
    encoder_failed: bool,
}

/// A drive's max torque after reset, per mille.
const DEFAULT_MAX_PERMILLE: u16 = 1000;

impl SimDrive {
    fn new(config: SimDriveConfig) -> Self {
        Self {
            config,
            nmt: None,
            state: DriveState::NotReadyToSwitchOn,
            mode: 0,
            max_permille: DEFAULT_MAX_PERMILLE,
            heartbeat_ms: 0,
            heartbeat_s: 0.0,
            latched: CstCommand::default(),
            applied_cw: 0,
            torque_permille: 0,
            position: 0,
            periods_since_sync: 0,
            error_code: 0,
            silent: false,
            refuse_cst: false,
            never_boots: false,
            start_in_fault: false,
            encoder_failed: false,
        }
    }

    fn statusword(&self) -> u16 {
        let voltage = matches!(
            self.state,
            DriveState::ReadyToSwitchOn
                | DriveState::SwitchedOn
                | DriveState::OperationEnabled
                | DriveState::QuickStopActive
        );
        let follows = self.state == DriveState::OperationEnabled && self.mode == cia402::MODE_CST;
        let clipped = follows && self.torque_permille.unsigned_abs() >= self.max_permille;
        self.state.statusword()
            | sw::REMOTE
            | if voltage { sw::VOLTAGE_ENABLED } else { 0 }
            | if follows { sw::FOLLOWS_COMMAND } else { 0 }
            | if clipped { sw::INTERNAL_LIMIT } else { 0 }
    }

    /// Power-on / NMT reset: parameters to their defaults, boot-up message. The
    /// hardware stays as it is (the position, a failed encoder, the injections).
    fn reset(&mut self, out: &mut dyn FnMut(CanFrame)) {
        *self = Self {
            position: self.position,
            silent: self.silent,
            refuse_cst: self.refuse_cst,
            never_boots: self.never_boots,
            start_in_fault: self.start_in_fault,
            encoder_failed: self.encoder_failed,
            ..Self::new(self.config)
        };
        if self.never_boots {
            return;
        }
        self.nmt = Some(NmtState::PreOperational);
        self.state = DriveState::SwitchOnDisabled;
        out(NmtState::BootUp.heartbeat(self.config.node));
        if self.start_in_fault {
            self.start_in_fault = false;
            self.fault(Emergency::DC_LINK_OVERVOLTAGE, Emergency::REG_VOLTAGE, out);
        }
    }

    fn fault(&mut self, code: u16, register: u8, out: &mut dyn FnMut(CanFrame)) {
        // Fault reaction (torque off) then Fault; the reaction is immediate here.
        self.state = DriveState::Fault;
        self.torque_permille = 0;
        self.error_code = code;
        if let Ok(f) = (Emergency {
            code,
            register: register | Emergency::REG_GENERIC,
        })
        .frame(self.config.node)
        {
            out(f);
        }
    }

    /// CiA 402's transitions for a controlword applied at a SYNC.
    fn apply_controlword(&mut self, word: u16) {
        let edge = word & cw::FAULT_RESET != 0 && self.applied_cw & cw::FAULT_RESET == 0;
        self.applied_cw = word;
        use DriveCommand as C;
        use DriveState as S;
        let command = DriveCommand::from_controlword(word);
        self.state = match (self.state, command) {
            (S::Fault, _) if edge && !self.encoder_failed => {
                self.error_code = 0;
                S::SwitchOnDisabled
            }
            (S::Fault, _) => S::Fault,
            (S::SwitchOnDisabled, C::Shutdown) => S::ReadyToSwitchOn,
            (S::ReadyToSwitchOn, C::SwitchOn) => S::SwitchedOn,
            (S::ReadyToSwitchOn, C::EnableOperation) => S::OperationEnabled,
            (S::ReadyToSwitchOn, C::DisableVoltage | C::QuickStop) => S::SwitchOnDisabled,
            (S::SwitchedOn, C::EnableOperation) => S::OperationEnabled,
            (S::SwitchedOn, C::Shutdown) => S::ReadyToSwitchOn,
            (S::SwitchedOn, C::DisableVoltage | C::QuickStop) => S::SwitchOnDisabled,
            (S::OperationEnabled, C::SwitchOn) => S::SwitchedOn,
            (S::OperationEnabled, C::Shutdown) => S::ReadyToSwitchOn,
            (S::OperationEnabled, C::DisableVoltage) => S::SwitchOnDisabled,
            (S::OperationEnabled, C::QuickStop) => S::QuickStopActive,
            (S::QuickStopActive, C::DisableVoltage) => S::SwitchOnDisabled,
            (S::QuickStopActive, C::EnableOperation) => S::OperationEnabled,
            (state, _) => state,
        };
    }

    fn on_sync(&mut self, out: &mut dyn FnMut(CanFrame)) {
        self.periods_since_sync = 0;
        if self.nmt != Some(NmtState::Operational) {
            return;
        }
        if self.encoder_failed && self.state != DriveState::Fault {
            self.fault(Emergency::ENCODER, 0, out);
        }
        self.apply_controlword(self.latched.controlword);
        let enabled = self.state == DriveState::OperationEnabled && self.mode == cia402::MODE_CST;
        let max = self.max_permille.min(i16::MAX as u16) as i16;
        self.torque_permille = if enabled {
            self.latched.target_torque.clamp(-max, max)
        } else {
            0
        };
        let feedback = CstFeedback {
            statusword: self.statusword(),
            position: self.position,
        };
        if let Ok(f) = CanFrame::new(
            kerf::codec::canopen::cob::TPDO1 | u16::from(self.config.node),
            &cia402::encode_tpdo(&feedback),
        ) {
            out(f);
        }
    }

    fn sdo(&mut self, request: SdoRequest) -> SdoResponse {
        let (od, write) = match request {
            SdoRequest::Download { od, value, size } => (od, Some((value, size))),
            SdoRequest::Upload { od } => (od, None),
        };
        let abort = |code| SdoResponse::Abort { od, code };
        // (value, size, writable)
        let object = match od.index {
            0x6060 => (u32::from(self.mode as u8), 1, true),
            0x6061 => (u32::from(self.mode as u8), 1, false),
            0x6072 => (u32::from(self.max_permille), 2, true),
            0x6076 => (self.config.rated_mn, 4, false),
            0x1017 => (u32::from(self.heartbeat_ms), 2, true),
            0x6041 => (u32::from(self.statusword()), 2, false),
            0x6064 => (self.position as u32, 4, false),
            0x603F => (u32::from(self.error_code), 2, false),
            0x1001 => (
                u32::from(u8::from(self.state == DriveState::Fault)),
                1,
                false,
            ),
            _ => return abort(SdoAbort::NO_OBJECT),
        };
        if od.sub != 0 {
            return abort(SdoAbort::NO_SUB);
        }
        let (current, size, writable) = object;
        let Some((value, written)) = write else {
            return SdoResponse::Uploaded {
                od,
                value: current,
                size,
            };
        };
        if !writable {
            return abort(SdoAbort::READ_ONLY);
        }
        if written != size {
            return abort(SdoAbort::LENGTH);
        }
        match od.index {
            0x6060 => {
                let mode = value as u8 as i8;
                if !matches!(mode, 8..=10) || (self.refuse_cst && mode == cia402::MODE_CST) {
                    return abort(SdoAbort::INVALID_VALUE);
                }
                self.mode = mode;
            }
            0x6072 => {
                if value > u32::from(self.config.peak_permille) {
                    return abort(SdoAbort::INVALID_VALUE);
                }
                self.max_permille = value as u16;
            }
            _ => {
                self.heartbeat_ms = value as u16;
                self.heartbeat_s = 0.0;
            }
        }
        SdoResponse::Downloaded { od }
    }

    fn receive(&mut self, frame: &CanFrame, out: &mut dyn FnMut(CanFrame)) {
        if self.silent {
            return;
        }
        let node = self.config.node;
        if frame.id == self.config.rpdo_id {
            if self.nmt == Some(NmtState::Operational) {
                if let Some(c) = cia402::decode_rpdo(frame.payload(), usize::from(self.config.slot))
                {
                    self.latched = c;
                }
            }
            return;
        }
        match Received::parse(frame) {
            Ok(Received::Nmt(command, target)) if target == 0 || target == node => match command {
                NmtCommand::ResetNode | NmtCommand::ResetCommunication => self.reset(out),
                _ if self.nmt.is_none() => {}
                NmtCommand::Start => self.nmt = Some(NmtState::Operational),
                NmtCommand::Stop => self.nmt = Some(NmtState::Stopped),
                NmtCommand::PreOperational => self.nmt = Some(NmtState::PreOperational),
            },
            Ok(Received::Sync(_)) => self.on_sync(out),
            Ok(Received::SdoRequest(n, request)) if n == node => {
                if matches!(
                    self.nmt,
                    Some(NmtState::PreOperational | NmtState::Operational)
                ) {
                    if let Ok(f) = self.sdo(request).frame(node) {
                        out(f);
                    }
                }
            }
            _ => {}
        }
    }

    fn tick(&mut self, period_s: f64, out: &mut dyn FnMut(CanFrame)) {
        if self.nmt.is_none() {
            return;
        }
        // A silent drive hears no SYNC, so its watchdog trips; what it sends is lost.
        let mut lost = |_| {};
        let out: &mut dyn FnMut(CanFrame) = if self.silent { &mut lost } else { out };
        self.periods_since_sync = self.periods_since_sync.saturating_add(1);
        let enabled = matches!(
            self.state,
            DriveState::OperationEnabled | DriveState::QuickStopActive
        );
        if enabled && self.periods_since_sync > self.config.watchdog_periods {
            self.fault(Emergency::HEARTBEAT, Emergency::REG_COMMUNICATION, out);
        }
        if self.heartbeat_ms > 0 {
            self.heartbeat_s += period_s;
            let every = f64::from(self.heartbeat_ms) * 1e-3;
            if self.heartbeat_s >= every - 1e-12 {
                self.heartbeat_s -= every;
                if let Some(state) = self.nmt {
                    out(state.heartbeat(self.config.node));
                }
            }
        }
    }

    /// The force the drive applies now, N.
    fn force_n(&self) -> f64 {
        if self.state != DriveState::OperationEnabled {
            return 0.0;
        }
        f64::from(self.torque_permille) * f64::from(self.config.rated_mn) * 1e-6
    }
}

/// Frames waiting to be sent, with their bus.
pub type Outbox = Deque<(u8, CanFrame), 64>;

/// N simulated drives on their buses.
#[derive(Clone, Debug)]
pub struct SimDriveSet<const N: usize> {
    drives: [SimDrive; N],
    outbox: Outbox,
    /// Frames lost because the outbox was full (a test reads it to be sure none were).
    pub dropped: u32,
}

impl<const N: usize> SimDriveSet<N> {
    /// The drives, powered but silent until an NMT reset (as after power-on: the
    /// boot-up they sent went unheard before the master started).
    pub fn new(configs: [SimDriveConfig; N]) -> Self {
        Self {
            drives: configs.map(SimDrive::new),
            outbox: Deque::new(),
            dropped: 0,
        }
    }

    /// Injects a fault into drive `i` (ignored for an index out of range).
    pub fn inject(&mut self, i: usize, injection: Injection) {
        let Some(d) = self.drives.get_mut(i) else {
            return;
        };
        let mut sent = heapless::Vec::<CanFrame, 2>::new();
        match injection {
            Injection::Overcurrent => {
                d.fault(Emergency::OVERCURRENT, Emergency::REG_CURRENT, &mut |f| {
                    let _ = sent.push(f);
                })
            }
            Injection::EncoderFault => d.encoder_failed = true,
            Injection::Silent => d.silent = true,
            Injection::RefuseCst => d.refuse_cst = true,
            Injection::NeverBoots => d.never_boots = true,
            Injection::StartInFault => d.start_in_fault = true,
            Injection::SafeTorqueOff => {
                d.state = DriveState::SwitchOnDisabled;
                d.torque_permille = 0;
                if let Ok(f) = (Emergency {
                    code: Emergency::SAFE_TORQUE_OFF,
                    register: Emergency::REG_GENERIC,
                })
                .frame(d.config.node)
                {
                    let _ = sent.push(f);
                }
            }
        }
        let bus = d.config.bus;
        for f in sent {
            self.push(bus, f);
        }
    }

    fn push(&mut self, bus: u8, frame: CanFrame) {
        if self.outbox.push_back((bus, frame)).is_err() {
            self.dropped += 1;
        }
    }

    /// A frame the master sent on `bus`: every drive on the bus hears it.
    pub fn deliver(&mut self, bus: u8, frame: &CanFrame) {
        let mut sent = heapless::Vec::<CanFrame, 4>::new();
        for i in 0..N {
            let Some(d) = self.drives.get_mut(i) else {
                continue;
            };
            if d.config.bus != bus {
                continue;
            }
            d.receive(frame, &mut |f| {
                let _ = sent.push(f);
            });
            for f in sent.iter() {
                self.push(bus, *f);
            }
            sent.clear();
        }
    }

    /// Time passes by `period_s`: heartbeats and the watchdog.
    pub fn tick(&mut self, period_s: f64) {
        for i in 0..N {
            let mut sent = heapless::Vec::<CanFrame, 4>::new();
            let Some(d) = self.drives.get_mut(i) else {
                continue;
            };
            d.tick(period_s, &mut |f| {
                let _ = sent.push(f);
            });
            let bus = d.config.bus;
            for f in sent {
                self.push(bus, f);
            }
        }
    }

    /// The next frame the drives sent, with its bus.
    pub fn next_frame(&mut self) -> Option<(u8, CanFrame)> {
        self.outbox.pop_front()
    }

    /// The forces the drives apply, N.
    pub fn forces_n(&self) -> [f64; N] {
        core::array::from_fn(|i| self.drives.get(i).map_or(0.0, SimDrive::force_n))
    }

    /// The positions the encoders see, m (each quantized to its increment).
    pub fn set_positions_m(&mut self, positions_m: &[f64; N]) {
        for (d, q) in self.drives.iter_mut().zip(positions_m) {
            let inc = libm::round(q / d.config.increment_m);
            d.position = inc.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
        }
    }

    /// Drive `i`'s state.
    pub fn state(&self, i: usize) -> Option<DriveState> {
        self.drives.get(i).map(|d| d.state)
    }

    /// Drive `i`'s NMT state (`None` before its boot-up).
    pub fn nmt(&self, i: usize) -> Option<NmtState> {
        self.drives.get(i).and_then(|d| d.nmt)
    }

    /// Drive `i`'s SDO answer to `request`, as the bus would carry it (for tests of
    /// the server alone).
    pub fn sdo(&mut self, i: usize, request: SdoRequest) -> Option<SdoResponse> {
        self.drives.get_mut(i).map(|d| d.sdo(request))
    }

    /// The object `od` of drive `i` read as the master would.
    pub fn read(&mut self, i: usize, od: Od) -> Option<SdoResponse> {
        self.sdo(i, SdoRequest::Upload { od })
    }
}

#[cfg(test)]
mod tests;
