//! Linear delta robot plant: three prismatic carriages driving one translating
//! effector through three arms (geometry of `kerf::kinematics::delta`, T ch. 6).
//!
//! Model (Lagrange with the loop closure p = FK(q) as a holonomic constraint, so the
//! generalized coordinates are the carriage displacements q and ṗ = Jx q̇):
//!
//!   T = ½ q̇ᵀ Mc q̇ + ½ me |ṗ|²,   V = −g · (mc Σ Ci + me p)
//!   ⇒ (Mc + me Jxᵀ Jx) q̈ = F − b q̇ − Fc tanh(q̇/vs) + mc (g · ui) + Jxᵀ me g
//!                          − me Jxᵀ J̇x q̇,
//!
//! where the velocity-product term is the Coriolis/centripetal force of the effector
//! seen at the carriages, ui the rail directions and g = (0, 0, gz) gravity along the
//! base z axis. Arms are massless; an arm's mass ma is lumped half at each end
//! (mc += ma/2, me += 3 ma/2), which keeps every arm's mass and centre of mass and
//! neglects its rotational inertia (ma la²/12, small for slender arms). A payload on
//! the effector adds to me (mass matrix and gravity alike; the effector only
//! translates, so its inertia tensor never enters). Masses and force limits of the
//! presets are from T 7.1.1–7.1.2.
//!
//! Every force on q acts along a carriage's own rail, so it enters the generalized
//! force unchanged: the motor force F from the drive (`crate::drive`: DAC, current
//! loop, ripple in the carriage's own q) and the friction of the carriage's bearings,
//! viscous b q̇ plus Coulomb Fc regularized as Fc tanh(q̇/vs). The regularization
//! replaces stiction by a steep viscous slope Fc/vs around rest, so a carriage pushed
//! below Fc creeps at vs atanh(F/Fc) instead of sticking; vs is chosen far below every
//! intended speed (see [`DeltaPlantParams::SLAVE_REALISTIC`]).
//!
//! Integration: classical fourth-order Runge–Kutta in joint coordinates with the force
//! command held over a control period (zero-order hold) and `substeps` steps per
//! period. The current loop's output is not approximated: within a substep it is the
//! exact solution of its first-order lag with the command held, evaluated at each RK4
//! stage's time. The effector is always computed by FK from q, so the loop closure
//! holds to rounding at every instant; RK4 has local error O(h⁵), which at h ≤ 1e-4 s
//! and the plant's modes (≤ 100 Hz without control) keeps the energy error far below
//! what any test of a controller can see (measured in
//! `energy_is_conserved_without_input`). The friction's slope near rest is stiff
//! (Fc/(vs mc) ≈ 1.1e4 /s for the realistic slave), so the plant raises the substep
//! count until h (Fc/vs + b)/mc ≤ [`MAX_FRICTION_STEP`]; the largest eigenvalue of
//! M⁻¹ times the friction slope is at most that, since M ≥ mc I. A symplectic scheme
//! (implicit midpoint) would need an iterated FK per stage.

use crate::drive::DriveParams;
use kerf::kinematics::delta::{DeltaConfig, DeltaGeometry, KinematicsError};
use kerf::kinematics::{Matrix3, Vector3};

/// Largest product of the substep and the friction's stiffness, h (Fc/vs + b)/mc, the
/// plant integrates with: RK4 is stable up to 2.79 on a decaying mode, and at 0.5 its
/// error per step on that mode is (0.5)⁵/120 ≈ 3e-4 of what is left of it.
pub const MAX_FRICTION_STEP: f64 = 0.5;

/// Mass, friction and drive parameters of a delta plant.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DeltaPlantParams {
    /// Moving mass of each carriage (motor slider plus its share of fixings) in kg.
    pub carriage_mass_kg: f64,
    /// Effector mass in kg.
    pub effector_mass_kg: f64,
    /// Mass of each arm in kg, lumped half at each end.
    pub arm_mass_kg: f64,
    /// Continuous force limit per motor in N; commands are clipped here.
    pub force_limit_n: f64,
    /// Viscous friction per carriage in N·s/m.
    pub viscous_n_s_per_m: f64,
    /// Coulomb friction per carriage in N, along its rail: Fc tanh(q̇/vs).
    pub coulomb_n: f64,
    /// Regularization velocity vs of the Coulomb friction in m/s (> 0 whenever
    /// `coulomb_n` is).
    pub coulomb_velocity_m_s: f64,
    /// Payload carried by the effector in kg (workpiece and holder), which the
    /// controller's model does not include.
    pub payload_kg: f64,
    /// Gravity component along the base +z axis in m/s² (−9.81 with z up).
    pub gravity_z_m_s2: f64,
    /// The motor drives: DAC, current loop, force ripple.
    pub drive: DriveParams,
}

impl DeltaPlantParams {
    /// Horizontal master (T 7.1.1): 335 g per motor, 164 g effector (the thesis gives
    /// these as totals, so arms are taken as included), 10 N continuous. No friction
    /// (set it per test), no payload, ideal drive; z up.
    pub const MASTER: Self = Self {
        carriage_mass_kg: 0.335,
        effector_mass_kg: 0.164,
        arm_mass_kg: 0.0,
        force_limit_n: 10.0,
        viscous_n_s_per_m: 0.0,
        coulomb_n: 0.0,
        coulomb_velocity_m_s: 0.0,
        payload_kg: 0.0,
        gravity_z_m_s2: -9.81,
        drive: DriveParams::IDEAL,
    };

    /// Keops slave (T 7.1.2): 71 g per motor, 68 g effector, 3.6 N continuous; z up.
    /// Frictionless, no payload, ideal drive.
    pub const SLAVE: Self = Self {
        carriage_mass_kg: 0.071,
        effector_mass_kg: 0.068,
        arm_mass_kg: 0.0,
        force_limit_n: 3.6,
        viscous_n_s_per_m: 0.0,
        coulomb_n: 0.0,
        coulomb_velocity_m_s: 0.0,
        payload_kg: 0.0,
        gravity_z_m_s2: -9.81,
        drive: DriveParams::IDEAL,
    };

    /// The Keops slave as the real robot is: [`DeltaPlantParams::SLAVE`]'s masses and
    /// limit plus
    ///
    /// - Coulomb friction 0.08 N and viscous 0.5 N·s/m per carriage: the LM1247's
    ///   slider runs in sleeve bearings, and these are the values of
    ///   `LinearMotorParams::LM1247_WITH_PAYLOAD` (≈2 % of the continuous force,
    ///   the order of a polymer sleeve bearing under the light side load of the arms).
    ///   Assumptions: T gives no friction figures. The arms' ruby-ball joints
    ///   (T 7.1.2, "very low friction between aluminum and ruby") turn under small
    ///   moment arms and are neglected.
    /// - vs = 0.1 mm/s: the width of the Coulomb law's transition, far below the
    ///   slave's contouring speeds (tens of mm/s) so the friction reverses as sharply
    ///   as a controller can see; a carriage held at half of Fc creeps at
    ///   vs atanh(0.5) = 55 µm/s. Stiffness Fc/(vs mc) = 1.1e4 /s: at the 10 kHz loop
    ///   with 4 substeps (`SimulatedDelta`), h k = 0.28 (the plant adds substeps past
    ///   0.5).
    /// - Payload 20 g: the slave carries the workpiece under the fixed laser head
    ///   (T 7.1.3; wood and fibreglass sheets, T 8.2.2). A 40 × 40 mm sheet of a few
    ///   mm (≈5 g) on an aluminium holder plate (≈15 g) is the assumed order, 30 % of
    ///   the 68 g effector.
    /// - Drive [`DriveParams::LM1247_DS1103`]: 16-bit DAC, 2 kHz current loop,
    ///   commutation, current-offset and detent ripple.
    pub const SLAVE_REALISTIC: Self = Self {
        viscous_n_s_per_m: 0.5,
        coulomb_n: 0.08,
        coulomb_velocity_m_s: 1e-4,
        payload_kg: 0.020,
        drive: DriveParams::LM1247_DS1103,
        ..Self::SLAVE
    };
}

/// Simulated delta robot (f64 reference).
#[derive(Clone, Debug)]
pub struct DeltaPlant {
    geometry: DeltaGeometry<f64>,
    params: DeltaPlantParams,
    /// Generalized gravity on each carriage, mc g · ui, in N.
    carriage_gravity_n: Vector3<f64>,
    substeps: u32,
    h_s: f64,
    /// Carriage displacements q in m.
    pub q_m: Vector3<f64>,
    /// Carriage velocities q̇ in m/s.
    pub q_dot_m_s: Vector3<f64>,
    /// An external force on the effector (an operator's hand on the master), N in the
    /// base frame; held over each step. It acts on the carriages as Jxᵀ F.
    pub effector_force_n: Vector3<f64>,
    /// Current loops' outputs (current × force constant) in N.
    drive_force_n: Vector3<f64>,
    commanded_force_n: Vector3<f64>,
    applied_force_n: Vector3<f64>,
    /// The carriages' mechanical end stops, m: [`END_STOP_INSET_M`] inside each
    /// actuator's kinematic travel.
    end_stops_m: [(f64, f64); 3],
}

/// How far inside the kinematic travel the end stops sit, m: a carriage that rests on
/// one (unpowered, under gravity) keeps the RK4 stages' overshoot of a few nanometres
/// inside the travel the kinematics accept.
pub const END_STOP_INSET_M: f64 = 0.5e-3;

/// Time derivative of the state (q̇, q̈) and the motor forces along the rails.
type Rate = (Vector3<f64>, Vector3<f64>, Vector3<f64>);

impl DeltaPlant {
    /// A plant at rest at `q_m`, stepped every `ts_s` with `substeps` RK4 steps (more
    /// when the Coulomb friction needs them, see [`MAX_FRICTION_STEP`]), current loops
    /// at zero. Fails when `q_m` does not assemble; an invalid geometry (see
    /// `DeltaGeometry::new`) or Coulomb friction without a positive regularization
    /// velocity and carriage mass is reported as `KinematicsError::NotFinite`.
    pub fn new(
        config: &DeltaConfig,
        params: DeltaPlantParams,
        ts_s: f64,
        substeps: u32,
        q_m: Vector3<f64>,
    ) -> Result<Self, KinematicsError> {
        let geometry = DeltaGeometry::new(config).map_err(|_| KinematicsError::NotFinite)?;
        geometry.forward(&q_m)?;
        let carriage_mass = params.carriage_mass_kg + 0.5 * params.arm_mass_kg;
        let [a1, a2, a3] = config.actuators;
        let carriage_gravity_n = Vector3::new(
            libm::sin(a1.alpha_rad),
            libm::sin(a2.alpha_rad),
            libm::sin(a3.alpha_rad),
        ) * (carriage_mass * params.gravity_z_m_s2);
        let mut substeps = substeps.max(1);
        if params.coulomb_n != 0.0 {
            let valid = params.coulomb_n > 0.0
                && params.coulomb_velocity_m_s > 0.0
                && carriage_mass > 0.0
                && ts_s.is_finite();
            if !valid {
                return Err(KinematicsError::NotFinite);
            }
            let stiffness_per_s = (params.coulomb_n / params.coulomb_velocity_m_s
                + params.viscous_n_s_per_m)
                / carriage_mass;
            let needed = libm::ceil(ts_s * stiffness_per_s / MAX_FRICTION_STEP);
            if !needed.is_finite() || needed >= 1e6 {
                return Err(KinematicsError::NotFinite);
            }
            substeps = substeps.max(needed as u32);
        }
        let end_stops_m = config.actuators.map(|a| {
            (
                a.travel_min_m + END_STOP_INSET_M,
                a.travel_max_m - END_STOP_INSET_M,
            )
        });
        Ok(Self {
            end_stops_m,
            geometry,
            params,
            carriage_gravity_n,
            substeps,
            h_s: ts_s / f64::from(substeps),
            q_m,
            q_dot_m_s: Vector3::zeros(),
            effector_force_n: Vector3::zeros(),
            drive_force_n: Vector3::zeros(),
            commanded_force_n: Vector3::zeros(),
            applied_force_n: Vector3::zeros(),
        })
    }

    fn carriage_mass_kg(&self) -> f64 {
        self.params.carriage_mass_kg + 0.5 * self.params.arm_mass_kg
    }

    fn effector_mass_kg(&self) -> f64 {
        self.params.effector_mass_kg + 1.5 * self.params.arm_mass_kg + self.params.payload_kg
    }

    /// Parameters in use.
    pub fn params(&self) -> &DeltaPlantParams {
        &self.params
    }

    /// RK4 substep in s (the control period over the substeps in use).
    pub fn substep_s(&self) -> f64 {
        self.h_s
    }

    /// Effector position p = FK(q) in m.
    pub fn effector_m(&self) -> Result<Vector3<f64>, KinematicsError> {
        self.geometry.forward(&self.q_m)
    }

    /// Effector velocity ṗ = Jx q̇ in m/s.
    pub fn effector_velocity_m_s(&self) -> Result<Vector3<f64>, KinematicsError> {
        let p = self.effector_m()?;
        Ok(self.geometry.jacobian(&self.q_m, &p)? * self.q_dot_m_s)
    }

    /// Motor forces the controller commanded for the last period, as written (before
    /// the limit, the DAC and the current loop), in N.
    pub fn commanded_force_n(&self) -> Vector3<f64> {
        self.commanded_force_n
    }

    /// Motor forces along the rails during the last period in N: the command after the
    /// limit for an ideal drive; otherwise their mean over the period (current loop and
    /// ripple included, by the integrator's own quadrature).
    pub fn applied_force_n(&self) -> Vector3<f64> {
        self.applied_force_n
    }

    /// Current loops' outputs now (current × force constant, before ripple) in N.
    pub fn drive_force_n(&self) -> Vector3<f64> {
        self.drive_force_n
    }

    /// Rail forces that hold the present pose at rest, −(mc g · ui + Jxᵀ me g) in N
    /// (payload included; friction, which can only help at rest, and ripple left out).
    pub fn holding_force_n(&self) -> Result<Vector3<f64>, KinematicsError> {
        let p = self.effector_m()?;
        let jx = self.geometry.jacobian(&self.q_m, &p)?;
        let gravity = Vector3::new(
            0.0,
            0.0,
            self.params.gravity_z_m_s2 * self.effector_mass_kg(),
        );
        Ok(-(self.carriage_gravity_n + jx.transpose() * gravity))
    }

    /// Kinetic plus potential energy in J (gravity's potential zero at z = 0 of every
    /// mass, payload included), plus the potential of the drive's current-independent
    /// ripple (zero for an ideal drive).
    pub fn energy_j(&self, config: &DeltaConfig) -> Result<f64, KinematicsError> {
        let p = self.effector_m()?;
        let p_dot = self.geometry.jacobian(&self.q_m, &p)? * self.q_dot_m_s;
        let (mc, me) = (self.carriage_mass_kg(), self.effector_mass_kg());
        let kinetic = 0.5 * mc * self.q_dot_m_s.norm_squared() + 0.5 * me * p_dot.norm_squared();
        let carriage_height: f64 = carriage_positions_m(config, &self.q_m)
            .iter()
            .map(|c| c.z)
            .sum();
        let potential = -self.params.gravity_z_m_s2 * (mc * carriage_height + me * p.z);
        let drive = &self.params.drive;
        let ripple: f64 = (0..3)
            .map(|i| drive.ripple_potential_j(i, self.q_m[i]))
            .sum();
        Ok(kinetic + potential + ripple)
    }

    /// Coulomb friction on each carriage in N, Fc tanh(q̇/vs).
    fn coulomb_n(&self, q_dot: &Vector3<f64>) -> Vector3<f64> {
        let (fc, vs) = (self.params.coulomb_n, self.params.coulomb_velocity_m_s);
        if fc == 0.0 {
            Vector3::zeros()
        } else {
            q_dot.map(|v| fc * libm::tanh(v / vs))
        }
    }

    /// (q̇, q̈, rail forces) at state (q, q̇) with current-loop outputs `drive_n`.
    fn rate(
        &self,
        q: &Vector3<f64>,
        q_dot: &Vector3<f64>,
        drive_n: &Vector3<f64>,
    ) -> Result<Rate, KinematicsError> {
        let p = self.geometry.forward(q)?;
        let jx = self.geometry.jacobian(q, &p)?;
        let jx_dot = self.geometry.jacobian_derivative(q, &p, q_dot)?;
        let me = self.effector_mass_kg();
        let mass =
            Matrix3::from_diagonal_element(self.carriage_mass_kg()) + jx.transpose() * jx * me;
        let gravity = Vector3::new(0.0, 0.0, self.params.gravity_z_m_s2 * me);
        let drive = &self.params.drive;
        let rail = Vector3::from_fn(|i, _| drive.rail_force_n(i, drive_n[i], q[i]));
        let rhs = rail - q_dot * self.params.viscous_n_s_per_m - self.coulomb_n(q_dot)
            + self.carriage_gravity_n
            + jx.transpose() * (gravity + self.effector_force_n)
            - jx.transpose() * (jx_dot * q_dot) * me;
        // M is symmetric positive definite wherever Jx exists.
        let q_ddot = mass
            .cholesky()
            .ok_or(KinematicsError::SingularJ2)?
            .solve(&rhs);
        Ok((*q_dot, q_ddot, rail))
    }

    /// Advances one control period with the motor forces `force_cmd_n` held (clipped
    /// to the continuous limit, a non-finite command applies zero; then through the
    /// drive's DAC, current loop and ripple). On error (the motion left the assembling
    /// or regular region) the state is left at the start of the failing substep.
    pub fn step(&mut self, force_cmd_n: Vector3<f64>) -> Result<(), KinematicsError> {
        let limit = self.params.force_limit_n;
        let drive = self.params.drive;
        self.commanded_force_n = force_cmd_n;
        let force = force_cmd_n.map(|f| {
            if f.is_finite() {
                drive.quantize_n(f.clamp(-limit, limit))
            } else {
                0.0
            }
        });
        if drive.current_tau_s() == 0.0 {
            self.drive_force_n = force;
        }
        let h = self.h_s;
        let mut mean = Vector3::zeros();
        for _ in 0..self.substeps {
            let (q, v, f0) = (self.q_m, self.q_dot_m_s, self.drive_force_n);
            // The current loop's exact output at the stage times 0, h/2, h.
            let f_half = f0.zip_map(&force, |f0, u| drive.current_loop_n(f0, u, 0.5 * h));
            let f_end = f0.zip_map(&force, |f0, u| drive.current_loop_n(f0, u, h));
            let (k1q, k1v, r1) = self.rate(&q, &v, &f0)?;
            let (k2q, k2v, r2) =
                self.rate(&(q + k1q * (0.5 * h)), &(v + k1v * (0.5 * h)), &f_half)?;
            let (k3q, k3v, r3) =
                self.rate(&(q + k2q * (0.5 * h)), &(v + k2v * (0.5 * h)), &f_half)?;
            let (k4q, k4v, r4) = self.rate(&(q + k3q * h), &(v + k3v * h), &f_end)?;
            self.q_m = q + (k1q + k2q * 2.0 + k3q * 2.0 + k4q) * (h / 6.0);
            self.q_dot_m_s = v + (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (h / 6.0);
            self.drive_force_n = f_end;
            mean += (r1 + r2 * 2.0 + r3 * 2.0 + r4) / 6.0;
            // The end stops: inelastic, the carriage held there, its velocity into the
            // stop gone (an unpowered carriage comes to rest on its lower stop).
            for ((q, v), (low, high)) in self
                .q_m
                .iter_mut()
                .zip(self.q_dot_m_s.iter_mut())
                .zip(self.end_stops_m)
            {
                if *q < low {
                    *q = low;
                    *v = v.max(0.0);
                } else if *q > high {
                    *q = high;
                    *v = v.min(0.0);
                }
            }
        }
        self.applied_force_n = if drive.is_instantaneous() {
            force
        } else {
            mean / f64::from(self.substeps)
        };
        Ok(())
    }
}

/// Carriage joint positions Ci = rb (cθi, sθi, 0) + di (−cαi cθi, −cαi sθi, sαi) in m
/// (T eq. 101), from the plain configuration.
pub fn carriage_positions_m(config: &DeltaConfig, q_m: &Vector3<f64>) -> [Vector3<f64>; 3] {
    let one = |i: usize, d: f64| {
        let a = config.actuators[i];
        let (st, ct) = (libm::sin(a.theta_rad), libm::cos(a.theta_rad));
        let (sa, ca) = (libm::sin(a.alpha_rad), libm::cos(a.alpha_rad));
        Vector3::new(ct, st, 0.0) * a.base_radius_m + Vector3::new(-ca * ct, -ca * st, sa) * d
    };
    [one(0, q_m.x), one(1, q_m.y), one(2, q_m.z)]
}

/// Effector joint positions Pi = p + re (cθi, sθi, 0) in m (T eq. 98).
pub fn effector_joints_m(config: &DeltaConfig, p_m: &Vector3<f64>) -> [Vector3<f64>; 3] {
    let one = |i: usize| {
        let a = config.actuators[i];
        p_m + Vector3::new(libm::cos(a.theta_rad), libm::sin(a.theta_rad), 0.0)
            * a.effector_radius_m
    };
    [one(0), one(1), one(2)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use kerf::kinematics::delta::Root;

    /// The Keops slave hanging (effector below the carriages, z up): a stable
    /// equilibrium exists (arms ~23° below horizontal), so the unforced robot swings
    /// about it instead of running into a singularity. Travel widened so the swing
    /// stays inside.
    pub(super) fn hanging_keops() -> DeltaConfig {
        let mut c = DeltaConfig::SLAVE_KEOPS;
        c.fk_root = Root::Minus;
        for a in c.actuators.iter_mut() {
            a.travel_min_m = -0.03;
            a.travel_max_m = 0.06;
        }
        c
    }

    #[test]
    fn energy_is_conserved_without_input() {
        let c = hanging_keops();
        // Asymmetric start, at rest: every carriage and the effector move.
        let q0 = Vector3::new(0.012, 0.006, 0.0);
        let mut plant = DeltaPlant::new(&c, DeltaPlantParams::SLAVE, 1e-4, 1, q0).unwrap();
        let e0 = plant.energy_j(&c).unwrap();
        let (mut drift, mut swing) = (0.0f64, 0.0f64);
        for _ in 0..100_000 {
            plant.step(Vector3::zeros()).unwrap();
            let e = plant.energy_j(&c).unwrap();
            drift = drift.max((e - e0).abs());
            swing = swing.max((plant.q_m - q0).amax());
        }
        // The robot really moved (a few mm), so energy was exchanged back and forth.
        assert!(swing > 1e-3, "{swing}");
        // RK4 at h = 1e-4 s on modes of a few Hz: per-step energy error ~(ωh)⁵ × E
        // ≈ 1e-17 J with E ~ 1e-3 J exchanged, so 1e5 steps give at most ~1e-12 J
        // even if every step's error added up.
        std::println!("energy drift over 10 s: {drift:.2e} J (swing {swing:.2e} m)");
        assert!(drift < 1e-12, "{drift}");
    }

    #[test]
    fn loop_closure_holds_throughout() {
        let c = hanging_keops();
        let mut plant = DeltaPlant::new(
            &c,
            DeltaPlantParams::SLAVE,
            1e-4,
            2,
            Vector3::new(0.01, 0.0, 0.004),
        )
        .unwrap();
        for k in 0..20_000 {
            // Some drive so the check does not only see free swinging.
            let t = k as f64 * 1e-4;
            plant
                .step(Vector3::new(
                    0.05 * libm::sin(20.0 * t),
                    0.05 * libm::cos(7.0 * t),
                    0.0,
                ))
                .unwrap();
            let p = plant.effector_m().unwrap();
            let carriages = carriage_positions_m(&c, &plant.q_m);
            let joints = effector_joints_m(&c, &p);
            for i in 0..3 {
                let err = ((joints[i] - carriages[i]).norm() - c.actuators[i].arm_m).abs();
                assert!(err < 1e-9, "step {k} arm {i}: {err}");
            }
        }
    }

    #[test]
    fn a_held_carriage_force_balances_gravity_statically() {
        // Horizontal master, z up, effector above the carriages (T's frame). Rails are
        // horizontal, so the static forces holding the pose are F = −Jxᵀ me g: applying
        // them keeps the robot at rest (checks the gravity and Jacobian wiring).
        let c = DeltaConfig::MASTER_HORIZONTAL;
        let q0 = Vector3::new(0.07, 0.065, 0.075);
        let mut plant = DeltaPlant::new(&c, DeltaPlantParams::MASTER, 1e-4, 1, q0).unwrap();
        let g = DeltaGeometry::<f64>::new(&c).unwrap();
        let p = g.forward(&q0).unwrap();
        let jx = g.jacobian(&q0, &p).unwrap();
        let hold = -(jx.transpose() * Vector3::new(0.0, 0.0, -9.81 * 0.164));
        for _ in 0..1000 {
            plant.step(hold).unwrap();
        }
        // Force rounding only: 1e-12 m after 0.1 s.
        assert!((plant.q_m - q0).amax() < 1e-12, "{}", plant.q_m - q0);
        // Without the holding force the effector falls (z decreases).
        for _ in 0..1000 {
            plant.step(Vector3::zeros()).unwrap();
        }
        assert!(plant.effector_m().unwrap().z < p.z - 1e-4);
    }
}

#[cfg(test)]
mod realistic_tests;
