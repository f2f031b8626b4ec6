//! A simulated delta robot behind kerf's HAL traits: the Lagrangian plant with one set
//! of Hall sensors per carriage. Nine Hall counts out, three forces and the laser's PWM
//! duty in; the forces go through the plant's drive (`DeltaPlantParams::drive`: DAC,
//! current loop, ripple), so what the controller writes and what acts on the rails can
//! differ. The laser's duty is held for the period and read back by the scenario.

use crate::axis::SimulatedClock;
use crate::delta_plant::{DeltaPlant, DeltaPlantParams};
use crate::hall_sensor::{HallSensor, HallSensorParams};
use kerf::hal::{ForceAndLaser, Monotonic, SampleInputs, WriteOutputs};
use kerf::kinematics::delta::{DeltaConfig, KinematicsError};
use kerf::kinematics::Vector3;
use kerf::Real;

/// Carriage forces in, Hall counts of every carriage out, one period per write.
#[derive(Clone, Debug)]
pub struct SimulatedDelta {
    /// The mechanism.
    pub plant: DeltaPlant,
    /// The Hall sensors of each carriage (each with its own noise seed).
    pub sensors: [HallSensor; 3],
    /// The first error of the plant's integration (the motion left the region where
    /// the mechanism assembles); the plant stands still from then on.
    pub error: Option<KinematicsError>,
    /// Simulated time, ns: one period per write.
    pub clock: SimulatedClock,
    /// The laser's PWM duty over the last period, as written (a duty outside [0, 1]
    /// or NaN is kept as written, for the scenario to catch).
    pub laser_duty: f64,
}

impl SimulatedDelta {
    /// The plant at rest at carriage positions `q_m`, 4 RK4 substeps (or more, as the
    /// plant's friction needs) per period of `ts_s`; carriage `k` has the sensors
    /// `sensors[k]`, noise seeded `seed + k`.
    pub fn new(
        config: &DeltaConfig,
        plant: DeltaPlantParams,
        sensors: [HallSensorParams; 3],
        ts_s: f64,
        seed: u64,
        q_m: [f64; 3],
    ) -> Result<Self, KinematicsError> {
        Ok(Self {
            plant: DeltaPlant::new(config, plant, ts_s, 4, Vector3::from(q_m))?,
            sensors: [(sensors[0], 0), (sensors[1], 1), (sensors[2], 2)]
                .map(|(params, k)| HallSensor::new(params, seed + k)),
            error: None,
            clock: SimulatedClock::new(ts_s),
            laser_duty: 0.0,
        })
    }

    /// Forces the controller wrote for the last period, N per carriage.
    pub fn commanded_force_n(&self) -> [f64; 3] {
        self.plant.commanded_force_n().into()
    }

    /// Forces that acted along the rails over the last period (mean, after the limit
    /// and the drive), N per carriage.
    pub fn applied_force_n(&self) -> [f64; 3] {
        self.plant.applied_force_n().into()
    }
}

impl SampleInputs<[[u16; 3]; 3]> for SimulatedDelta {
    fn sample(&mut self) -> [[u16; 3]; 3] {
        let mut counts = [[0; 3]; 3];
        for ((c, sensor), q) in counts
            .iter_mut()
            .zip(self.sensors.iter_mut())
            .zip(self.plant.q_m.iter())
        {
            *c = sensor.sample(*q);
        }
        counts
    }
}

impl<T: Real> WriteOutputs<ForceAndLaser<T, 3>> for SimulatedDelta {
    /// Applies the forces, holds the laser's duty and advances the plant by one period.
    fn write(&mut self, outputs: &ForceAndLaser<T, 3>) {
        if self.error.is_none() {
            let force = Vector3::from(outputs.force_n.map(|f| f.to_f64()));
            self.error = self.plant.step(force).err();
        }
        self.laser_duty = outputs.laser_duty.to_f64();
        self.clock.advance();
    }
}

impl Monotonic for SimulatedDelta {
    fn tick_hz(&self) -> u64 {
        self.clock.tick_hz()
    }
    fn now(&mut self) -> u64 {
        self.clock.now()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kerf::kinematics::delta::Root;

    fn delta(params: DeltaPlantParams) -> SimulatedDelta {
        let mut c = DeltaConfig::SLAVE_KEOPS;
        c.fk_root = Root::Minus;
        for a in c.actuators.iter_mut() {
            a.travel_min_m = -0.03;
            a.travel_max_m = 0.06;
        }
        let sensors = [HallSensorParams::LM1247_16BIT; 3];
        SimulatedDelta::new(&c, params, sensors, 1e-4, 1, [0.012, 0.006, 0.0]).unwrap()
    }

    #[test]
    fn reports_the_commanded_and_the_applied_force() {
        let written = ForceAndLaser {
            force_n: [1.0f32, f32::NAN, 10.0],
            laser_duty: 0.25,
        };
        // Ideal drive: the command after the limit acts (NaN → 0, 10 → 3.6 N).
        let mut d = delta(DeltaPlantParams::SLAVE);
        d.write(&written);
        assert_eq!(d.applied_force_n(), [1.0, 0.0, 3.6]);
        assert_eq!(d.laser_duty, 0.25);
        let c = d.commanded_force_n();
        assert!(c[0] == 1.0 && c[1].is_nan() && c[2] == 10.0);
        // Realistic drive: over the first period the 2 kHz current loop delivers on
        // average 1 − (τ/T)(1 − e^(−T/τ)) = 0.43 of the 1 N step (the ripple adds at
        // most 2 % of that plus 15 mN).
        let mut d = delta(DeltaPlantParams::SLAVE_REALISTIC);
        d.write(&written);
        let tau = DeltaPlantParams::SLAVE_REALISTIC.drive.current_tau_s();
        let mean = 1.0 - tau / 1e-4 * (1.0 - libm::exp(-1e-4 / tau));
        let applied = d.applied_force_n();
        assert!(
            (applied[0] - mean).abs() < 0.02 * mean + 0.015 + 1e-4,
            "{applied:?}"
        );
        assert!(applied[1].abs() <= 0.015 + 1e-9, "{applied:?}");
        assert!(applied[2] > 1.0 && applied[2] < 3.6, "{applied:?}");
        assert_eq!(d.commanded_force_n()[0], 1.0);
    }
}
