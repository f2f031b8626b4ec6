//! A simulated linear-motor axis behind kerf's HAL traits: Hall counts out, force in.

use crate::hall_sensor::{HallSensor, HallSensorParams};
use crate::linear_motor::{LinearMotor, LinearMotorParams};
use kerf::hal::{Monotonic, SampleInputs, WriteOutputs};
use kerf::Real;

/// One axis: plant plus sensors, advanced by one period per force command.
#[derive(Clone, Debug)]
pub struct SimulatedAxis {
    /// The slider.
    pub motor: LinearMotor,
    /// Its Hall sensors.
    pub sensor: HallSensor,
    /// Simulated time, ns: one period per write.
    pub clock: SimulatedClock,
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
            clock: SimulatedClock::new(ts_s),
        }
    }

    /// Advances the plant one period with `force_n` held.
    pub fn apply_force(&mut self, force_n: f64) {
        self.motor.step(force_n);
        self.clock.advance();
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

impl Monotonic for SimulatedAxis {
    fn tick_hz(&self) -> u64 {
        self.clock.tick_hz()
    }
    fn now(&mut self) -> u64 {
        self.clock.now()
    }
}

/// Simulated time in nanoseconds, advanced one control period at a time (a board's
/// timer counts on its own; here time passes only as the plant is stepped).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct SimulatedClock {
    now_ns: u64,
    period_ns: u64,
}

impl SimulatedClock {
    /// Time 0, periods of `ts_s` (rounded to the nanosecond).
    pub fn new(ts_s: f64) -> Self {
        Self {
            now_ns: 0,
            period_ns: libm::round(ts_s * 1e9) as u64,
        }
    }

    /// One period later.
    pub fn advance(&mut self) {
        self.now_ns += self.period_ns;
    }

    /// Lets `ns` pass without a period (a stalled control interrupt).
    pub fn stall(&mut self, ns: u64) {
        self.now_ns += ns;
    }
}

impl Monotonic for SimulatedClock {
    fn tick_hz(&self) -> u64 {
        1_000_000_000
    }
    fn now(&mut self) -> u64 {
        self.now_ns
    }
}
