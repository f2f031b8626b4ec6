//! ARROW with its six actuators behind CiA 402 drives (docs/drives.md): the
//! master of `kerf::machines::arrow::drives` on three simulated buses, the
//! simulated drives of `hal_mock::cia402` applying their forces to the plant and
//! reading its joints through their 50 nm encoders. The turntable stays local.
//!
//! A period, as on the board: at the tick the master sends, per bus, the SYNC and
//! the RPDO of the forces computed in the period before; the drives apply the RPDO
//! they latched in the period before at the SYNC and answer with their TPDOs
//! (statusword, position sampled at the SYNC); the master checks and converts
//! them, the machine computes, and the forces go out with the next SYNC. A force
//! therefore acts two periods after the positions it was computed from were sampled
//! (the law cannot finish before the next SYNC: docs/drives.md). With
//! [`DriveIo::rpdo_before_sync`] the RPDO is delivered before the SYNC instead, as
//! a board whose law and RPDO fit between the TPDOs and the next SYNC would: one
//! period.

use crate::arrow::{ArrowIo, ArrowScenario};
use hal_mock::arrow::{ArrowPlant, ArrowReading};
use hal_mock::cia402::{SimDriveModel, SimDriveSet};
use heapless::Vec;
use kerf::app::drive_set::{DriveFault, Phase};
use kerf::codec::canopen::{cob, CanFrame};
use kerf::error::ConfigError;
use kerf::kinematics::arrow::{ActuatorVector, ArrowError, Pose, ACTUATORS};
use kerf::machines::arrow::drives::{forces, joints, ArrowDrives, ARROW_DRIVES};
use kerf::machines::arrow::machine::{ArrowInputs, ArrowOutputs};

/// The plant, the master and the drives between them.
pub struct DriveIo<'d> {
    /// The plant.
    pub plant: ArrowPlant<f64>,
    /// The master.
    pub master: ArrowDrives<f64>,
    /// The drives.
    pub drives: SimDriveSet<ACTUATORS>,
    /// Deliver each period's RPDO before its SYNC (one period from sample to force).
    pub rpdo_before_sync: bool,
    /// Called at the start of period k with the drives (to inject faults).
    pub inject: &'d mut dyn FnMut(u64, &mut SimDriveSet<ACTUATORS>),
    /// Frames the master sent, in all.
    pub frames_sent: u64,
    /// The most frames the master handed out for one bus in one period.
    pub most_frames_per_bus: usize,
    period_s: f64,
    joints_m: ActuatorVector<f64>,
}

impl<'d> DriveIo<'d> {
    /// ARROW's drive set ([`ARROW_DRIVES`], [`SimDriveModel::ARROW`]) on `plant`,
    /// before bring-up.
    pub fn new(
        scenario: &ArrowScenario,
        plant: ArrowPlant<f64>,
        inject: &'d mut dyn FnMut(u64, &mut SimDriveSet<ACTUATORS>),
    ) -> Result<Self, ConfigError> {
        let master = ArrowDrives::<f64>::new(&ARROW_DRIVES)?;
        let drives = SimDriveSet::new(
            SimDriveModel::ARROW.drives(&ARROW_DRIVES.drives, ARROW_DRIVES.increment_m),
        );
        let mut io = Self {
            plant,
            master,
            drives,
            rpdo_before_sync: false,
            inject,
            frames_sent: 0,
            most_frames_per_bus: 0,
            period_s: scenario.plant.period_s,
            joints_m: ActuatorVector::zeros(),
        };
        io.sample();
        Ok(io)
    }

    /// The drives' encoders see the plant's true joints.
    fn sample(&mut self) {
        let (pose, _) = self.plant.state();
        if let Ok(q) = self.plant.geometry().inverse(&pose) {
            self.drives.set_positions_m(&forces(&q));
        }
    }

    /// One exchange on the buses: the master's frames of the period's tick delivered
    /// (SYNC first unless [`Self::rpdo_before_sync`]), every frame the drives sent
    /// handed to the master.
    fn exchange(&mut self) {
        let mut sent: Vec<(u8, CanFrame), 32> = Vec::new();
        self.master.start_period(&mut |bus, f| {
            let _ = sent.push((bus, *f));
        });
        self.frames_sent += sent.len() as u64;
        for bus in 0..3u8 {
            let n = sent.iter().filter(|(b, _)| *b == bus).count();
            self.most_frames_per_bus = self.most_frames_per_bus.max(n);
        }
        if self.rpdo_before_sync {
            sent.sort_unstable_by_key(|(bus, f)| (*bus, f.function() != cob::RPDO1));
        }
        for (bus, f) in &sent {
            self.drives.deliver(*bus, f);
        }
        while let Some((bus, f)) = self.drives.next_frame() {
            self.master.receive(bus, &f);
        }
    }

    /// Brings the drives up, the plant held by the actuators' brakes; returns the
    /// periods it took, or the master's fault.
    pub fn bring_up(&mut self, max_periods: u32) -> Result<u32, DriveFault> {
        for k in 0..max_periods {
            self.exchange();
            self.drives.tick(self.period_s);
            match self.master.phase() {
                Phase::Operational => return Ok(k + 1),
                Phase::Faulted(f) => return Err(f),
                Phase::BringingUp(_) => {}
            }
        }
        Err(DriveFault::Stopped)
    }

    /// The joints as the drives' encoders read them now, m.
    fn encoders(&self) -> Result<ActuatorVector<f64>, ArrowError> {
        let q = self.plant.geometry().inverse(&self.plant.state().0)?;
        let inc = ARROW_DRIVES.increment_m;
        Ok(q.map(|v| libm::round(v / inc) * inc))
    }
}

impl ArrowIo<f64> for DriveIo<'_> {
    fn read(&mut self, k: u64) -> Result<ArrowInputs<f64>, ArrowError> {
        (self.inject)(k, &mut self.drives);
        self.exchange();
        let drive_fault = match self.master.feedback() {
            Ok(Some(p)) => {
                self.joints_m = joints(&p);
                None
            }
            Ok(None) => Some(DriveFault::Stopped),
            Err(f) => Some(f),
        };
        Ok(ArrowInputs {
            joints_m: self.joints_m,
            table_rad: self.plant.read()?.turntable_rad,
            drive_fault,
        })
    }

    fn step(&mut self, outputs: &ArrowOutputs<f64>) -> Result<ArrowReading<f64>, ArrowError> {
        self.master.command(&forces(&outputs.forces_n));
        let applied = joints(&self.drives.forces_n());
        let reading = self.plant.step(&applied, outputs.torques_n_m)?;
        self.sample();
        self.drives.tick(self.period_s);
        Ok(ArrowReading {
            joints_m: self.encoders()?,
            turntable_rad: reading.turntable_rad,
        })
    }

    fn pose(&self) -> Pose<f64> {
        self.plant.state().0
    }
}
