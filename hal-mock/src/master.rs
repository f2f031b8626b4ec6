//! The master delta behind its encoders: the Lagrangian plant with an operator's force
//! on the effector, and a 16-bit quadrature counter per carriage (T 7.1.1: 0.5 µm
//! linear encoders). The counter starts at an arbitrary register value at power-up,
//! counts whole steps of the resolution (the position truncated towards −∞, as a
//! quadrature decoder does) and wraps.

use crate::delta_plant::{DeltaPlant, DeltaPlantParams};
use kerf::kinematics::delta::{DeltaConfig, KinematicsError};
use kerf::kinematics::Vector3;

/// Carriage forces in, encoder counts out, one period per step.
#[derive(Clone, Debug)]
pub struct SimulatedMaster {
    /// The mechanism; its `effector_force_n` is the operator's hand.
    pub plant: DeltaPlant,
    /// The first error of the plant's integration; the plant stands still from then on.
    pub error: Option<KinematicsError>,
    resolution_m: f64,
    home_m: Vector3<f64>,
    register_at_home: [u16; 3],
}

impl SimulatedMaster {
    /// The plant at rest at the carriage positions `home_m` (where the counters read
    /// `register_at_home`), 4 RK4 substeps per period of `ts_s`, encoders of
    /// `resolution_m`.
    pub fn new(
        config: &DeltaConfig,
        params: DeltaPlantParams,
        ts_s: f64,
        home_m: [f64; 3],
        resolution_m: f64,
        register_at_home: [u16; 3],
    ) -> Result<Self, KinematicsError> {
        let home = Vector3::from(home_m);
        Ok(Self {
            plant: DeltaPlant::new(config, params, ts_s, 4, home)?,
            error: None,
            resolution_m,
            home_m: home,
            register_at_home,
        })
    }

    /// The counters now.
    pub fn counts(&self) -> [u16; 3] {
        let mut counts = self.register_at_home;
        for (c, (q, home)) in counts
            .iter_mut()
            .zip(self.plant.q_m.iter().zip(self.home_m.iter()))
        {
            let steps = libm::floor((q - home) / self.resolution_m) as i64;
            *c = c.wrapping_add(steps as u16);
        }
        counts
    }

    /// Applies the forces for one period (the operator's force as set on the plant).
    pub fn step(&mut self, force_n: [f64; 3]) {
        if self.error.is_none() {
            self.error = self.plant.step(Vector3::from(force_n)).err();
        }
    }
}
