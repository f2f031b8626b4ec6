//! T's network disturbance observer (docs/control.md §22, T 5.3.2 eq. 93–95): the
//! master's estimate of the slave's present state from the slave's delayed
//! measurements and the commands the master sent, with no delay known and no ticks
//! compared. The alternative to `control::delay_observer` on the same master
//! (`machines::remote_master::SlaveEstimate`).
//!
//! The slave under its disturbance observer is the nominal double integrator ẍs = u.
//! What reaches the master is its state D late; T calls the difference between the
//! acceleration commanded now and the one measured, D late, the network disturbance
//! (eq. 93, in acceleration units: the slave's nominal inertia cancels on both sides),
//!
//! ```text
//! d(t) = u(t) − ẍs(t − D),
//! ```
//!
//! estimates it as a disturbance observer does, through a low-pass filter of bandwidth
//! g with the measured velocity's derivative taken by the filter (no differentiation),
//! integrates the estimate into the velocity the slave gains during the delay (eq. 94)
//! and adds it to the delayed velocity (eq. 95, whose print adds it to the delayed
//! *position*: a velocity is meant, as eq. 94's integral and the text say):
//!
//! ```text
//! d̂ = g/(s + g) [u − s vd],   Δv = ∫ d̂,   v̂ = vd + Δv.
//! ```
//!
//! Eq. 96 also uses a position estimate q̂s, which T does not define; the firmware builds
//! it the same way one integration further, with the velocity estimate as the input:
//!
//! ```text
//! d̂x = g/(s + g) [v̂ − s xd],   Δx = ∫ d̂x,   x̂ = xd + Δx.
//! ```
//!
//! Together v̂ = vd + g/(s+g)(∫u − vd): below g the estimate is the commands
//! integrated (the slave as it will be, without the delay), above g the measurement.
//! T notes that the observer so stated has no term that pulls the estimate back to the
//! slave (its "convergence term", left to its reference 115): a slave that leaves its
//! model — a lost command block, a push its own observer does not cancel, a start away
//! from the estimate — stays off the estimate for good. The firmware implements it as
//! stated, so that the comparison with `control::delay_observer` (which has such a
//! term) measures the method, not an addition to it.
//!
//! The measurements are the newest report's, held between reports (the slave sends a
//! block every 16 samples); the filters' g takes up the step each new report makes.

use crate::error::{coefficient, positive, ConfigError};
use crate::scalar::Float;
use nalgebra::Vector3;

/// The observer's settings.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct NetworkObserverConfig {
    /// The master's control period, s (one step).
    pub period_s: f64,
    /// Bandwidth g of both disturbance filters, rad/s.
    pub bandwidth_rad_s: f64,
}

/// Why a report was not used.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ReportRejected {
    /// A position or velocity is not finite.
    NotFinite,
}

/// The observer: coefficients and state.
#[derive(Clone, Debug)]
pub struct NetworkObserver<T: Float> {
    ts: T,
    g: T,
    /// The newest delayed measurement (position, velocity), m and m/s.
    delayed: (Vector3<T>, Vector3<T>),
    /// The velocity filter's state (d̂ = state − g vd), m/s².
    velocity_filter: Vector3<T>,
    /// The position filter's state (d̂x = state − g xd), m/s.
    position_filter: Vector3<T>,
    /// Δv and Δx (eq. 94 and its position counterpart).
    gained: (Vector3<T>, Vector3<T>),
    rejected: u32,
}

impl<T: Float> NetworkObserver<T> {
    /// Validates the settings; the estimate starts at rest at `slave_position`.
    pub fn new(
        config: &NetworkObserverConfig,
        slave_position: Vector3<T>,
    ) -> Result<Self, ConfigError> {
        let ts = positive("period_s", config.period_s)?;
        let g = positive("bandwidth_rad_s", config.bandwidth_rad_s)?;
        // Forward Euler of the filters is stable for g Ts < 2 and accurate well below.
        if g * ts >= 0.5 {
            return Err(ConfigError::out_of_range("bandwidth_rad_s"));
        }
        let mut observer = Self {
            ts: coefficient("period_s", ts)?,
            g: coefficient("bandwidth_rad_s", g)?,
            delayed: (Vector3::zeros(), Vector3::zeros()),
            velocity_filter: Vector3::zeros(),
            position_filter: Vector3::zeros(),
            gained: (Vector3::zeros(), Vector3::zeros()),
            rejected: 0,
        };
        let at_rest = (slave_position, Vector3::zeros());
        observer.restart(at_rest, at_rest);
        Ok(observer)
    }

    /// Starts over with the slave measured at `measured` (position, velocity) and the
    /// estimate at `estimate`: no disturbance, Δx and Δv the difference. A slave known
    /// to rest is best started at rest whatever its measured velocity says: the
    /// observer has no term that would take the measurement's noise out of Δv later.
    pub fn restart(
        &mut self,
        measured: (Vector3<T>, Vector3<T>),
        estimate: (Vector3<T>, Vector3<T>),
    ) {
        let (position, velocity) = measured;
        self.delayed = measured;
        self.velocity_filter = velocity * self.g;
        self.position_filter = position * self.g;
        self.gained = (estimate.1 - velocity, estimate.0 - position);
    }

    /// A report arrived: the slave's delayed position and velocity, m and m/s.
    pub fn received(
        &mut self,
        position: &Vector3<T>,
        velocity: &Vector3<T>,
    ) -> Result<(), ReportRejected> {
        if !position
            .iter()
            .chain(velocity.iter())
            .all(|v| v.is_finite())
        {
            self.rejected = self.rejected.saturating_add(1);
            return Err(ReportRejected::NotFinite);
        }
        self.delayed = (*position, *velocity);
        Ok(())
    }

    /// One master control period with `command`, the slave's task acceleration just
    /// computed, m/s².
    pub fn step(&mut self, command: &Vector3<T>) {
        let (g, ts) = (self.g, self.ts);
        let (xd, vd) = self.delayed;
        // Eq. 93 through the filter: d̂ = ξ − g vd, ξ̇ = g (u + g vd − ξ).
        let disturbance = self.velocity_filter - vd * g;
        self.velocity_filter += (command + vd * g - self.velocity_filter) * (g * ts);
        // Eq. 94, and eq. 95's velocity.
        self.gained.0 += disturbance * ts;
        let velocity = vd + self.gained.0;
        // The position counterpart, on the velocity estimate.
        let position_disturbance = self.position_filter - xd * g;
        self.position_filter += (velocity + xd * g - self.position_filter) * (g * ts);
        self.gained.1 += position_disturbance * ts;
    }

    /// The estimate of the slave's present position and velocity, m and m/s.
    pub fn estimate(&self) -> (Vector3<T>, Vector3<T>) {
        let (xd, vd) = self.delayed;
        (xd + self.gained.1, vd + self.gained.0)
    }

    /// Reports refused so far.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }
}

#[cfg(test)]
mod tests;
