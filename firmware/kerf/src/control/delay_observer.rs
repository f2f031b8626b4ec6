//! The master's estimate of the slave over a delayed link (SPEC control "With delay",
//! T 5.3.2): a Smith predictor whose delay is read off the packets, never configured.
//! It estimates the slave's delay-free response — where the slave is when it executes
//! the present master state — which the master uses in place of the slave's delayed
//! measurement (for the lag it renders to the operator, say): the measurement itself
//! is a round trip plus the forward delay behind that.
//!
//! The master runs a model of the slave under its tracking law (`control::bilateral`:
//! reference s(xm − cm) + cs, error poles −λ and −K) from its own motion, one step per
//! control period, so the model is always at the present. Each packet the master sends
//! carries its tick, and the model's position at that tick is kept in a short history.
//! The slave echoes, with its measured position, the tick of the newest master packet
//! it had applied. On receipt the master compares the measurement with the model's
//! position *at the echoed tick* — both describe the same instant of the slave — and
//! low-passes the difference (what the model misses: friction, load, model error).
//! The estimate is the present model plus that difference:
//!
//!   x̂s(now) = model(now) + LPF[ys(echo) − model(echo)].
//!
//! The round trip is whatever the echo says, packet by packet, so a constant, a
//! varying or a jittering delay is handled alike; a packet older than the history,
//! from the future or not finite is dropped and counted. Ticks are `u32` master
//! periods compared by wrapping difference: the history works across the counter's
//! wrap (five days at 10 kHz).

use crate::control::bilateral::{Bilateral, BilateralConfig, MasterState};
use crate::error::{coefficient, positive, ConfigContext, ConfigError};
use crate::scalar::Float;
use nalgebra::Vector3;

/// The observer's settings.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DelayObserverConfig {
    /// The slave's tracking law, as the slave runs it (the model's law).
    pub tracking: BilateralConfig,
    /// The master's control period, s (one model step).
    pub period_s: f64,
    /// Bandwidth of the low-pass on the model's error, rad/s (applied per received
    /// packet with the time since the previous one).
    pub correction_bandwidth_rad_s: f64,
}

/// Why a received packet was not used.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EchoRejected {
    /// The echoed tick is not in the history (older than it holds, or never sent).
    NotInHistory,
    /// The measured position is not finite.
    NotFinite,
}

/// One history entry: the model's position when the packet of `tick` was sent.
#[derive(Copy, Clone, Debug, PartialEq)]
struct Sent<T> {
    tick: u32,
    position: Vector3<T>,
}

/// The observer: coefficients and state. `H` packets of history (the longest round
/// trip it can follow is H packet periods).
#[derive(Clone, Debug)]
pub struct DelayObserver<T: Float, const H: usize> {
    law: Bilateral<T>,
    ts: T,
    /// ω_c · Ts per control period, for the correction's per-packet gain.
    correction_rate: T,
    model_position: Vector3<T>,
    model_velocity: Vector3<T>,
    /// Control periods since the master started (the master's tick).
    tick: u32,
    history: [Option<Sent<T>>; H],
    next: usize,
    correction: Vector3<T>,
    /// Tick of the newest echo used (the correction's time base).
    last_echo: Option<u32>,
    /// Round trip of the newest echo used, in master periods.
    round_trip_periods: u32,
    rejected: u32,
}

impl<T: Float, const H: usize> DelayObserver<T, H> {
    /// Validates the settings; the model starts at rest at the slave's centre plus
    /// the scaled offset of `master_position` (where the slave is after homing).
    pub fn new(
        config: &DelayObserverConfig,
        master_position: Vector3<T>,
    ) -> Result<Self, ConfigError> {
        let law = Bilateral::new(&config.tracking).within("tracking")?;
        let ts = positive("period_s", config.period_s)?;
        let wc = positive(
            "correction_bandwidth_rad_s",
            config.correction_bandwidth_rad_s,
        )?;
        let start = law
            .slave_reference(&MasterState {
                position: master_position,
                velocity: Vector3::zeros(),
                acceleration: Vector3::zeros(),
            })
            .position;
        Ok(Self {
            law,
            ts: coefficient("period_s", ts)?,
            correction_rate: coefficient("correction_bandwidth_rad_s", wc * ts)?,
            model_position: start,
            model_velocity: Vector3::zeros(),
            tick: 0,
            history: [None; H],
            next: 0,
            correction: Vector3::zeros(),
            last_echo: None,
            round_trip_periods: 0,
            rejected: 0,
        })
    }

    /// One master control period: the model slave follows the master's present
    /// state under the tracking law. Returns the master's tick for this period.
    pub fn step(&mut self, master: &MasterState<T>) -> u32 {
        let (kp, kd) = self.law.gains();
        let r = self.law.slave_reference(master);
        let a = r.acceleration
            + (r.velocity - self.model_velocity) * kd
            + (r.position - self.model_position) * kp;
        // Semi-implicit Euler: stable for the law's poles well below 1/Ts.
        self.model_velocity += a * self.ts;
        self.model_position += self.model_velocity * self.ts;
        self.tick = self.tick.wrapping_add(1);
        self.tick
    }

    /// A packet carrying this period's tick has been sent: keep the model's position
    /// for its echo.
    pub fn sent(&mut self) {
        if let Some(slot) = self.history.get_mut(self.next) {
            *slot = Some(Sent {
                tick: self.tick,
                position: self.model_position,
            });
        }
        self.next = (self.next + 1) % H.max(1);
    }

    /// The slave's report: its measured position and the tick of the newest master
    /// packet it had applied. Updates the correction, or says why not.
    pub fn received(
        &mut self,
        echo_tick: u32,
        slave_position: &Vector3<T>,
    ) -> Result<(), EchoRejected> {
        if !slave_position.iter().all(|v| v.is_finite()) {
            self.rejected = self.rejected.saturating_add(1);
            return Err(EchoRejected::NotFinite);
        }
        let Some(sent) = self
            .history
            .iter()
            .flatten()
            .find(|s| s.tick == echo_tick)
            .copied()
        else {
            self.rejected = self.rejected.saturating_add(1);
            return Err(EchoRejected::NotInHistory);
        };
        // Gain for the time since the previous echo: 1 − e^(−ω_c Δt) ≈ ω_c Δt / (1 +
        // ω_c Δt) (the backward-Euler step, stable for any gap).
        let gap = self
            .last_echo
            .map_or(1, |last| echo_tick.wrapping_sub(last).clamp(1, 1 << 20));
        let x = self.correction_rate * crate::scalar::lit::<T>(f64::from(gap));
        let gain = x / (T::one() + x);
        let error = slave_position - sent.position;
        self.correction += (error - self.correction) * gain;
        self.last_echo = Some(echo_tick);
        self.round_trip_periods = self.tick.wrapping_sub(echo_tick);
        Ok(())
    }

    /// The estimate of the slave's delay-free position (module docs), m.
    pub fn estimate(&self) -> Vector3<T> {
        self.model_position + self.correction
    }

    /// The model slave's present position and velocity (without the correction).
    pub fn model(&self) -> (Vector3<T>, Vector3<T>) {
        (self.model_position, self.model_velocity)
    }

    /// The round trip the newest used echo showed, in master periods.
    pub fn round_trip_periods(&self) -> u32 {
        self.round_trip_periods
    }

    /// Echoes rejected so far.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }
}

#[cfg(test)]
mod tests;
