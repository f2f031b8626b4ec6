//! The motor the FOC tests drive: three phases integrated one by one (shared by the
//! current loop's tests and the commissioning's).

use super::MotorWindings;
use core::f64::consts::PI;

/// The PWM period of the tests, s (20 kHz).
pub(super) const TS: f64 = 1.0 / 20_000.0;

/// The motor as the test's reference: three phases in a star, each L di/dt = V_x − V_n
/// − R i − e_x with e_x = −(2/3)·K_f·v·sin(θ − 2πk/3), the leg's average voltage its
/// duty times the bus less the dead time in the direction of its current, the
/// neutral where the currents sum to zero. Integrated by RK4 in 20 steps a period,
/// the duties of a sample applied from half a period after it (the next PWM
/// period), the previous ones until then.
pub(super) struct Motor {
    pub currents: [f64; 3],
    pub position_m: f64,
    pub speed_m_s: f64,
    pub windings: MotorWindings,
    pub dead_time_s: f64,
    pub bus: f64,
}

impl Motor {
    pub fn theta(&self) -> f64 {
        2.0 * PI * self.position_m / self.windings.pitch_m
    }

    fn derivative(&self, i: [f64; 3], position: f64, duties: [f64; 3]) -> [f64; 3] {
        let w = &self.windings;
        let theta = 2.0 * PI * position / w.pitch_m;
        let k_e = 2.0 / 3.0 * w.force_constant_n_per_a;
        let legs: [f64; 3] = core::array::from_fn(|x| {
            let lost = self.dead_time_s / TS * i[x].signum();
            (duties[x] - lost).clamp(0.0, 1.0) * self.bus
        });
        let e: [f64; 3] = core::array::from_fn(|x| {
            -k_e * self.speed_m_s * libm::sin(theta - 2.0 * PI * x as f64 / 3.0)
        });
        // The neutral: Σ di/dt = 0 and Σ e = 0.
        let neutral = (legs[0] + legs[1] + legs[2]) / 3.0;
        core::array::from_fn(|x| {
            (legs[x] - neutral - w.resistance_ohm * i[x] - e[x]) / w.inductance_h
        })
    }

    pub fn run(&mut self, duration: f64, duties: [f64; 3]) {
        let n = 10;
        let h = duration / n as f64;
        for _ in 0..n {
            let p = self.position_m;
            let v = self.speed_m_s;
            let add = |a: [f64; 3], b: [f64; 3], s: f64| {
                core::array::from_fn::<f64, 3, _>(|x| a[x] + s * b[x])
            };
            let k1 = self.derivative(self.currents, p, duties);
            let k2 = self.derivative(add(self.currents, k1, h / 2.0), p + v * h / 2.0, duties);
            let k3 = self.derivative(add(self.currents, k2, h / 2.0), p + v * h / 2.0, duties);
            let k4 = self.derivative(add(self.currents, k3, h), p + v * h, duties);
            self.currents = core::array::from_fn(|x| {
                self.currents[x] + h / 6.0 * (k1[x] + 2.0 * k2[x] + 2.0 * k3[x] + k4[x])
            });
            self.position_m += v * h;
        }
    }

    /// The true i_q (Park of the motor's currents at its true angle).
    pub fn i_dq(&self) -> (f64, f64) {
        let theta = self.theta();
        let [a, b, c] = self.currents;
        let alpha = (2.0 * a - b - c) / 3.0;
        let beta = (b - c) / 3f64.sqrt();
        (
            libm::cos(theta) * alpha + libm::sin(theta) * beta,
            libm::cos(theta) * beta - libm::sin(theta) * alpha,
        )
    }
}
