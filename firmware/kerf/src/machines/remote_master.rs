//! The master of remote machining (T ch. 5, 8.3): the horizontal delta the operator
//! moves by hand, held on the contour by a virtual fixture, computing the slave's
//! commands over the delayed link.
//!
//! Each period, in the data flow's order:
//!
//! 1. Sensing: the carriages' 0.5 µm encoders (`sensing::encoder`), a tracking
//!    observer per carriage for q̇, the effector (x, ẋ) by FK and Jx.
//! 2. The fixture (`control::constraint`, docs/control.md §20, T 5.2): the constrained
//!    task acceleration ẍc and the projector P onto the constrained subspace. The
//!    carriages get q̈c = Jx⁻¹(ẍc − P J̇x q̇), and each carriage's disturbance observer
//!    runs as a monitor: its estimate d̂ (the operator's force, gravity, friction, the
//!    rest of the inertia, as joint forces) is compensated only in the constrained
//!    subspace, Jxᵀ P Jx⁻ᵀ d̂. Along the curve nothing resists or cancels the
//!    operator's push: the fixture is force-transparent there and stiff across it and
//!    in z.
//! 3. Haptics (T 9.2's future work): with the slave's beam at constant power the
//!    cut's depth goes as 1/speed; when the operator's speed along the curve leaves
//!    the band that keeps the energy per length inside its limits, a light force
//!    along the curve (gain × the speed's excursion, capped) pushes back towards the
//!    band.
//! 4. The slave's command (T 5.3.2, eq. 93–96): every `samples_per_command` periods,
//!    the tracking law (`control::bilateral`) on the master's state and the delay
//!    observer's estimate of the slave (`control::delay_observer`) gives the slave's
//!    task acceleration; the observer's model executes it every period. It goes out as
//!    this period's [`MasterOutputs::command`] with its tick, for the image to stream.
//!    The slave's reports (its position and the tick it was executing) correct the
//!    observer. [`SlaveEstimate`] chooses what the law closes on: kerf's observer, T's
//!    own network disturbance observer (`control::network_observer`, eq. 93–95: no
//!    ticks compared, no convergence term), or the newest report as it is (the
//!    comparison case, in which the round trip sits inside the loop).
//!
//! The slave's acceleration feedforward is left out of the law (the master's
//! acceleration would be the second difference of 0.5 µm counts); at the law's 5 Hz
//! poles this costs a tracking error of the slave's acceleration over λK, a few
//! micrometres on the scenarios' curves.

use crate::app::remote_link::{RemoteCommand, SlaveReport};
use crate::app::supervisor::NoSweep;
use crate::app::supervisor::{
    first_non_finite_index, FiniteOutputs, Machine, NonFiniteOutput, Step,
};
use crate::control::bilateral::{Bilateral, BilateralConfig, MasterState};
use crate::control::constraint::{Fixture, FixtureConfig, FixtureError};
use crate::control::delay_observer::{DelayObserver, DelayObserverConfig};
use crate::control::dob::{Dob, DobConfig, DobState};
use crate::control::network_observer::{NetworkObserver, NetworkObserverConfig};
use crate::error::{coefficient, positive, representable, ConfigContext, ConfigError};
use crate::kinematics::delta::{DeltaConfig, DeltaGeometry, KinematicsError};
use crate::scalar::{lit, Float, Real};
use crate::sensing::encoder::{Encoder, EncoderConfig, EncoderFault, EncoderState};
use crate::sensing::velocity::{TrackingObserver, TrackingObserverConfig, TrackingObserverState};
use crate::trajectory::constraint::{ConstraintConfig, MotionConstraint};
use crate::trajectory::ContourError;
use nalgebra::{Matrix3, Vector3};

pub mod link;
pub mod product;

/// Contour points a fixture job can carry.
pub const FIXTURE_POINTS: usize = 128;

/// Link samples of history the delay observer keeps: 512 ms at 1 kHz samples.
pub const OBSERVER_HISTORY: usize = 512;

/// The haptic band (item 3 of the module docs).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct HapticConfig {
    /// The operator's speed band along the curve, m/s (master speed: the slave moves
    /// at scale × this). `[lo, hi]`, 0 ≤ lo < hi.
    pub speed_band_m_s: [f64; 2],
    /// Force per unit of speed outside the band, N·s/m.
    pub gain_n_s_per_m: f64,
    /// Largest force rendered, N.
    pub max_force_n: f64,
}

/// Everything the master needs, in SI units.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct RemoteMasterConfig {
    /// Control period, s.
    pub period_s: f64,
    /// The master delta's geometry.
    pub delta: DeltaConfig,
    /// Each carriage's encoder.
    pub encoders: [EncoderConfig; 3],
    /// Carriage positions at power-up (the homing stops), m.
    pub home_m: [f64; 3],
    /// Velocity observer of each carriage.
    pub velocity: TrackingObserverConfig,
    /// Each carriage's disturbance observer (its `compensate` is ignored: the
    /// compensation is the projected one).
    pub dob: DobConfig,
    /// The fixture's poles across the curve and in z.
    pub fixture: FixtureConfig,
    /// How a contour's points become the fixture's windows.
    pub constraint: ConstraintConfig,
    /// The slave's tracking law: scale and centres, its poles.
    pub tracking: BilateralConfig,
    /// The delay observer's correction (its period is `period_s`), rad/s.
    pub observer_bandwidth_rad_s: f64,
    /// What the slave's law closes on.
    pub slave_estimate: SlaveEstimate,
    /// Control periods per link sample.
    pub samples_per_command: u32,
    /// The haptic band (`None`: off).
    pub haptic: Option<HapticConfig>,
}

/// The slave's state the tracking law uses (module docs, item 4).
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum SlaveEstimate {
    /// The newest report as it arrived: the round trip inside the loop.
    Newest,
    /// kerf's delay observer (`control::delay_observer`): the model compared with the
    /// reports at the ticks they echo, corrected at `observer_bandwidth_rad_s`.
    EchoedTicks,
    /// T's network disturbance observer (`control::network_observer`).
    NetworkDisturbance {
        /// Bandwidth of its filters, rad/s.
        bandwidth_rad_s: f64,
    },
}

/// Why the master stopped.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RemoteMasterFault {
    /// A carriage's encoder.
    Encoder {
        /// Carriage index.
        axis: u8,
        /// What it did.
        fault: EncoderFault,
    },
    /// The effector or its Jacobians could not be computed.
    Kinematics(KinematicsError),
    /// The effector is too far from the fixture's contour to evaluate it.
    Constraint(ContourError),
    /// The fixture's law has no output.
    Fixture(FixtureError),
    /// A non-finite value in the period (a force, an estimate).
    NotFinite,
}

/// Why a fixture job does not fit.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FixtureJobError {
    /// The empty default job.
    NoContour,
    /// The height is not finite.
    NotFinite,
}

/// A fixture session: the contour the operator follows, at a height, and whether the
/// slave's beam is to be on.
#[derive(Clone, Debug)]
pub struct FixtureJob<T: Float> {
    constraint: Option<MotionConstraint<T, FIXTURE_POINTS>>,
    z_m: f64,
    laser_on: bool,
}

impl<T: Float> Default for FixtureJob<T> {
    /// The empty job every master refuses.
    fn default() -> Self {
        Self {
            constraint: None,
            z_m: 0.0,
            laser_on: false,
        }
    }
}

impl<T: Float> FixtureJob<T> {
    /// The contour `points` (x, y in the master's frame, m), followed at height `z_m`.
    pub fn new(
        points: &[[f64; 2]],
        config: &ConstraintConfig,
        z_m: f64,
        laser_on: bool,
    ) -> Result<Self, ContourError> {
        if !z_m.is_finite() {
            return Err(ConfigError::not_finite("z_m").into());
        }
        Ok(Self {
            constraint: Some(MotionConstraint::new(points, config)?),
            z_m,
            laser_on,
        })
    }
}

/// One period's inputs.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct RemoteMasterInputs {
    /// The carriages' 16-bit encoder counters.
    pub encoder_counts: [u16; 3],
    /// The newest slave report that arrived this period.
    pub report: Option<SlaveReport>,
}

/// One period's outputs.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MasterOutputs<T> {
    /// Carriage forces, N.
    pub force_n: [T; 3],
    /// The slave's command to send this period, with its tick.
    pub command: Option<(u32, RemoteCommand)>,
}

/// One period's telemetry.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct MasterTelemetry<T> {
    /// The master's effector, m.
    pub effector_m: [T; 3],
    /// Its velocity, m/s.
    pub velocity_m_s: [T; 3],
    /// φ: the distance across the curve (signed) and below the height, m.
    pub constraint_m: [T; 2],
    /// The carriage forces of the period, N (zero while the fixture holds nothing).
    pub force_n: [T; 3],
    /// The haptic force along the curve, N.
    pub haptic_n: T,
    /// The observer's estimate of the slave, m (or the newest report without it).
    pub slave_estimate_m: Option<[T; 3]>,
    /// The tracking law's error at the newest command: the scaled master less the
    /// slave as [`MasterTelemetry::slave_estimate_m`] has it, m.
    pub tracking_error_m: [T; 3],
    /// The beam of the newest command sent.
    pub laser_on: bool,
    /// The round trip the newest echo showed, periods.
    pub round_trip_periods: u32,
    /// Reports the observer refused so far.
    pub rejected_reports: u32,
}

/// One carriage's state.
#[derive(Copy, Clone, Debug, PartialEq)]
struct Carriage<T: Float> {
    encoder: EncoderState,
    velocity: TrackingObserverState<T>,
    dob: DobState<T>,
    applied_acceleration: T,
}

/// The master as a [`Machine`].
#[derive(Clone, Debug)]
pub struct RemoteMaster<T: Float> {
    geometry: DeltaGeometry<T>,
    encoders: [Encoder<T>; 3],
    home_m: [T; 3],
    velocity: TrackingObserver<T>,
    dob: Dob<T>,
    inv_mass: T,
    fixture: Fixture<T>,
    tracking: Bilateral<T>,
    haptic: Option<(T, T, T, T)>,
    slave_estimate: SlaveEstimate,
    samples_per_command: u32,
    carriages: [Carriage<T>; 3],
    /// kerf's observer: it also counts the master's ticks, whichever estimate is used.
    observer: DelayObserver<T, OBSERVER_HISTORY>,
    /// T's observer, when [`SlaveEstimate::NetworkDisturbance`] is chosen, and
    /// whether it has started (at the first report of a command played).
    network_observer: Option<(NetworkObserver<T>, bool)>,
    /// The newest report (position, velocity); the observer starts from the first.
    measured_slave: Option<(Vector3<T>, Vector3<T>)>,
    observer_ready: bool,
    command: Vector3<T>,
    phase_in_sample: u32,
    telemetry: MasterTelemetry<T>,
}

impl<T: Float> RemoteMaster<T> {
    /// Validates `config`; a bad field is named with its path.
    pub fn new(config: &RemoteMasterConfig) -> Result<Self, ConfigError> {
        let ts = positive("period_s", config.period_s)?;
        let encoder = |k: usize, c: &EncoderConfig| {
            Encoder::new(c, ts)
                .within("encoders")
                .map_err(|e| e.indexed(k))
        };
        let [e0, e1, e2] = &config.encoders;
        let home_m = crate::error::representable_each::<T, 3>("home_m", config.home_m)?;
        let dob_config = DobConfig {
            compensate: false,
            ..config.dob
        };
        let haptic = match &config.haptic {
            None => None,
            Some(h) => {
                let [lo, hi] = h.speed_band_m_s;
                if !(lo >= 0.0 && hi > lo && hi.is_finite()) {
                    return Err(ConfigError::out_of_range("speed_band_m_s").within("haptic"));
                }
                let gain = positive("gain_n_s_per_m", h.gain_n_s_per_m).within("haptic")?;
                let max = positive("max_force_n", h.max_force_n).within("haptic")?;
                let scalar = |name, v| coefficient::<T>(name, v).within("haptic");
                Some((
                    representable::<T>("speed_band_m_s", lo).within("haptic")?,
                    scalar("speed_band_m_s", hi)?,
                    scalar("gain_n_s_per_m", gain)?,
                    scalar("max_force_n", max)?,
                ))
            }
        };
        if config.samples_per_command == 0 {
            return Err(ConfigError::out_of_range("samples_per_command"));
        }
        // The observer's only own setting is this config's observer bandwidth: name it so.
        let observer_bandwidth =
            positive("observer_bandwidth_rad_s", config.observer_bandwidth_rad_s)?;
        let observer = DelayObserver::new(
            &DelayObserverConfig {
                period_s: ts,
                correction_bandwidth_rad_s: observer_bandwidth,
            },
            Vector3::zeros(),
        )
        .map_err(|_| ConfigError::out_of_range("observer_bandwidth_rad_s"))?;
        let network_observer = match config.slave_estimate {
            SlaveEstimate::NetworkDisturbance { bandwidth_rad_s } => Some((
                NetworkObserver::new(
                    &NetworkObserverConfig {
                        period_s: ts,
                        bandwidth_rad_s,
                    },
                    Vector3::zeros(),
                )
                .within("slave_estimate")?,
                false,
            )),
            _ => None,
        };
        Ok(Self {
            geometry: DeltaGeometry::new(&config.delta).within("delta")?,
            encoders: [encoder(0, e0)?, encoder(1, e1)?, encoder(2, e2)?],
            home_m,
            velocity: TrackingObserver::new(&config.velocity, ts).within("velocity")?,
            dob: Dob::new(&dob_config, ts).within("dob")?,
            inv_mass: coefficient("nominal_mass_kg", 1.0 / config.dob.nominal_mass_kg)
                .within("dob")?,
            fixture: Fixture::new(&config.fixture).within("fixture")?,
            tracking: Bilateral::new(&config.tracking).within("tracking")?,
            haptic,
            slave_estimate: config.slave_estimate,
            samples_per_command: config.samples_per_command,
            carriages: home_m.map(|h| Carriage {
                encoder: EncoderState::unhomed(),
                velocity: TrackingObserverState::at_rest(h),
                dob: DobState::at(T::zero()),
                applied_acceleration: T::zero(),
            }),
            observer,
            network_observer,
            measured_slave: None,
            observer_ready: false,
            command: Vector3::zeros(),
            phase_in_sample: 0,
            telemetry: MasterTelemetry {
                effector_m: [T::zero(); 3],
                velocity_m_s: [T::zero(); 3],
                constraint_m: [T::zero(); 2],
                force_n: [T::zero(); 3],
                haptic_n: T::zero(),
                slave_estimate_m: None,
                tracking_error_m: [T::zero(); 3],
                laser_on: false,
                round_trip_periods: 0,
                rejected_reports: 0,
            },
        })
    }

    /// The geometry.
    pub fn geometry(&self) -> &DeltaGeometry<T> {
        &self.geometry
    }

    /// The slave's tracking law.
    pub fn tracking(&self) -> &Bilateral<T> {
        &self.tracking
    }

    /// Reads the encoders and tracks the carriages: (q, q̇), m and m/s.
    fn measure(
        &mut self,
        counts: &[u16; 3],
    ) -> Result<(Vector3<T>, Vector3<T>), RemoteMasterFault> {
        let mut q = Vector3::zeros();
        let mut q_dot = Vector3::zeros();
        for (k, (carriage, (encoder, (raw, home)))) in self
            .carriages
            .iter_mut()
            .zip(self.encoders.iter().zip(counts.iter().zip(self.home_m)))
            .enumerate()
        {
            let position = encoder
                .update(&mut carriage.encoder, *raw)
                .map_err(|fault| RemoteMasterFault::Encoder {
                    axis: k as u8,
                    fault,
                })?
                + home;
            let v = self.velocity.update(
                &mut carriage.velocity,
                position,
                carriage.applied_acceleration,
            );
            if let (Some(qk), Some(vk)) = (q.get_mut(k), q_dot.get_mut(k)) {
                *qk = position;
                *vk = v;
            }
        }
        Ok((q, q_dot))
    }

    /// The newest report: the observer's correction (or its start).
    fn take_report(&mut self, report: &Option<SlaveReport>) {
        let Some(r) = report else { return };
        let v = |a: [f32; 3]| Vector3::new(a[0], a[1], a[2]).map(|c| lit::<T>(f64::from(c)));
        let (position, velocity) = (v(r.position_m), v(r.velocity_m_s));
        if !(position
            .iter()
            .chain(velocity.iter())
            .all(|c| c.is_finite()))
        {
            return;
        }
        if self.observer_ready {
            if let Some(echo) = r.echo_tick {
                let _ = self.observer.received(echo, &position);
            }
        } else {
            self.observer.restart(position);
            self.observer_ready = true;
        }
        // T's observer assumes the slave and the estimate start equal (T 5.3.2) and has
        // no term that would make them so later: it starts at the first report of a
        // slave executing this master's commands (at rest at its start until then).
        if let Some((network, started)) = &mut self.network_observer {
            if *started {
                let _ = network.received(&position, &velocity);
            } else {
                // The slave reports only once it rests at its start: the estimate
                // starts there at rest (the measured velocity is that of a slave at
                // rest, and its noise would stay in the estimate).
                network.restart((position, velocity), (position, Vector3::zeros()));
                *started = true;
            }
        }
        self.measured_slave = Some((position, velocity));
    }

    /// The haptic force along the unit tangent for the speed `v_along` (signed).
    fn haptic_force(&self, v_along: T) -> T {
        let Some((lo, hi, gain, max)) = self.haptic else {
            return T::zero();
        };
        let speed = v_along.abs();
        let excursion = if speed > hi {
            speed - hi
        } else if speed < lo {
            speed - lo
        } else {
            return T::zero();
        };
        let sign = if v_along < T::zero() {
            -T::one()
        } else {
            T::one()
        };
        -(gain * excursion).max(-max).min(max) * sign
    }

    /// The fixture's period: the carriage forces.
    fn fixture_forces(
        &mut self,
        job: &FixtureJob<T>,
        q: &Vector3<T>,
        q_dot: &Vector3<T>,
    ) -> Result<(Vector3<T>, MasterState<T>), RemoteMasterFault> {
        let constraint = job
            .constraint
            .as_ref()
            .ok_or(RemoteMasterFault::Constraint(ContourError::TooFewPoints))?;
        let g = &self.geometry;
        let kinematics = RemoteMasterFault::Kinematics;
        let x = g.forward(q).map_err(kinematics)?;
        let jx = g.jacobian(q, &x).map_err(kinematics)?;
        let jx_inv = g.jacobian_inverse(q, &x).map_err(kinematics)?;
        let v = jx * q_dot;
        let jx_dot = g
            .jacobian_derivative(q, &x, q_dot)
            .map_err(RemoteMasterFault::Kinematics)?;
        let value = constraint
            .evaluate(x, lit(job.z_m))
            .map_err(RemoteMasterFault::Constraint)?;
        let out = self
            .fixture
            .task_acceleration(&value, &v)
            .map_err(RemoteMasterFault::Fixture)?;
        let p: Matrix3<T> = out.projector;
        let q_ddot = jx_inv * (out.constrained_acceleration - p * (jx_dot * q_dot));
        // The tangent: the in-plane gradient of φ₁ turned a quarter.
        let (gx, gy) = (value.jacobian.m11, value.jacobian.m12);
        let tangent = Vector3::new(-gy, gx, T::zero());
        let norm = tangent.norm();
        let tangent = if norm > T::zero() {
            tangent / norm
        } else {
            tangent
        };
        let haptic = self.haptic_force(v.dot(&tangent));
        let estimate = Vector3::from(self.carriages.map(|c| c.dob.estimate_n));
        let compensation = jx.transpose() * (p * (jx_inv.transpose() * estimate))
            + jx.transpose() * (tangent * haptic);
        self.telemetry.effector_m = [x.x, x.y, x.z];
        self.telemetry.velocity_m_s = [v.x, v.y, v.z];
        self.telemetry.constraint_m = [value.phi.x, value.phi.y];
        self.telemetry.haptic_n = haptic;
        let master = MasterState {
            position: x,
            velocity: v,
            acceleration: Vector3::zeros(),
        };
        Ok((q_ddot + compensation * self.inv_mass, master))
    }

    /// Each carriage's observer turns its acceleration into a force.
    fn actuate(
        &mut self,
        acceleration: &Vector3<T>,
        q_dot: &Vector3<T>,
    ) -> Result<[T; 3], RemoteMasterFault> {
        let mut forces = [T::zero(); 3];
        for ((carriage, force), (a, v)) in self
            .carriages
            .iter_mut()
            .zip(forces.iter_mut())
            .zip(acceleration.iter().zip(q_dot.iter()))
        {
            let out = self.dob.update(&mut carriage.dob, *a, *v);
            carriage.applied_acceleration = self.dob.applied_acceleration(&out);
            *force = out.force_n;
            if !(out.force_n + carriage.dob.estimate_n + carriage.applied_acceleration).is_finite()
            {
                return Err(RemoteMasterFault::NotFinite);
            }
        }
        Ok(forces)
    }

    /// The slave's command of this period, if one is due, for the master's `master`
    /// state (its acceleration left out: module docs). A command that is not finite
    /// as the link carries it (in `f32`: a finite `f64` beyond 3.4e38 is ∞ there) is
    /// never sent nor run by the observer's model: the period faults.
    fn slave_command(
        &mut self,
        master: &MasterState<T>,
        laser_on: bool,
    ) -> Result<Option<(u32, RemoteCommand)>, RemoteMasterFault> {
        if !self.observer_ready {
            return Ok(None);
        }
        let due = self.phase_in_sample == 0;
        if due {
            let slave = match (&self.slave_estimate, &self.network_observer) {
                (SlaveEstimate::Newest, _) => self.measured_slave,
                (SlaveEstimate::EchoedTicks, _) => Some(self.observer.estimate()),
                (SlaveEstimate::NetworkDisturbance { .. }, Some((network, true))) => {
                    Some(network.estimate())
                }
                (SlaveEstimate::NetworkDisturbance { .. }, _) => self.measured_slave,
            };
            if let Some((x, v)) = slave {
                let (command, error) = self.tracking.task_acceleration(master, &x, &v);
                if !command.iter().all(|a| (a.to_f64() as f32).is_finite()) {
                    return Err(RemoteMasterFault::NotFinite);
                }
                self.command = command;
                self.telemetry.slave_estimate_m = Some([x.x, x.y, x.z]);
                self.telemetry.tracking_error_m = [error.x, error.y, error.z];
            }
        }
        // The next phase without a remainder (`samples_per_command` ≥ 1, checked in
        // `new`; a comparison leaves no division by zero in the period).
        let next = self.phase_in_sample.saturating_add(1);
        self.phase_in_sample = if next >= self.samples_per_command {
            0
        } else {
            next
        };
        let tick = self.observer.step(&self.command);
        if let Some((network, true)) = &mut self.network_observer {
            network.step(&self.command);
        }
        if !due {
            return Ok(None);
        }
        self.observer.sent();
        self.telemetry.round_trip_periods = self.observer.round_trip_periods();
        self.telemetry.rejected_reports = self.observer.rejected();
        self.telemetry.laser_on = laser_on;
        let c = self.command.map(|a| a.to_f64() as f32);
        Ok(Some((
            tick,
            RemoteCommand {
                acceleration_m_s2: [c.x, c.y, c.z],
                laser_on,
            },
        )))
    }

    fn safe(&self) -> MasterOutputs<T> {
        MasterOutputs {
            force_n: [T::zero(); 3],
            command: None,
        }
    }
}

impl<T: Float> Machine for RemoteMaster<T> {
    type Inputs = RemoteMasterInputs;
    type Outputs = MasterOutputs<T>;
    type Job = FixtureJob<T>;
    type JobError = FixtureJobError;
    type Coefficients = Fixture<T>;
    type SweepSample = NoSweep;
    type Calibration = ();
    type Fault = RemoteMasterFault;
    type Telemetry = MasterTelemetry<T>;

    /// Zero force (the operator holds the handle), no command.
    fn safe_outputs(&self) -> MasterOutputs<T> {
        self.safe()
    }

    fn monitor(&mut self, inputs: &RemoteMasterInputs) -> Result<(), RemoteMasterFault> {
        let (q, q_dot) = self.measure(&inputs.encoder_counts)?;
        for c in &mut self.carriages {
            c.applied_acceleration = T::zero();
        }
        // The period's outputs are the safe ones: no force.
        self.telemetry.force_n = [T::zero(); 3];
        let (x, v) = self
            .geometry
            .task_state(&q, &q_dot)
            .map_err(RemoteMasterFault::Kinematics)?;
        self.telemetry.effector_m = [x.x, x.y, x.z];
        self.telemetry.velocity_m_s = [v.x, v.y, v.z];
        Ok(())
    }

    /// Encoders need no sweep.
    fn begin_calibration(&mut self) {}

    fn calibrate(
        &mut self,
        inputs: &RemoteMasterInputs,
        _: &mut dyn FnMut(NoSweep),
    ) -> Result<Step<MasterOutputs<T>>, RemoteMasterFault> {
        self.monitor(inputs)?;
        Ok(Step::Done(self.safe()))
    }

    fn finish_calibration(&mut self, _: &()) {}

    fn check_job(&self, job: &FixtureJob<T>) -> Result<(), FixtureJobError> {
        match job.constraint {
            None => Err(FixtureJobError::NoContour),
            Some(_) if !job.z_m.is_finite() => Err(FixtureJobError::NotFinite),
            Some(_) => Ok(()),
        }
    }

    fn begin_job(&mut self, job: &FixtureJob<T>) -> Result<(), FixtureJobError> {
        self.check_job(job)?;
        for c in &mut self.carriages {
            c.dob = DobState::at(c.velocity.velocity);
        }
        // The observer starts from the next report.
        self.observer_ready = false;
        self.measured_slave = None;
        self.command = Vector3::zeros();
        self.phase_in_sample = 0;
        self.telemetry.laser_on = false;
        Ok(())
    }

    fn run(
        &mut self,
        job: &FixtureJob<T>,
        inputs: &RemoteMasterInputs,
    ) -> Result<Step<MasterOutputs<T>>, RemoteMasterFault> {
        let (q, q_dot) = self.measure(&inputs.encoder_counts)?;
        self.take_report(&inputs.report);
        let (acceleration, master) = self.fixture_forces(job, &q, &q_dot)?;
        let force_n = self.actuate(&acceleration, &q_dot)?;
        self.telemetry.force_n = force_n;
        let command = self.slave_command(&master, job.laser_on)?;
        Ok(Step::Continue(MasterOutputs { force_n, command }))
    }

    /// No command goes out from here on: the beam's telemetry says so.
    fn begin_stop(&mut self) {
        self.telemetry.laser_on = false;
    }

    /// The fixture lets go at once (the operator holds the handle).
    fn stop(
        &mut self,
        _job: &Self::Job,
        inputs: &RemoteMasterInputs,
    ) -> Result<Step<MasterOutputs<T>>, RemoteMasterFault> {
        self.monitor(inputs)?;
        Ok(Step::Done(self.safe()))
    }

    fn set_coefficients(&mut self, fixture: &Fixture<T>) {
        self.fixture = *fixture;
    }

    /// The estimates restart where the carriages are. The encoders keep their count:
    /// after an encoder fault it is not trusted, and only a power-up at the homing
    /// stops re-homes them.
    fn reset(&mut self) {
        for c in &mut self.carriages {
            c.velocity = TrackingObserverState::at_rest(c.velocity.position);
            c.dob = DobState::at(T::zero());
            c.applied_acceleration = T::zero();
        }
        self.observer_ready = false;
    }

    fn telemetry(&self) -> MasterTelemetry<T> {
        self.telemetry
    }
}

/// The carriage forces 0–2, the slave command's accelerations 3–5 (f32, as sent).
impl<T: Real> FiniteOutputs for MasterOutputs<T> {
    fn first_not_finite(&self) -> Option<u8> {
        let command = self.command.map_or([0.0; 3], |(_, c)| c.acceleration_m_s2);
        first_non_finite_index(self.force_n)
            .or_else(|| first_non_finite_index(command).map(|i| i + 3))
    }
}

impl From<NonFiniteOutput> for RemoteMasterFault {
    fn from(_: NonFiniteOutput) -> Self {
        Self::NotFinite
    }
}
