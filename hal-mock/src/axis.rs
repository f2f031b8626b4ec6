//! A simulated linear-motor axis behind kerf's HAL traits: Hall counts out, force in.

use crate::hall_sensor::{HallSensor, HallSensorParams};
use crate::linear_motor::{LinearMotor, LinearMotorParams};
use kerf::hal::{SampleInputs, WriteOutputs};
use kerf::Real;

/// One axis: plant plus sensors, advanced by one period per force command.
#[derive(Clone, Debug)]
pub struct SimulatedAxis {
    /// The slider.
    pub motor: LinearMotor,
    /// Its Hall sensors.
    pub sensor: HallSensor,
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
        }
    }

    /// Advances the plant one period with `force_n` held.
    pub fn apply_force(&mut self, force_n: f64) {
        self.motor.step(force_n);
    }
}

impl SampleInputs<[[u16; 3]; 1]> for SimulatedAxis {
    fn sample(&mut self) -> [[u16; 3]; 1] {
        [self.sensor.sample(self.motor.position_m)]
    }
}

impl<T: Real> WriteOutputs<[T; 1]> for SimulatedAxis {
    /// Applies the force and advances the plant by one period.
    fn write(&mut self, force_n: &[T; 1]) {
        self.apply_force(force_n[0].to_f64());
    }
}
