//! Calibration of a machine's Hall sensors, split between the two contexts.
//!
//! In the control period, [`CalibrationSweep`] moves every axis together 1.5 magnetic
//! pitches out and back, twice (the machine ends where it started), and hands raw
//! samples to the slower context. There, [`CalibrationFit`] collects them and runs the
//! sensor-model fit (`sensing::hall::calibration`), which is far too long for a control
//! period.
//!
//! The fit needs samples taken at a fixed rate while the true motion is smooth in time
//! whatever the Hall error (see `sensing::hall::calibration`): a loop closed on the
//! uncalibrated decoders would make the *decoded* motion smooth and put the error into
//! the true one. So the first out-and-back is closed loop: each way ramps up to a
//! cruise of [`CRUISE_PITCHES_PER_S`] and measures each axis' mean force over exactly
//! one pitch of it ([`SweepMode::Settle`]; the loop's force ripple from the decoder's
//! error is periodic in the pitch and averages out). The second out-and-back ramps up
//! the same way, then coasts with the force of the same direction held, open loop
//! ([`SweepMode::Coast`]): the slider moves under a constant force against friction
//! (Coulomb + viscous, a smooth approach to a speed; on a delta also smooth pose-
//! dependent gravity and inertia), and only these samples are streamed, one segment per
//! coast. The loop closes again for the ramp down. A coast whose decoded position strays
//! more than [`COAST_BOUND_M`] from the cruise reference faults the axis (the held force
//! was far off: a load, a stall), so the open loop is bounded.
//!
//! All axes sweep together rather than one at a time: the sweep takes a third of the
//! time on three axes, and on a delta equal carriage moves translate the effector
//! along its axis instead of sideways, so the pose stays well inside the workspace.

use crate::app::axis::HallAxis;
use crate::app::supervisor::Machine;
use crate::error::{build_each, coefficient, factor, positive, ConfigError};
use crate::scalar::Real;
use crate::sensing::hall::{
    CalibrationError, HallCalibration, HallCalibrator, HallConfig, SelfCalibration,
};
use crate::trajectory::Reference;

/// Raw samples kept per axis (two coasts of at most half of it each).
pub const CALIBRATION_SAMPLES: usize = 512;
/// Samples streamed per coast at most.
pub const SAMPLES_PER_COAST: u32 = (CALIBRATION_SAMPLES / 2) as u32;
/// Pitches swept each way: more than one, so the coast covers a pitch after the ramp.
pub const SWEEP_PITCHES: f64 = 1.5;
/// Cruise speed in pitches per second (0.25 m/s at an 18 mm pitch): fast enough that a
/// coast of a pitch is short (83 ms), so that the error of the held force drifts little
/// (δF·t²/2m) and the motion stays close to the fit's cubic in time, and that Coulomb
/// friction never stops the coast; slow enough that ramps and coast fit in the 1.5
/// pitches of a way (and the Keops delta's 0–40 mm travel from its 10 mm home).
pub const CRUISE_PITCHES_PER_S: f64 = 125.0 / 9.0;
/// Duration of the ramp up and of the ramp down, s (peak acceleration 1.5 v/T =
/// 18.75 m/s² at an 18 mm pitch, within the machines' 20 m/s²).
pub const RAMP_S: f64 = 0.02;
/// Closed-loop cruise after a ramp before a settle or a coast starts, s: the loop's
/// transient from the ramp decays.
pub const SETTLE_DELAY_S: f64 = 0.005;
/// Largest distance between the coasting axis' decoded position and the cruise
/// reference, m, before the axis faults.
pub const COAST_BOUND_M: f64 = 0.005;
/// Rest before each way of the sweep, s.
const REST_S: f64 = 0.02;
/// Rest after the last coast, closed loop, s: the loop takes up what the coast strayed
/// (up to a few mm) before the axes re-home.
const FINAL_REST_S: f64 = 0.2;
/// Ways of the sweep: out and back closed loop (settles), out and back coasting.
const WAYS: u32 = 4;
/// Streamed in place of a sample at the start of each coast: a new segment for the fit
/// (three channels at zero are never a healthy sample: the decoder rejects the rail).
pub const SEGMENT_BREAK: [u16; 3] = [0; 3];

/// What the machine does with each axis in the present period of a sweep.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum SweepMode {
    /// Closed loop on the reference (rests, ramps, the cruise around settles and coasts).
    Track,
    /// Closed loop at cruise over exactly one pitch: the mean force of these periods is
    /// held in the coast the same way.
    Settle,
    /// Open loop: the held force, samples streamed.
    Coast,
}

/// The control-period half: the out-and-back sweep of N axes and the sample stream.
#[derive(Clone, Debug)]
pub struct CalibrationSweep<T: Real, const N: usize> {
    start_m: [T; N],
    /// Ts as a coefficient: time is k·Ts from the period count ([`Real::count_times`],
    /// which does not pass k through the signal range: 1500 periods pass Q6.25's 64).
    ts: T::Coef,
    rest: T,
    ramp: T,
    inv_ramp: T,
    cruise_end: T,
    speed: T,
    distance: T,
    period: u32,
    periods: u32,
    way_periods: u32,
    settle_from: u32,
    settle_to: u32,
    coast_from: u32,
    coast_to: u32,
    decimation: u32,
}

impl<T: Real, const N: usize> CalibrationSweep<T, N> {
    /// The sweep of axes starting (and ending) at `start_m`, for a sensor of `pitch_m`
    /// and a control period of `period_s`.
    ///
    /// Errors: a start that is not finite (`start_m[i]`); a period so long that the
    /// coast has too few samples, or so short that the sweep's period count passes
    /// `u32` (`period_s` out of range); a coefficient the scalar cannot hold.
    pub fn new(start_m: [T; N], pitch_m: f64, period_s: f64) -> Result<Self, ConfigError> {
        if let Some(k) = start_m.iter().position(|s| !s.is_finite()) {
            return Err(ConfigError::not_finite("start_m").indexed(k));
        }
        let pitch = positive("pitch_m", pitch_m)?;
        let ts = positive("period_s", period_s)?;
        let speed = CRUISE_PITCHES_PER_S * pitch;
        let distance = SWEEP_PITCHES * pitch;
        // Each ramp covers speed·RAMP_S/2; the cruise the rest.
        let cruise_s = distance / speed - RAMP_S;
        let way = REST_S + RAMP_S + cruise_s + RAMP_S;
        // Every count in f64 first: the whole sweep's must fit a u32 (the period
        // counter), and then so does each part of it.
        let way_periods = libm::round(way / ts);
        let periods = f64::from(WAYS) * way_periods + libm::ceil(FINAL_REST_S / ts);
        if periods >= f64::from(u32::MAX) {
            return Err(ConfigError::out_of_range("period_s"));
        }
        let (way_periods, periods) = (way_periods as u32, periods as u32);
        let settle_from = libm::ceil((REST_S + RAMP_S + SETTLE_DELAY_S) / ts) as u32;
        // The settle averages the force over exactly one pitch of the cruise: the
        // loop's force ripple from the nominal decoder's error (periodic in the pitch)
        // then averages out.
        let settle_to =
            settle_from.saturating_add(libm::round(1.0 / CRUISE_PITCHES_PER_S / ts) as u32);
        let coast_from = settle_from;
        let coast_to = libm::floor((REST_S + RAMP_S + cruise_s) / ts) as u32;
        // The fit's segments need samples, and the coast must be a whole pitch.
        if coast_to < coast_from.saturating_add(64) || (cruise_s - SETTLE_DELAY_S) * speed < pitch {
            return Err(ConfigError::out_of_range("period_s"));
        }
        Ok(Self {
            start_m,
            ts: factor::<T>("period_s", ts)?,
            rest: coefficient("period_s", REST_S)?,
            ramp: coefficient("period_s", RAMP_S)?,
            inv_ramp: coefficient("period_s", 1.0 / RAMP_S)?,
            cruise_end: coefficient("pitch_m", RAMP_S + cruise_s)?,
            speed: coefficient("pitch_m", speed)?,
            distance: coefficient("pitch_m", distance)?,
            period: 0,
            periods,
            way_periods,
            settle_from,
            settle_to: settle_to.min(coast_to),
            coast_from,
            coast_to,
            decimation: (coast_to - coast_from).div_ceil(SAMPLES_PER_COAST),
        })
    }

    /// The way (0 and 2 out, 1 and 3 back; the last rest counts as way 3) and the
    /// period within it.
    fn way(&self) -> (u32, u32) {
        // `way_periods` is positive (`new` checks the coast fits in a way);
        // `checked_div` says so without a panic path.
        let way = self
            .period
            .checked_div(self.way_periods)
            .unwrap_or(0)
            .min(WAYS - 1);
        (way, self.period.saturating_sub(way * self.way_periods))
    }

    /// Whether the present way is back towards the start (the direction whose settle
    /// force a coast holds).
    pub fn backwards(&self) -> bool {
        self.way().0 % 2 == 1
    }

    /// What the machine does this period.
    pub fn mode(&self) -> SweepMode {
        let (way, k) = self.way();
        if way >= 2 && (self.coast_from..self.coast_to).contains(&k) {
            SweepMode::Coast
        } else if way < 2 && (self.settle_from..self.settle_to).contains(&k) {
            SweepMode::Settle
        } else {
            SweepMode::Track
        }
    }

    /// Reference of every axis for the present period (rest, ramp, cruise, ramp, and
    /// the same back, twice, and a last rest). During a coast it is the cruise the
    /// coast should follow.
    pub fn reference(&self) -> [Reference<T>; N] {
        let (way, k) = self.way();
        let out = way % 2 == 0;
        // t = k·Ts − rest, from the integer period count (no accumulated rounding).
        let t = T::count_times(k, self.ts) - self.rest;
        let (two, three, six) = (T::from_f64(2.0), T::from_f64(3.0), T::from_f64(6.0));
        let half = T::from_f64(0.5);
        let v = self.speed;
        // Smoothstep speed ramps: v(s) = v (3s² − 2s³), x(s) = v T (s³ − s⁴/2).
        let (x, dx, ddx) = if t <= T::ZERO {
            (T::ZERO, T::ZERO, T::ZERO)
        } else if t < self.ramp {
            let s = t * self.inv_ramp;
            let (s2, s3) = (s * s, s * s * s);
            (
                v * self.ramp * (s3 - half * s3 * s),
                v * (three * s2 - two * s3),
                v * six * (s - s2) * self.inv_ramp,
            )
        } else if t < self.cruise_end {
            (v * (t - half * self.ramp), v, T::ZERO)
        } else if t < self.cruise_end + self.ramp {
            let s = (t - self.cruise_end) * self.inv_ramp;
            let (s2, s3) = (s * s, s * s * s);
            (
                v * (self.cruise_end - half * self.ramp) + v * self.ramp * (s - s3 + half * s3 * s),
                v - v * (three * s2 - two * s3),
                -(v * six * (s - s2) * self.inv_ramp),
            )
        } else {
            (self.distance, T::ZERO, T::ZERO)
        };
        let (offset, x, dx, ddx) = if out {
            (T::ZERO, x, dx, ddx)
        } else {
            (self.distance, -x, -dx, -ddx)
        };
        self.start_m.map(|start| Reference {
            position: start + offset + x,
            velocity: dx,
            acceleration: ddx,
        })
    }

    /// Passes this period's raw counts of every axis to `record` when they are to be
    /// kept (every `decimation`-th period of a coast, after a [`SEGMENT_BREAK`] at its
    /// start), and advances; `true` once the sweep is over.
    pub fn advance(&mut self, counts: &[[u16; 3]; N], record: &mut dyn FnMut(HallSample)) -> bool {
        let (_, k) = self.way();
        // `decimation` is at least 1 (`new`); `checked_rem` says so without a panic path.
        let kept = k
            .checked_sub(self.coast_from)
            .and_then(|into_coast| into_coast.checked_rem(self.decimation))
            == Some(0);
        if self.mode() == SweepMode::Coast && kept {
            for (axis, c) in counts.iter().enumerate() {
                let axis = axis as u8;
                if k == self.coast_from {
                    record(HallSample {
                        axis,
                        counts: SEGMENT_BREAK,
                    });
                }
                record(HallSample { axis, counts: *c });
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
    /// Keeps one streamed sample of its axis ([`SEGMENT_BREAK`] starts a new segment).
    pub fn push(&mut self, sample: HallSample) -> Result<(), CalibrationError> {
        let HallSample { axis, counts } = sample;
        match self.calibrators.get_mut(usize::from(axis)) {
            Some(c) if counts == SEGMENT_BREAK => c.new_segment(),
            Some(c) => c.push(counts),
            None => Err(CalibrationError::TooFewSamples),
        }
    }

    /// Fits the sensor model of `axis`, starting from the nominal calibration `initial`.
    // Out of line: a cold path. Inlined into its callers once per axis, its tables
    // and matrices were scalarised into one frame of tens of KB and copied word by
    // word (about 100 KB of flash per caller); see BENCHMARKS.md, Memory.
    #[inline(never)]
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
/// samples, returns the decoders to send with `FinishCalibration` and the fits. An
/// axis whose noise cannot keep its configured fault-error budget is installed with
/// the smallest budget it can keep, reported in its fit's
/// [`SelfCalibration::fault_budget_raised`].
// Out of line: its per-axis decoders and fits are tens of KB of frame, which would
// otherwise add to its caller's (the board's link task; see BENCHMARKS.md, Stack).
#[inline(never)]
pub fn fit_sensors<T: Real, const N: usize>(
    hall: &[HallConfig; N],
    samples: &CalibrationFit<N>,
) -> Result<([HallAxis<T>; N], [SelfCalibration; N]), CalibrationFailure> {
    // Two passes, each array filled in place: a pass of (decoder, fit) pairs held
    // both and their copies in one frame, tens of KB more stack in the link task.
    let fits = build_each(
        "hall",
        hall,
        |axis, hall| {
            let mut fit = samples
                .finish(axis, &hall.calibration)
                .map_err(|error| CalibrationFailure::Fit { axis, error })?;
            // A budget the sensors' noise cannot keep is raised to the one it can, and said.
            fit.fault_budget_raised = hall.with_self_calibration_within_noise(&fit).1;
            Ok(fit)
        },
        CalibrationFailure::Config,
    )?;
    let sensors = build_each(
        "hall",
        hall,
        |axis, hall| {
            // `fits` has an element for every axis.
            let fit = fits.get(axis).ok_or(ConfigError::out_of_range("hall"))?;
            installed_axis(hall, fit).map_err(|e| e.at(axis).within("hall"))
        },
        |e| e,
    )
    .map_err(CalibrationFailure::Config)?;
    Ok((sensors, fits))
}

/// The decoder of one axis with its fit installed. Out of line: its configuration and
/// decoder are temporaries of a few KB that would otherwise sit in `fit_sensors`' frame
/// beside the fit's deepest calls.
#[inline(never)]
fn installed_axis<T: Real>(
    hall: &HallConfig,
    fit: &SelfCalibration,
) -> Result<HallAxis<T>, ConfigError> {
    HallAxis::new(&hall.with_self_calibration_within_noise(fit).0)
}

/// One sample of a Hall calibration sweep: an axis' raw counts ([`SEGMENT_BREAK`]
/// where a coast begins).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HallSample {
    /// Axis index.
    pub axis: u8,
    /// Raw Hall counts.
    pub counts: [u16; 3],
}

/// A machine whose calibration is one fitted Hall decoder per axis, from the samples
/// of its sweep: the slower context's side of `FinishCalibration`.
pub trait HallMachine<const N: usize>: Machine<SweepSample = HallSample> {
    /// Fits the streamed samples into the machine's calibration; also returns the fits.
    fn fit(
        hall: &[HallConfig; N],
        samples: &CalibrationFit<N>,
    ) -> Result<(Self::Calibration, [SelfCalibration; N]), CalibrationFailure>;
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    /// A period short enough that the sweep's count passes u32 (4 ways of 0.148 s
    /// and the 0.2 s rest at 1e-10 s: 7.9e9 periods) is refused, as is a NaN start;
    /// the shortest period whose count fits still builds.
    #[test]
    fn sweep_counts_and_start_are_checked() {
        assert_eq!(
            CalibrationSweep::<f64, 1>::new([0.0], 0.018, 1e-10).err(),
            Some(ConfigError::out_of_range("period_s"))
        );
        assert!(CalibrationSweep::<f64, 1>::new([0.0], 0.018, 1e-9).is_ok());
        assert_eq!(
            CalibrationSweep::<f64, 2>::new([0.0, f64::NAN], 0.018, 1e-4).err(),
            Some(ConfigError::not_finite("start_m").indexed(1))
        );
    }

    #[test]
    fn sweep_goes_out_and_back_and_streams_two_coasts_at_cruise() {
        for ts in [1e-4, 4.17e-4] {
            let mut sweep = CalibrationSweep::<f64, 2>::new([0.004, -0.01], 0.018, ts).unwrap();
            let mut fit = CalibrationFit::<2>::default();
            let (mut first, mut far) = (None, 0.0f64);
            let mut last;
            let mut previous: Option<f64> = None;
            let (mut periods, mut breaks, mut pushed, mut settles) = (0, 0, [0u32; 2], 0);
            let mut coast_speeds = Vec::new();
            loop {
                let r = sweep.reference();
                first.get_or_insert([r[0].position, r[1].position]);
                far = far.max(r[0].position);
                // The reference is continuous and its velocity its derivative.
                if let Some(p) = previous {
                    let v = (r[0].position - p) / ts;
                    assert!(
                        (v - r[0].velocity).abs() < 18.76 * ts / 2.0 + 1e-9,
                        "{v} {r:?}"
                    );
                }
                previous = Some(r[0].position);
                last = [r[0].position, r[1].position];
                assert!((r[1].position - r[0].position + 0.014).abs() < 1e-15);
                if sweep.mode() == SweepMode::Settle {
                    settles += 1;
                    assert_eq!(r[0].velocity.abs(), CRUISE_PITCHES_PER_S * 0.018);
                }
                if sweep.mode() == SweepMode::Coast {
                    coast_speeds.push(r[0].velocity.abs());
                    assert_eq!(r[0].acceleration, 0.0);
                }
                periods += 1;
                // Any healthy-looking counts: only the bookkeeping is under test here.
                let done = sweep.advance(&[[30000, 20000, 15000]; 2], &mut |sample| {
                    if sample.counts == SEGMENT_BREAK {
                        breaks += 1;
                    } else {
                        pushed[usize::from(sample.axis)] += 1;
                    }
                    fit.push(sample).unwrap();
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
            // Two coasts per axis, each a segment of at most SAMPLES_PER_COAST, at the
            // cruise speed throughout, covering more than a pitch.
            assert_eq!(breaks, 4);
            assert!(pushed[0] <= 2 * SAMPLES_PER_COAST, "{pushed:?}");
            assert!(pushed[0] > 2 * 64, "{pushed:?}");
            assert_eq!(pushed[0], pushed[1]);
            let speed = CRUISE_PITCHES_PER_S * 0.018;
            assert!(coast_speeds.iter().all(|v| (v - speed).abs() < 1e-12));
            assert!(coast_speeds.len() as f64 * ts * speed > 0.018);
            // Each settle covers one pitch, to a period.
            assert!((f64::from(settles) * ts * speed - 2.0 * 0.018).abs() < 2.0 * ts * speed);
        }
    }

    /// `backwards` against the reference's own direction: wherever the reference
    /// moves, it says back exactly when the velocity is negative (the sweep goes out
    /// first); it changes three times (out, back, out, back) and the final rest counts
    /// as the last way back.
    #[test]
    fn backwards_is_the_direction_of_the_reference() {
        let mut sweep = CalibrationSweep::<f64, 1>::new([0.004], 0.018, 1e-4).unwrap();
        let (mut changes, mut last, mut moving) = (0, false, 0);
        loop {
            let v = sweep.reference()[0].velocity;
            if v != 0.0 {
                moving += 1;
                assert_eq!(sweep.backwards(), v < 0.0, "period {}: {v}", sweep.period);
            }
            if sweep.backwards() != last {
                changes += 1;
                last = sweep.backwards();
            }
            if sweep.advance(&[[30000, 20000, 15000]], &mut |_| {}) {
                break;
            }
        }
        assert!(last, "the final rest is part of the last way back");
        assert_eq!(changes, 3);
        assert!(moving > 1000, "{moving}");
    }

    /// Coasts of two axes with different sensors (axis 1 with a larger amplitude and
    /// an offset a tenth of it higher): each fit recovers its own axis' amplitude and
    /// offset, and each installed decoder's rail band is its own sensor's range (the
    /// samples' extremes, plus the decoder's 5 % of A margin), so that no axis gets
    /// another's calibration; an axis without samples is named in the error.
    #[test]
    fn fit_sensors_fits_each_axis_from_its_own_samples() {
        use core::f64::consts::PI;
        let hall = [HallConfig::LM1247_16BIT; 2];
        let a = hall[0].amplitude_counts;
        let o = f64::from(hall[0].calibration.offset_counts[0]);
        let sensor = [(o, 0.95 * a), (o + 0.1 * a, 1.08 * a)];
        let sample = |axis: usize, phi: f64| -> [u16; 3] {
            let (offset, amplitude) = sensor[axis];
            core::array::from_fn(|k| {
                let p = phi + 2.0 * PI / 3.0 * k as f64;
                libm::round(offset + amplitude * (libm::sin(p) + 0.02 * libm::sin(3.0 * p))) as u16
            })
        };
        let mut samples = CalibrationFit::<2>::default();
        let mut extremes = [[u16::MAX, 0]; 2];
        // Two coasts per axis of 1.3 pitches each at a constant speed, out and back.
        for (axis, extremes) in extremes.iter_mut().enumerate() {
            for direction in [1.0, -1.0] {
                let at = |counts| HallSample {
                    axis: axis as u8,
                    counts,
                };
                samples.push(at(SEGMENT_BREAK)).unwrap();
                for k in 0..200 {
                    let u = sample(
                        axis,
                        0.4 + direction * 2.0 * PI * 1.3 * f64::from(k) / 200.0,
                    );
                    for c in u {
                        *extremes = [extremes[0].min(c), extremes[1].max(c)];
                    }
                    samples.push(at(u)).unwrap();
                }
            }
        }
        let (sensors, fits) = fit_sensors::<f32, 2>(&hall, &samples).unwrap();
        for axis in 0..2 {
            let (offset, amplitude) = sensor[axis];
            let model = fits[axis].model;
            // Noise-free but for ADC rounding (0.5 LSB of 11000 counts): within 0.1 %.
            assert!(
                (model.mean_amplitude_counts() / amplitude - 1.0).abs() < 1e-3,
                "axis {axis}: {model:?}"
            );
            assert!(
                (model.channels[0].offset_counts - offset).abs() < 1e-3 * amplitude,
                "axis {axis}: {model:?}"
            );
            // The band reaches 5 % of the configured A beyond the healthy range. The
            // samples' extremes miss the model's by up to 1.2 A · (0.02 rad)²/2 =
            // 2.4e-4 A (half their spacing, the curvature with the third harmonic);
            // the fitted model is within 1e-3 A (above): 2e-3 A and a count of
            // rounding leave room, a swapped axis is 0.1 A off.
            let margin = crate::sensing::hall::RAIL_MARGIN * hall[axis].amplitude_counts;
            let band = sensors[axis].decoder().rail_band_counts();
            for [lo, hi] in band {
                let [min, max] = extremes[axis].map(f64::from);
                assert!(
                    (f64::from(lo) - (min - margin)).abs() < 2.0 + 2e-3 * amplitude,
                    "axis {axis}: {lo} against {min}"
                );
                assert!(
                    (f64::from(hi) - (max + margin)).abs() < 2.0 + 2e-3 * amplitude,
                    "axis {axis}: {hi} against {max}"
                );
            }
        }
        let mut one = CalibrationFit::<2>::default();
        for k in 0..200 {
            let counts = sample(0, 2.0 * PI * 1.3 * f64::from(k) / 200.0);
            one.push(HallSample { axis: 0, counts }).unwrap();
        }
        assert_eq!(
            fit_sensors::<f32, 2>(&hall, &one).err(),
            Some(CalibrationFailure::Fit {
                axis: 1,
                error: CalibrationError::TooFewSamples
            })
        );
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
        // Too few periods in a coast for the fit's segment.
        assert_eq!(
            CalibrationSweep::<f32, 1>::new([0.0], 0.018, 0.01).err(),
            Some(ConfigError::out_of_range("period_s"))
        );
    }
}
