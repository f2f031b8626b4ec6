//! A simulated linear-motor axis behind kerf's HAL traits: Hall counts out, force in.

use crate::hall_sensor::{HallSensor, HallSensorParams};
use crate::linear_motor::{LinearMotor, LinearMotorParams};
use kerf::hal::{ControlClock, ForceOutput, HallInput};

/// One axis: plant plus sensors, advanced by one period per force command.
#[derive(Clone, Debug)]
pub struct SimulatedAxis {
    /// The slider.
    pub motor: LinearMotor,
    /// Its Hall sensors.
    pub sensor: HallSensor,
    ts_s: f64,
}

impl SimulatedAxis {
    /// Plant integrated with 10 substeps per period (100 kHz at a 10 kHz loop).
    pub fn new(
        motor: LinearMotorParams,
        sensor: HallSensorParams,
        ts_s: f64,
        seed: u64,
        position_m: f64,
    ) -> Self {
        Self {
            motor: LinearMotor::new(motor, ts_s, 10, position_m),
            sensor: HallSensor::new(sensor, seed),
            ts_s,
        }
    }

    /// Advances the plant one period with `force_n` held.
    pub fn apply_force(&mut self, force_n: f64) {
        self.motor.step(force_n);
    }
}

impl HallInput for SimulatedAxis {
    fn hall_counts(&mut self, _axis: usize) -> [u16; 3] {
        let x = self.motor.position_m;
        self.sensor.sample(x)
    }
}

impl ForceOutput for SimulatedAxis {
    /// Applies the force and advances the plant by one period.
    fn set_force(&mut self, _axis: usize, force_n: f32) {
        self.apply_force(f64::from(force_n));
    }
}

impl ControlClock for SimulatedAxis {
    fn period_s(&self) -> f32 {
        self.ts_s as f32
    }
}
