//! Calibration of a machine's Hall sensors, split between the two contexts.
//!
//! In the control period, [`CalibrationSweep`] moves every axis together, closed loop
//! with the nominal decoders, 1.5 magnetic pitches out and back (so every phase is
//! seen twice and the machine ends where it started), and hands a decimated stream of
//! raw samples to the slower context. There, [`CalibrationFit`] collects them and runs
//! the sensor-model fit (`sensing::hall::calibration`), which is far too long for a
//! control period.
//!
//! All axes sweep together rather than one at a time: the sweep takes a third of the
//! time on three axes, and on a delta equal carriage moves translate the effector
//! along its axis instead of sideways, so the pose stays well inside the workspace.

use crate::app::axis::HallAxis;
use crate::app::supervisor::Machine;
use crate::control::pd::Reference;
use crate::error::{positive, ConfigError};
use crate::scalar::Real;
use crate::sensing::hall::{
    CalibrationError, HallCalibration, HallCalibrator, HallConfig, SelfCalibration,
};
use crate::trajectory::quintic::Quintic;

/// Raw samples kept per axis.
pub const CALIBRATION_SAMPLES: usize = 512;
/// Pitches swept: more than one, so every phase is seen, with margin for the ends.
pub const SWEEP_PITCHES: f64 = 1.5;
/// Duration of each way of the sweep, s (peak speed 1.875 × 27 mm / 0.6 s = 84 mm/s at
/// an 18 mm pitch).
pub const SWEEP_DURATION_S: f64 = 0.6;
/// Rest before the sweep starts, between the two ways, and after it ends, s.
const REST_S: f64 = 0.02;

/// The control-period half: the out-and-back sweep of N axes and the sample stream.
#[derive(Clone, Debug)]
pub struct CalibrationSweep<T, const N: usize> {
    out: Quintic<T>,
    back: Quintic<T>,
    start_m: [T; N],
    ts: T,
    rest: T,
    period: u32,
    periods: u32,
    back_from: u32,
    decimation: u32,
}

impl<T: Real, const N: usize> CalibrationSweep<T, N> {
    /// A sweep of [`SWEEP_PITCHES`] of `pitch_m` from `start_m` (per axis) and back, at
    /// control period `period_s`.
    pub fn new(start_m: [T; N], pitch_m: f64, period_s: f64) -> Result<Self, ConfigError> {
        let pitch = positive("pitch_m", pitch_m)?;
        let ts = positive("period_s", period_s)?;
        let way = SWEEP_DURATION_S + REST_S;
        let periods = libm::ceil((2.0 * way + REST_S) / ts) as u32;
        if periods < CALIBRATION_SAMPLES as u32 {
            return Err(ConfigError::out_of_range("period_s"));
        }
        Ok(Self {
            out: Quintic::new(0.0, SWEEP_PITCHES * pitch, SWEEP_DURATION_S)?,
            back: Quintic::new(
                SWEEP_PITCHES * pitch,
                -SWEEP_PITCHES * pitch,
                SWEEP_DURATION_S,
            )?,
            start_m,
            ts: T::from_f64(ts),
            rest: T::from_f64(REST_S),
            period: 0,
            periods,
            back_from: libm::round(way / ts) as u32,
            // Spread the kept samples over the whole sweep.
            decimation: periods.div_ceil(CALIBRATION_SAMPLES as u32 - 1),
        })
    }

    /// Reference of every axis for the present period (rest, out, rest, back, rest).
    pub fn reference(&self) -> [Reference<T>; N] {
        let (way, k) = if self.period < self.back_from {
            (&self.out, self.period)
        } else {
            (&self.back, self.period - self.back_from)
        };
        // t = k·Ts − rest, from the integer period count (no accumulated rounding).
        let t = T::from_q32(i64::from(k) << 32) * self.ts - self.rest;
        let s = way.sample(t);
        self.start_m.map(|start| Reference {
            position: start + s.position,
            ..s
        })
    }

    /// Passes this period's raw counts of every axis to `record` when they are to be
    /// kept, and advances; `true` once the sweep is over.
    pub fn advance(
        &mut self,
        counts: &[[u16; 3]; N],
        record: &mut dyn FnMut(u8, [u16; 3]),
    ) -> bool {
        // `decimation` is at least 1 (`new`); `checked_rem` says so without a panic path.
        if self.period.checked_rem(self.decimation) == Some(0) {
            for (axis, c) in counts.iter().enumerate() {
                record(axis as u8, *c);
            }
        }
        self.period += 1;
        self.period >= self.periods
    }

    /// Periods the sweep lasts.
    pub fn periods(&self) -> u32 {
        self.periods
    }
}

/// The slower context's half: the streamed samples of N axes and the fit.
#[derive(Clone, Debug)]
pub struct CalibrationFit<const N: usize> {
    calibrators: [HallCalibrator<CALIBRATION_SAMPLES>; N],
}

impl<const N: usize> Default for CalibrationFit<N> {
    fn default() -> Self {
        Self {
            calibrators: core::array::from_fn(|_| HallCalibrator::new()),
        }
    }
}

impl<const N: usize> CalibrationFit<N> {
    /// Keeps one streamed sample of `axis`.
    pub fn push(&mut self, axis: u8, counts: [u16; 3]) -> Result<(), CalibrationError> {
        match self.calibrators.get_mut(usize::from(axis)) {
            Some(c) => c.push(counts),
            None => Err(CalibrationError::TooFewSamples),
        }
    }

    /// Fits the sensor model of `axis`, starting from the nominal calibration `initial`.
    pub fn finish(
        &self,
        axis: usize,
        initial: &HallCalibration,
    ) -> Result<SelfCalibration, CalibrationError> {
        match self.calibrators.get(axis) {
            Some(c) => c.solve(initial),
            None => Err(CalibrationError::TooFewSamples),
        }
    }
}

/// Why the slower context could not turn a calibration into decoders.
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum CalibrationFailure {
    /// The fit of an axis failed.
    Fit {
        /// Axis index.
        axis: usize,
        /// Why.
        error: CalibrationError,
    },
    /// The fitted decoder configuration was rejected.
    Config(ConfigError),
}

/// The slower context's end of a calibration: fits every axis from the streamed
/// samples, returns the decoders to send with `FinishCalibration` and the fits.
pub fn fit_sensors<T: Real, const N: usize>(
    hall: &[HallConfig; N],
    samples: &CalibrationFit<N>,
) -> Result<([HallAxis<T>; N], [SelfCalibration; N]), CalibrationFailure> {
    let mut sensors = heapless::Vec::<HallAxis<T>, N>::new();
    let mut fits = heapless::Vec::<SelfCalibration, N>::new();
    for (axis, hall) in hall.iter().enumerate() {
        let fit = samples
            .finish(axis, &hall.calibration)
            .map_err(|error| CalibrationFailure::Fit { axis, error })?;
        let mut sensor = HallAxis::new(&hall.with_self_calibration(&fit))
            .map_err(|e| CalibrationFailure::Config(e.at(axis).within("hall")))?;
        sensor.set_correction(Some(fit.correction));
        let _ = sensors.push(sensor);
        let _ = fits.push(fit);
    }
    match (sensors.into_array(), fits.into_array()) {
        (Ok(sensors), Ok(fits)) => Ok((sensors, fits)),
        _ => Err(CalibrationFailure::Fit {
            axis: 0,
            error: CalibrationError::TooFewSamples,
        }),
    }
}

/// A machine whose calibration is one fitted Hall decoder per axis: the slower
/// context's side of `FinishCalibration`.
pub trait HallMachine<const N: usize>: Machine {
    /// Fits the streamed samples into the machine's calibration; also returns the fits.
    fn fit(
        hall: &[HallConfig; N],
        samples: &CalibrationFit<N>,
    ) -> Result<(Self::Calibration, [SelfCalibration; N]), CalibrationFailure>;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweep_goes_out_and_back_and_streams_the_store_without_overflow() {
        for ts in [1e-4, 4.17e-4] {
            let mut sweep = CalibrationSweep::<f64, 2>::new([0.004, -0.01], 0.018, ts).unwrap();
            let mut fit = CalibrationFit::<2>::default();
            let (mut first, mut far) = (None, 0.0f64);
            let mut last;
            let mut periods = 0;
            let mut pushed = [0u32; 2];
            loop {
                let r = sweep.reference();
                first.get_or_insert([r[0].position, r[1].position]);
                far = far.max(r[0].position);
                last = [r[0].position, r[1].position];
                assert!((r[1].position - r[0].position + 0.014).abs() < 1e-15);
                periods += 1;
                // Any healthy-looking counts: only the bookkeeping is under test here.
                let done = sweep.advance(&[[30000, 20000, 15000]; 2], &mut |axis, c| {
                    pushed[usize::from(axis)] += 1;
                    fit.push(axis, c).unwrap();
                });
                if done {
                    break;
                }
            }
            assert_eq!(periods, sweep.periods());
            assert_eq!(first, Some([0.004, -0.01]));
            assert!(
                (far - (0.004 + SWEEP_PITCHES * 0.018)).abs() < 1e-12,
                "{far}"
            );
            assert!((last[0] - 0.004).abs() < 1e-12, "{last:?}");
            assert!(
                pushed[0] > CALIBRATION_SAMPLES as u32 * 9 / 10,
                "{pushed:?}"
            );
            assert_eq!(pushed[0], pushed[1]);
        }
    }

    #[test]
    fn rejects_bad_config() {
        assert_eq!(
            CalibrationSweep::<f32, 1>::new([0.0], 0.0, 1e-4).err(),
            Some(ConfigError::not_positive("pitch_m"))
        );
        assert_eq!(
            CalibrationSweep::<f32, 1>::new([0.0], 0.018, f64::NAN).err(),
            Some(ConfigError::not_finite("period_s"))
        );
        // Too few periods in the sweep for the sample store.
        assert_eq!(
            CalibrationSweep::<f32, 1>::new([0.0], 0.018, 0.01).err(),
            Some(ConfigError::out_of_range("period_s"))
        );
    }
}
