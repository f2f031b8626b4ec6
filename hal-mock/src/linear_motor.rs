//! Linear motor plant: m ẍ = F_motor − b ẋ − Fc sgn(ẋ) + F_load.
//!
//! The force command is held over a control period (zero-order hold) and the motion is
//! integrated in substeps, each solved exactly for the linear part (constant force,
//! viscous decay e^(−b h / m)) so the only approximation is where Coulomb friction
//! changes sign: a substep whose velocity would cross zero ends at rest, and the slider
//! stays stuck while the net applied force is within the Coulomb level (stiction).

/// Physical parameters of a linear motor axis.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct LinearMotorParams {
    /// Total moving mass in kg (slider plus payload).
    pub mass_kg: f64,
    /// Force constant in N/A (for reporting current; the plant takes force).
    pub force_constant_n_per_a: f64,
    /// Coulomb friction level in N.
    pub coulomb_n: f64,
    /// Viscous friction in N·s/m.
    pub viscous_n_s_per_m: f64,
    /// Continuous force limit in N; commands are clipped here (driver current limit).
    pub force_limit_n: f64,
}

impl LinearMotorParams {
    /// Faulhaber LM1247 class: 71 g slider plus a 50 g payload (a delta carriage and its
    /// arm share), 3.6 N continuous force. Friction of a sleeve-bearing slider: 0.08 N
    /// Coulomb, 0.5 N·s/m viscous. Force constant 9.9 N/A (LM1247-020 class).
    pub const LM1247_WITH_PAYLOAD: Self = Self {
        mass_kg: 0.121,
        force_constant_n_per_a: 9.9,
        coulomb_n: 0.08,
        viscous_n_s_per_m: 0.5,
        force_limit_n: 3.6,
    };
}

/// State of the simulated slider.
#[derive(Clone, Debug)]
pub struct LinearMotor {
    params: LinearMotorParams,
    substeps: u32,
    h_s: f64,
    decay: f64,
    /// Position in m.
    pub position_m: f64,
    /// Velocity in m/s.
    pub velocity_m_s: f64,
    /// External load force in N (a disturbance the controller does not know).
    pub load_force_n: f64,
    applied_force_n: f64,
}

impl LinearMotor {
    /// A slider at rest at `position_m`, integrated with `substeps` per period of `ts_s`.
    pub fn new(params: LinearMotorParams, ts_s: f64, substeps: u32, position_m: f64) -> Self {
        let substeps = substeps.max(1);
        let h_s = ts_s / f64::from(substeps);
        Self {
            params,
            substeps,
            h_s,
            decay: libm::exp(-params.viscous_n_s_per_m * h_s / params.mass_kg),
            position_m,
            velocity_m_s: 0.0,
            load_force_n: 0.0,
            applied_force_n: 0.0,
        }
    }

    /// Parameters in use.
    pub fn params(&self) -> &LinearMotorParams {
        &self.params
    }

    /// Motor force actually applied during the last period (after the driver limit).
    pub fn applied_force_n(&self) -> f64 {
        self.applied_force_n
    }

    /// Advances one control period with the force command held.
    pub fn step(&mut self, force_cmd_n: f64) {
        let p = self.params;
        let force = if force_cmd_n.is_finite() {
            force_cmd_n.clamp(-p.force_limit_n, p.force_limit_n)
        } else {
            0.0
        };
        self.applied_force_n = force;
        let drive = force + self.load_force_n;
        for _ in 0..self.substeps {
            let v0 = self.velocity_m_s;
            if v0 == 0.0 && libm::fabs(drive) <= p.coulomb_n {
                continue; // stuck
            }
            let direction = if v0 != 0.0 {
                v0.signum()
            } else {
                drive.signum()
            };
            let net = drive - p.coulomb_n * direction;
            // Exact solution of m v̇ = net − b v over h (b > 0), or uniform acceleration.
            let (v1, dx) = if p.viscous_n_s_per_m > 0.0 {
                let v_inf = net / p.viscous_n_s_per_m;
                let v1 = v_inf + (v0 - v_inf) * self.decay;
                let tau = p.mass_kg / p.viscous_n_s_per_m;
                (
                    v1,
                    v_inf * self.h_s + (v0 - v_inf) * tau * (1.0 - self.decay),
                )
            } else {
                let a = net / p.mass_kg;
                (
                    v0 + a * self.h_s,
                    v0 * self.h_s + 0.5 * a * self.h_s * self.h_s,
                )
            };
            if v1 * direction < 0.0 {
                // Velocity reached zero inside the substep: stop there (friction reverses).
                // The time to stop is approximated by linear interpolation of v.
                let frac = v0 / (v0 - v1);
                self.position_m += 0.5 * v0 * frac * self.h_s;
                self.velocity_m_s = 0.0;
            } else {
                self.position_m += dx;
                self.velocity_m_s = v1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frictionless(mass: f64, viscous: f64) -> LinearMotorParams {
        LinearMotorParams {
            mass_kg: mass,
            force_constant_n_per_a: 1.0,
            coulomb_n: 0.0,
            viscous_n_s_per_m: viscous,
            force_limit_n: 10.0,
        }
    }

    #[test]
    fn constant_force_matches_the_closed_form() {
        // x(t) = F t² / 2m without friction; with viscous friction
        // x(t) = (F/b) (t − τ (1 − e^(−t/τ))), τ = m/b.
        let mut m = LinearMotor::new(frictionless(0.1, 0.0), 1e-4, 10, 0.0);
        for _ in 0..1000 {
            m.step(0.5);
        }
        assert!((m.position_m - 0.5 * 0.5 / 0.1 * 0.01).abs() < 1e-12);
        let mut m = LinearMotor::new(frictionless(0.1, 2.0), 1e-4, 10, 0.0);
        for _ in 0..1000 {
            m.step(0.5);
        }
        let tau: f64 = 0.05;
        let x = 0.5 / 2.0 * (0.1 - tau * (1.0 - (-0.1f64 / tau).exp()));
        assert!((m.position_m - x).abs() < 1e-12, "{} vs {x}", m.position_m);
    }

    #[test]
    fn coulomb_friction_holds_and_stops_the_slider() {
        let mut p = LinearMotorParams::LM1247_WITH_PAYLOAD;
        p.viscous_n_s_per_m = 0.0;
        let mut m = LinearMotor::new(p, 1e-4, 10, 0.0);
        for _ in 0..1000 {
            m.step(0.9 * p.coulomb_n);
        }
        assert_eq!(m.position_m, 0.0);
        // Coasting from 0.1 m/s with only Coulomb friction stops after v²m/(2Fc).
        m.velocity_m_s = 0.1;
        for _ in 0..20_000 {
            m.step(0.0);
        }
        let d = 0.1 * 0.1 * p.mass_kg / (2.0 * p.coulomb_n);
        assert_eq!(m.velocity_m_s, 0.0);
        assert!(
            (m.position_m - d).abs() < 1e-6 * d + 1e-9,
            "{} vs {d}",
            m.position_m
        );
    }

    #[test]
    fn command_is_clipped_to_the_continuous_limit() {
        let mut m = LinearMotor::new(LinearMotorParams::LM1247_WITH_PAYLOAD, 1e-4, 1, 0.0);
        m.step(50.0);
        assert_eq!(m.applied_force_n(), 3.6);
        m.step(f64::NAN);
        assert_eq!(m.applied_force_n(), 0.0);
    }
}
