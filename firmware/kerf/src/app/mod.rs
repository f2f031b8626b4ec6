//! Machines and their supervisor: how a machine runs, one step per control period.
//!
//! [`supervisor`] owns the modes (Idle → Calibrating → Ready → Running → Stopping →
//! Fault) and the command and report queues; a machine implements
//! [`supervisor::Machine`]. [`axis`] is one Hall-sensed linear-motor axis split into
//! coefficients and state; [`joints`] is the machine of N such axes that follow
//! joint-space jobs (the single LM1247 axis is its N = 1 case); [`calibrate`] is the
//! calibration sweep and the fit the slower context runs on the streamed samples.

pub mod axis;
pub mod calibrate;
pub mod drive_set;
pub mod host_link;
pub mod jobs;
pub mod joints;
pub mod lockstep;
pub mod playout;
pub mod remote_link;
pub mod settings_store;
pub mod stream;
pub mod supervisor;

use crate::error::{positive, ConfigError};
use crate::hal::{Monotonic, SampleInputs, WriteOutputs};
use supervisor::{Machine, Supervisor};

/// One control period on a board: note when it started, sample every input, step the
/// supervisor, write every output. The control interrupt of the QEMU image and of a
/// board image call this.
pub fn control_period<M, H>(
    supervisor: &mut Supervisor<'_, M>,
    clock: &mut PeriodClock,
    hal: &mut H,
) -> M::Outputs
where
    M: Machine,
    H: SampleInputs<M::Inputs> + WriteOutputs<M::Outputs> + Monotonic,
{
    clock.start(hal.now());
    let inputs = hal.sample();
    let outputs = supervisor.step(&inputs);
    hal.write(&outputs);
    outputs
}

/// Watches the control period's start times on the board's [`Monotonic`] tick: a
/// period that starts more than half a period late means one was missed (the control
/// interrupt overran or was masked). Counted, not faulted: the machine's own checks
/// (observer, sensors) decide whether the motion suffered.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct PeriodClock {
    period_ticks: u64,
    last: Option<u64>,
    late_periods: u32,
    longest_ticks: u64,
}

impl PeriodClock {
    /// A clock for `period_s` on a tick of `tick_hz`; the period must be at least two
    /// ticks.
    pub fn new(period_s: f64, tick_hz: u64) -> Result<Self, ConfigError> {
        let ticks = positive("period_s", period_s)? * tick_hz as f64;
        if !(2.0..=u64::MAX as f64).contains(&ticks) {
            return Err(ConfigError::out_of_range("period_s"));
        }
        Ok(Self {
            period_ticks: libm::round(ticks) as u64,
            last: None,
            late_periods: 0,
            longest_ticks: 0,
        })
    }

    /// A period starts at tick `now`.
    pub fn start(&mut self, now: u64) {
        if let Some(last) = self.last {
            // Ticks only count up; a wrap of 64 bits is out of a machine's life, and
            // `wrapping_sub` keeps even that one correct.
            let interval = now.wrapping_sub(last);
            self.longest_ticks = self.longest_ticks.max(interval);
            if interval > self.period_ticks + self.period_ticks / 2 {
                self.late_periods = self.late_periods.saturating_add(1);
            }
        }
        self.last = Some(now);
    }

    /// Periods that started more than half a period late.
    pub fn late_periods(&self) -> u32 {
        self.late_periods
    }

    /// The longest time between two period starts, in ticks.
    pub fn longest_ticks(&self) -> u64 {
        self.longest_ticks
    }

    /// The nominal period, in ticks.
    pub fn period_ticks(&self) -> u64 {
        self.period_ticks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missed_period_is_counted_once() {
        let mut clock = PeriodClock::new(1e-4, 170_000_000).unwrap();
        assert_eq!(clock.period_ticks(), 17_000);
        // Jitter of a few hundred ticks is not late; a skipped period is.
        for now in [0, 17_000, 34_300, 51_000, 85_000, 102_000] {
            clock.start(now);
        }
        assert_eq!(clock.late_periods(), 1);
        assert_eq!(clock.longest_ticks(), 34_000);
        // Across the 64-bit wrap.
        let mut clock = PeriodClock::new(1e-4, 170_000_000).unwrap();
        clock.start(u64::MAX - 5_000);
        clock.start(11_999);
        assert_eq!((clock.late_periods(), clock.longest_ticks()), (0, 17_000));
    }

    #[test]
    fn a_period_shorter_than_two_ticks_is_refused() {
        assert!(PeriodClock::new(1e-4, 10_000).is_err());
        assert!(PeriodClock::new(f64::NAN, 1_000_000).is_err());
        assert!(PeriodClock::new(1e-4, 20_000).is_ok());
    }
}
