//! The simulated ARROW (A 2.2.3, 3.2.1): the parallel module moved by the direct
//! dynamic model (eq. 20) under six actuator forces, the turntable by eq. 23, and the
//! encoders that measure them.
//!
//! The plant is built from its own geometry, which differs from the controller's model
//! by a geometric error (A 3.2.1: model inaccuracies, assembly errors): joint
//! references computed with the model then ask for joint positions no pose of the
//! plant meets exactly, and the part of the error outside Jm's column space is what
//! redundant actuators fight over. Forces are clipped at the actuators' limit (the
//! drives), the motion is integrated by RK4 in substeps of the control period, and
//! the encoders quantize: the linear actuators' scales (not printed; 1 µm, a common
//! incremental scale) and the turntable motors' 5,000 pulses per revolution (A 5.1)
//! counted in quadrature (20,000 counts per turn).

use kerf::kinematics::arrow::{
    ActuatorVector, ArrowConfig, ArrowDynamics, ArrowError, ArrowGeometry, ArrowMasses, Pose,
};
use kerf::{Float, Real};

/// Everything that makes a simulated ARROW.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowPlantConfig {
    /// The machine as built (the controller's model plus the geometric error).
    pub geometry: ArrowConfig,
    /// Masses and the actuators' force limit.
    pub masses: ArrowMasses,
    /// Control period, s.
    pub period_s: f64,
    /// RK4 substeps per period.
    pub substeps: u32,
    /// Linear encoder resolution, m.
    pub encoder_resolution_m: f64,
    /// Turntable encoder counts per turn.
    pub turntable_counts_per_turn: u32,
}

impl ArrowPlantConfig {
    /// ARROW integrated over control periods of `period_s` with the geometric error of an assembled machine:
    /// arm 1 0.2 mm long, arm 4 0.15 mm short, the top rail 0.3 mm high, the bottom
    /// one 0.1 mm towards the plate (each within a machine shop's assembly tolerance,
    /// and together about 0.2–0.3 mm of joint inconsistency).
    pub fn with_geometric_error(period_s: f64) -> Self {
        let mut geometry = ArrowConfig::ARROW;
        geometry.arms[0].length_m += 0.2e-3;
        geometry.arms[3].length_m -= 0.15e-3;
        geometry.arms[0].rail_z_m += 0.3e-3;
        geometry.arms[1].rail_z_m += 0.3e-3;
        geometry.arms[4].rail_y_m += 0.1e-3;
        geometry.arms[5].rail_y_m += 0.1e-3;
        Self {
            geometry,
            masses: ArrowMasses::ARROW,
            period_s,
            substeps: 4,
            encoder_resolution_m: 1e-6,
            turntable_counts_per_turn: 20_000,
        }
    }
}

/// The encoders' reading at the end of a period.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ArrowReading<T = f64> {
    /// Linear actuator positions, quantized, m.
    pub joints_m: ActuatorVector<T>,
    /// Turntable motor angles (q_T1 = θx, q_T2 = −θx, eq. 8), quantized, rad.
    pub turntable_rad: [T; 2],
}

/// The simulated machine, integrated in the scalar `T`: f64 on the host, f32 in the
/// emulated MCU's image (whose f64 is software floating point). In f32 the pose's
/// rounding near y = 0.5 m is 0.03 µm, well under the encoders' 1 µm.
#[derive(Clone, Debug)]
pub struct ArrowPlant<T: Float = f64> {
    config: ArrowPlantConfig,
    geometry: ArrowGeometry<T>,
    dynamics: ArrowDynamics<T>,
    turntable_inertia: T,
    force_limit_n: T,
    pose: Pose<T>,
    rate: Pose<T>,
    theta_x: T,
    theta_x_rate: T,
}

impl<T: Float> ArrowPlant<T> {
    /// At rest at `pose` with the table at `theta_x_rad`.
    pub fn new(
        config: &ArrowPlantConfig,
        pose: Pose<T>,
        theta_x_rad: T,
    ) -> Result<Self, ArrowError> {
        let geometry = ArrowGeometry::new(&config.geometry).map_err(|_| ArrowError::NotFinite)?;
        let arms = &config.geometry.arms;
        let dynamics = ArrowDynamics::new(&config.masses, arms[0].length_m, arms[2].length_m)
            .map_err(|_| ArrowError::NotFinite)?;
        geometry.inverse(&pose)?;
        Ok(Self {
            config: *config,
            geometry,
            dynamics,
            turntable_inertia: <T as Real>::from_f64(config.masses.turntable_inertia_kg_m2),
            force_limit_n: <T as Real>::from_f64(config.masses.actuator_force_limit_n),
            pose,
            rate: Pose::zeros(),
            theta_x: theta_x_rad,
            theta_x_rate: T::zero(),
        })
    }

    /// The true pose and rate (what the encoders only see through the joints).
    pub fn state(&self) -> (Pose<T>, Pose<T>) {
        (self.pose, self.rate)
    }

    /// The table's true angle, rad.
    pub fn theta_x_rad(&self) -> T {
        self.theta_x
    }

    /// The plant's own geometry.
    pub fn geometry(&self) -> &ArrowGeometry<T> {
        &self.geometry
    }

    /// One control period under `forces_n` (clipped at the limit) and the turntable
    /// motors' torques; returns the encoders at its end, or the error that stopped
    /// the model (the plate driven out of reach).
    pub fn step(
        &mut self,
        forces_n: &ActuatorVector<T>,
        torques_n_m: [T; 2],
    ) -> Result<ArrowReading<T>, ArrowError> {
        self.step_loaded(forces_n, torques_n_m, &Pose::zeros())
    }

    /// [`Self::step`] with an external wrench on the plate (N along x, y, z and N·m
    /// about z: a tool stalled in the workpiece, a collision), carried to the
    /// actuators' joints as the minimum-norm forces (Jmᵀ)⁺ w it loads them with.
    pub fn step_loaded(
        &mut self,
        forces_n: &ActuatorVector<T>,
        torques_n_m: [T; 2],
        load_n: &Pose<T>,
    ) -> Result<ArrowReading<T>, ArrowError> {
        let c = <T as Real>::from_f64;
        let limit = self.force_limit_n;
        // The minimum-norm joint forces of the load, solved only when there is one
        // (the dynamics below evaluate Jm again for the motion).
        let transmitted = if load_n.iter().all(|w| *w == T::zero()) {
            ActuatorVector::zeros()
        } else {
            let (_, jm) = self.geometry.jacobian(&self.pose)?;
            let normal = (jm.transpose() * jm)
                .try_inverse()
                .ok_or(ArrowError::PlateSingular)?;
            jm * (normal * load_n)
        };
        let forces = forces_n.map(|f| {
            if f.is_finite() {
                f.max(-limit).min(limit)
            } else {
                T::zero()
            }
        }) + transmitted;
        let h = c(self.config.period_s / f64::from(self.config.substeps.max(1)));
        let (half, two, sixth) = (h * c(0.5), c(2.0), h / c(6.0));
        let (g, d) = (&self.geometry, &self.dynamics);
        let f = |x: &Pose<T>, v: &Pose<T>| d.acceleration(g, x, v, &forces);
        for _ in 0..self.config.substeps.max(1) {
            let (x, v) = (self.pose, self.rate);
            let k1 = (v, f(&x, &v)?);
            let k2 = (v + k1.1 * half, f(&(x + k1.0 * half), &(v + k1.1 * half))?);
            let k3 = (v + k2.1 * half, f(&(x + k2.0 * half), &(v + k2.1 * half))?);
            let k4 = (v + k3.1 * h, f(&(x + k3.0 * h), &(v + k3.1 * h))?);
            self.pose += (k1.0 + k2.0 * two + k3.0 * two + k4.0) * sixth;
            self.rate += (k1.1 + k2.1 * two + k3.1 * two + k4.1) * sixth;
        }
        // Eq. 23–24: both motors turn the table, the second in the opposite sense.
        let torque = torques_n_m.map(|t| if t.is_finite() { t } else { T::zero() });
        let accel = (torque[0] - torque[1]) / self.turntable_inertia;
        let dt = c(self.config.period_s);
        self.theta_x += self.theta_x_rate * dt + c(0.5) * accel * dt * dt;
        self.theta_x_rate += accel * dt;
        self.read()
    }

    /// The encoders now (counted in f64: an f32 position divided by the 1 µm step
    /// would round to a neighbouring count).
    pub fn read(&self) -> Result<ArrowReading<T>, ArrowError> {
        let q = self.geometry.inverse(&self.pose)?;
        let lsb = self.config.encoder_resolution_m;
        let turn = core::f64::consts::TAU / f64::from(self.config.turntable_counts_per_turn);
        let quantize =
            |v: T, step: f64| <T as Real>::from_f64(libm::round(v.to_f64() / step) * step);
        Ok(ArrowReading {
            joints_m: q.map(|v| quantize(v, lsb)),
            turntable_rad: [quantize(self.theta_x, turn), quantize(-self.theta_x, turn)],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Held by the feedforward of its own model against gravity, the plant stays at
    /// rest (to the RK4 round-off); the encoders read its joints to their resolution.
    #[test]
    fn feedforward_of_the_plant_model_holds_it_still() {
        let config = ArrowPlantConfig::with_geometric_error(2e-4);
        let pose = Pose::new(0.1, 0.5, 0.0, 0.1);
        let mut plant = ArrowPlant::<f64>::new(&config, pose, 0.0).unwrap();
        let ff = plant
            .dynamics
            .feedforward(&plant.geometry, &pose, &Pose::zeros(), &Pose::zeros())
            .unwrap();
        let mut reading = None;
        for _ in 0..500 {
            reading = Some(plant.step(&ff.forces_n, [0.0, 0.0]).unwrap());
        }
        let (x, v) = plant.state();
        assert!((x - pose).amax() < 1e-9 && v.amax() < 1e-8, "{x:?} {v:?}");
        let q = plant.geometry.inverse(&pose).unwrap();
        assert!((reading.unwrap().joints_m - q).amax() <= 0.5e-6 + 1e-12);
    }

    /// Without force the plate falls at g (the actuators' carts ride along: the
    /// vertical acceleration is m_P g over the whole effective mass, below g).
    #[test]
    fn unsupported_plate_falls_and_the_table_turns() {
        let config = ArrowPlantConfig::with_geometric_error(2e-4);
        let mut plant =
            ArrowPlant::<f64>::new(&config, Pose::new(0.0, 0.5, 0.0, 0.0), 0.0).unwrap();
        for _ in 0..100 {
            plant
                .step(&ActuatorVector::zeros(), [1.204, -1.204])
                .unwrap();
        }
        let (x, v) = plant.state();
        assert!(v.z < 0.0 && v.z > -9.8 * 0.02, "{v:?}");
        assert!(x.z < 0.0);
        // θ̈x = (Γ1 − Γ2)/I_T = 2 rad/s² for 20 ms.
        assert!((plant.theta_x_rad() - 0.5 * 2.0 * 0.02 * 0.02).abs() < 1e-12);
    }
}
