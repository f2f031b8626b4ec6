//! A simulated delta robot behind kerf's HAL traits: the Lagrangian plant with one set
//! of Hall sensors per carriage. Nine Hall counts out, three forces in.

use crate::axis::SimulatedClock;
use crate::delta_plant::{DeltaPlant, DeltaPlantParams};
use crate::hall_sensor::{HallSensor, HallSensorParams};
use kerf::hal::{Monotonic, SampleInputs, WriteOutputs};
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
}

impl SimulatedDelta {
    /// The plant at rest at carriage positions `q_m`, 4 RK4 substeps per period of
    /// `ts_s`; carriage `k` has the sensors `sensors[k]`, noise seeded `seed + k`.
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
        })
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

impl<T: Real> WriteOutputs<[T; 3]> for SimulatedDelta {
    /// Applies the forces and advances the plant by one period.
    fn write(&mut self, force_n: &[T; 3]) {
        if self.error.is_none() {
            let force = Vector3::from(force_n.map(|f| f.to_f64()));
            self.error = self.plant.step(force).err();
        }
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
