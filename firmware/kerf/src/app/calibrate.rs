//! Calibration mode of one axis: a slow closed-loop sweep over 1.5 magnetic pitches
//! with the nominal Hall decoder, recording raw samples, then the sensor-model fit
//! (`sensing::hall::calibration`). The mode supplies the reference for each period, so
//! the same control loop that runs the machine drives the sweep.

use crate::control::pd::Reference;
use crate::error::{positive, ConfigError};
use crate::scalar::Real;
use crate::sensing::hall::{CalibrationError, HallCalibration, HallCalibrator, SelfCalibration};
use crate::trajectory::quintic::Quintic;

/// Raw samples the mode keeps.
pub const CALIBRATION_SAMPLES: usize = 512;
/// Pitches swept: more than one, so every phase is seen, with margin for the ends.
pub const SWEEP_PITCHES: f64 = 1.5;
/// Sweep duration, s (peak speed 1.875 × 27 mm / 0.6 s = 84 mm/s at an 18 mm pitch).
pub const SWEEP_DURATION_S: f64 = 0.6;
/// Rest before the sweep starts and after it ends, s.
const REST_S: f64 = 0.02;

/// Progress of the calibration mode.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalibrationProgress {
    /// The sweep goes on; keep stepping.
    Sweeping,
    /// All samples are in: call [`HallCalibrationMode::finish`].
    Done,
}

/// The calibration sweep and its sample store.
#[derive(Clone, Debug)]
pub struct HallCalibrationMode<T> {
    sweep: Quintic<T>,
    ts: T,
    /// Time since the sweep's start (negative during the first rest), s.
    sweep_time: T,
    periods: u32,
    decimation: u32,
    period: u32,
    calibrator: HallCalibrator<CALIBRATION_SAMPLES>,
}

impl<T: Real> HallCalibrationMode<T> {
    /// A sweep from `start_m` over [`SWEEP_PITCHES`] of `pitch_m`, at period `ts_s`.
    pub fn new(start_m: f64, pitch_m: f64, ts_s: f64) -> Result<Self, ConfigError> {
        let pitch = positive("pitch_m", pitch_m)?;
        let ts = positive("ts_s", ts_s)?;
        let periods = libm::ceil((SWEEP_DURATION_S + 2.0 * REST_S) / ts) as u32;
        if periods < CALIBRATION_SAMPLES as u32 {
            return Err(ConfigError::out_of_range("ts_s"));
        }
        Ok(Self {
            sweep: Quintic::new(start_m, SWEEP_PITCHES * pitch, SWEEP_DURATION_S)?,
            ts: T::from_f64(ts),
            sweep_time: T::from_f64(-REST_S),
            periods,
            // Spread the kept samples over the whole sweep.
            decimation: periods.div_ceil(CALIBRATION_SAMPLES as u32 - 1),
            period: 0,
            calibrator: HallCalibrator::new(),
        })
    }

    /// Reference for the present period (rest, sweep, rest).
    pub fn reference(&self) -> Reference<T> {
        self.sweep.sample(self.sweep_time)
    }

    /// Records this period's raw Hall counts; reports whether the sweep is over.
    pub fn record(
        &mut self,
        hall_counts: [u16; 3],
    ) -> Result<CalibrationProgress, CalibrationError> {
        if self.period % self.decimation == 0 {
            self.calibrator.push(hall_counts)?;
        }
        self.period += 1;
        self.sweep_time = self.sweep_time + self.ts;
        Ok(if self.period >= self.periods {
            CalibrationProgress::Done
        } else {
            CalibrationProgress::Sweeping
        })
    }

    /// Fits the sensor model, starting from the nominal calibration `initial`.
    pub fn finish(&self, initial: &HallCalibration) -> Result<SelfCalibration, CalibrationError> {
        self.calibrator.solve(initial)
    }

    /// Periods the whole mode lasts.
    pub fn periods(&self) -> u32 {
        self.periods
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_covers_the_pitches_and_fills_the_store_without_overflow() {
        for ts in [1e-4, 4.17e-4] {
            let mut mode = HallCalibrationMode::<f64>::new(0.004, 0.018, ts).unwrap();
            let (mut first, mut last) = (None, 0.0);
            let mut progress = CalibrationProgress::Sweeping;
            let mut periods = 0;
            while progress == CalibrationProgress::Sweeping {
                let r = mode.reference();
                first.get_or_insert(r.position);
                last = r.position;
                // Any healthy-looking counts: only the bookkeeping is under test here.
                progress = mode.record([30000, 20000, 15000]).unwrap();
                periods += 1;
            }
            assert_eq!(periods, mode.periods());
            assert_eq!(first, Some(0.004));
            assert!(
                (last - (0.004 + SWEEP_PITCHES * 0.018)).abs() < 1e-12,
                "{last}"
            );
        }
    }

    #[test]
    fn rejects_bad_config() {
        assert_eq!(
            HallCalibrationMode::<f32>::new(0.0, 0.0, 1e-4).err(),
            Some(ConfigError::not_positive("pitch_m"))
        );
        assert_eq!(
            HallCalibrationMode::<f32>::new(0.0, 0.018, f64::NAN).err(),
            Some(ConfigError::not_finite("ts_s"))
        );
        // Too few periods in the sweep for the sample store.
        assert_eq!(
            HallCalibrationMode::<f32>::new(0.0, 0.018, 0.01).err(),
            Some(ConfigError::out_of_range("ts_s"))
        );
    }
}
