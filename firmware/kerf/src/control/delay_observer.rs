//! The master's estimate of the slave over a delayed link (docs/control.md §22,
//! T 5.3.2): a Smith predictor whose delay is read off the packets, never configured.
//!
//! In T's arrangement (T eq. 93–96) the master side computes the slave's
//! command — the tracking law of `control::bilateral` on the master's present state
//! and the slave's state — sends it, and the slave applies it under its disturbance
//! observer, which makes the slave the nominal double integrator ẍs = u. The slave's
//! measured state arrives a round trip late; closing the law on it puts the whole
//! round trip inside the loop (at 40 ms and tracking poles at 30 rad/s the loop rings
//! and at higher bandwidths it is unstable). The observer instead runs that nominal
//! model on the master, one step per control period with the command just computed,
//! so the model is the slave *as it will be when it executes this command*, with no
//! delay in the loop.
//!
//! Each packet the master sends carries its tick, and the model's position at that
//! tick is kept in a short history. The slave echoes, with its measured position, the
//! tick of the command it was executing. On receipt the master compares the
//! measurement with the model's position *at the echoed tick* — both describe the
//! slave at the same point of the command stream — and low-passes the difference (what
//! the model misses: friction the slave's observer has not cancelled, a load, a lost
//! packet). The estimate is the present model plus that difference:
//!
//!   x̂s(now) = model(now) + d̂ + ḋ̂ · (now − echo),   x̂̇s = model velocity + ḋ̂,
//!
//! where d̂, ḋ̂ track the model's error d = ys(echo) − model(echo) and its rate (the
//! "convergence term" that T's reference 115 adds to the network observer;
//! here an α-β tracker), and the law uses x̂s, x̂̇s in place of the slave's state. Because the
//! correction is inside the loop, a constant push on the slave is cancelled, not just
//! estimated. The round trip is whatever the echo says, packet by packet, so a
//! constant, a varying or a jittering delay is handled alike; a packet older than the
//! history, from the future or not finite is dropped and counted. Ticks are `u32`
//! master periods compared by wrapping difference: the history works across the
//! counter's wrap (five days at 10 kHz).

use crate::error::{coefficient, positive, ConfigError};
use crate::scalar::Float;
use nalgebra::Vector3;

/// The observer's settings.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct DelayObserverConfig {
    /// The master's control period, s (one model step).
    pub period_s: f64,
    /// Bandwidth of the tracker of the model's error, rad/s (both its poles; applied
    /// per received packet with the time since the previous one).
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
    /// The echoed tick is older than the newest echo used (a report overtaken by a
    /// later one on a link that reorders).
    Stale,
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
    ts: T,
    /// ω_c · Ts per control period, for the correction's per-packet gain.
    correction_rate: T,
    model_position: Vector3<T>,
    model_velocity: Vector3<T>,
    /// Control periods since the master started (the master's tick).
    tick: u32,
    history: [Option<Sent<T>>; H],
    next: usize,
    /// The model's error at the newest echo, m, and its rate, m/s.
    correction: Vector3<T>,
    correction_rate_m_s: Vector3<T>,
    /// Tick of the newest echo used (the correction's time base).
    last_echo: Option<u32>,
    /// Round trip of the newest echo used, in master periods.
    round_trip_periods: u32,
    rejected: u32,
}

impl<T: Float, const H: usize> DelayObserver<T, H> {
    /// Validates the settings; the model starts at rest at `slave_position` (where the
    /// slave reported it is before the master takes over).
    pub fn new(
        config: &DelayObserverConfig,
        slave_position: Vector3<T>,
    ) -> Result<Self, ConfigError> {
        let ts = positive("period_s", config.period_s)?;
        let wc = positive(
            "correction_bandwidth_rad_s",
            config.correction_bandwidth_rad_s,
        )?;
        Ok(Self {
            ts: coefficient("period_s", ts)?,
            correction_rate: coefficient("correction_bandwidth_rad_s", wc * ts)?,
            model_position: slave_position,
            model_velocity: Vector3::zeros(),
            tick: 0,
            history: [None; H],
            next: 0,
            correction: Vector3::zeros(),
            correction_rate_m_s: Vector3::zeros(),
            last_echo: None,
            round_trip_periods: 0,
            rejected: 0,
        })
    }

    /// Starts over in place (the history emptied, the correction zero) with the model
    /// at rest at `slave_position`; the tick keeps counting, so echoes of packets sent
    /// before cannot match a new one.
    pub fn restart(&mut self, slave_position: Vector3<T>) {
        self.model_position = slave_position;
        self.model_velocity = Vector3::zeros();
        // In place: an array temporary of the history's size would land on the
        // control period's stack.
        for slot in &mut self.history {
            *slot = None;
        }
        self.next = 0;
        self.correction = Vector3::zeros();
        self.correction_rate_m_s = Vector3::zeros();
        self.last_echo = None;
        self.round_trip_periods = 0;
    }

    /// One master control period: the model slave executes `command` (the desired task
    /// acceleration just sent, m/s²). Returns the master's tick for this period.
    pub fn step(&mut self, command: &Vector3<T>) -> u32 {
        // Semi-implicit Euler: stable for the law's poles well below 1/Ts.
        self.model_velocity += command * self.ts;
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
        // The model's error d = ys − model is tracked with its rate (an α-β filter with
        // both poles at r = e^(−ω_c Δt) for the time Δt since the previous echo): a
        // slave whose observer has left it a velocity offset drifts from the model
        // linearly, and a position-only correction would trail that ramp.
        let gap = match self.last_echo {
            None => 1,
            // A report that a later one overtook says less than the one used: dropped
            // (its gap would read as the counter's wrap).
            Some(last) if echo_tick.wrapping_sub(last) >= 1 << 31 => {
                self.rejected = self.rejected.saturating_add(1);
                return Err(EchoRejected::Stale);
            }
            Some(last) => echo_tick.wrapping_sub(last).clamp(1, 1 << 20),
        };
        let dt = self.ts * crate::scalar::lit::<T>(f64::from(gap));
        let r = (-self.correction_rate * crate::scalar::lit::<T>(f64::from(gap))).exp();
        let (alpha, beta) = (T::one() - r * r, (T::one() - r) * (T::one() - r));
        if self.last_echo.is_some() {
            self.correction += self.correction_rate_m_s * dt;
        }
        let innovation = (slave_position - sent.position) - self.correction;
        self.correction += innovation * alpha;
        self.correction_rate_m_s += innovation * (beta / dt);
        self.last_echo = Some(echo_tick);
        self.round_trip_periods = self.tick.wrapping_sub(echo_tick);
        Ok(())
    }

    /// The estimate of the slave's delay-free position and velocity (module docs), m
    /// and m/s.
    pub fn estimate(&self) -> (Vector3<T>, Vector3<T>) {
        // The error's rate carries it from the echo's tick to the present.
        let since = self.last_echo.map_or(0, |e| self.tick.wrapping_sub(e));
        let ahead = self.ts * crate::scalar::lit::<T>(f64::from(since));
        (
            self.model_position + self.correction + self.correction_rate_m_s * ahead,
            self.model_velocity + self.correction_rate_m_s,
        )
    }

    /// The master's tick: control periods stepped so far (wrapping).
    pub fn tick(&self) -> u32 {
        self.tick
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
