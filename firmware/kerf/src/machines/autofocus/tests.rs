//! The stage's periods on a synthetic bench: a focus axis that follows the
//! acceleration command exactly (q̈ = a, integrated exactly over a period) between
//! hard stops, and a camera whose window moments have a known sharpness S(q, m) with
//! one peak at q_f(m) = 2 mm + 3 mm (m − 1) (the focus of `hal_mock::focus`'s
//! inspection camera). Each frame is read out one frame period after its exposure,
//! with the position latched at the exposure, as a camera's DMA delivers it.

use super::product::{CONFIG, LAW, PERIODS_PER_FRAME, VELOCITY_BANDWIDTH_HZ};
use super::*;
use core::f64::consts::TAU;
use std::vec::Vec;

/// Pixels of the window, and its mean grey level.
const PIXELS: u32 = 4096;
const MEAN: f64 = 120.0;

/// Moments of a window of mean [`MEAN`] whose normalized variance is `s`.
fn moments(s: f64) -> WindowMoments {
    let n = f64::from(PIXELS);
    let sum = (n * MEAN) as u32;
    // S = variance / mean, and S2 = n (variance + mean²).
    let sum_of_squares = libm::round(n * (s * MEAN + MEAN * MEAN)) as u64;
    WindowMoments {
        pixels: PIXELS,
        sum,
        sum_of_squares,
    }
}

fn focus_m(m: f64) -> f64 {
    2e-3 + 3e-3 * (m - 1.0)
}

/// A peak of height 20 m² over a floor of 0.5 grey levels, of half-width 2 mm / m: a
/// Lorentzian, whose relative curvature at the peak (2/w² = 5e5 m⁻² at m = 1) is the
/// inspection camera's (docs of `AutofocusConfig::FOCUS_10MM_100FPS`) and whose
/// flanks keep a relative gradient of a few hundred per metre across the travel.
fn sharpness(q: f64, m: f64, focus: f64) -> f64 {
    let w = 2e-3 / m;
    let d = (q - focus) / w;
    0.5 + 20.0 * m * m / (1.0 + d * d)
}

fn law() -> FocusLaw<f64> {
    let velocity = TrackingObserverConfig {
        bandwidth_rad_s: TAU * VELOCITY_BANDWIDTH_HZ,
    };
    FocusLaw::new(&LAW, &velocity, CONFIG.period_s).unwrap()
}

struct Bench {
    stage: FocusStage<f64>,
    q: f64,
    v: f64,
    period: u32,
    /// The frame being read out: exposure position and sharpness.
    pending: Option<(f64, f64)>,
    /// Where the peak is, for a magnification.
    focus: fn(f64) -> f64,
}

impl Bench {
    fn new(q: f64) -> Self {
        Self {
            stage: FocusStage::new(&CONFIG, law()).unwrap(),
            q,
            v: 0.0,
            period: 0,
            pending: None,
            focus: focus_m,
        }
    }

    /// This period's inputs: a frame every [`PERIODS_PER_FRAME`] periods, the one
    /// exposed a frame earlier (`sharpness` overrides the model's).
    fn inputs(&mut self, m: f64, frames: bool) -> StageInputs<f64> {
        let mut frame = None;
        if self.period % PERIODS_PER_FRAME == 0 && frames {
            frame = self.pending.take().map(|(q, s)| Frame {
                moments: moments(s),
                exposure_position_m: q,
            });
            self.pending = Some((self.q, sharpness(self.q, m, (self.focus)(m))));
        }
        self.period += 1;
        StageInputs {
            position_m: self.q,
            frame,
        }
    }

    /// The axis under the command, between the stops at 0 and 10 mm.
    fn apply(&mut self, outputs: &StageOutputs<f64>) {
        let (a, h) = (outputs.acceleration_m_s2, CONFIG.period_s);
        self.q += self.v * h + 0.5 * a * h * h;
        self.v += a * h;
        let [lo, hi] = CONFIG.stops_m;
        if self.q < lo || self.q > hi {
            self.q = self.q.clamp(lo, hi);
            self.v = 0.0;
        }
    }

    /// Runs `job` until it ends: the positions at the end of each step with their
    /// magnification, and the periods run; or the fault.
    fn run(&mut self, job: &ZoomSchedule) -> Result<(Vec<(f64, f64)>, u32), StageFault> {
        self.stage.check_job(job).unwrap();
        self.stage.begin_job(job).unwrap();
        let mut ends = Vec::new();
        let mut m = self.stage.safe_outputs().magnification;
        for k in 0.. {
            let inputs = self.inputs(m, true);
            let step = self.stage.run(job, &inputs)?;
            let (Step::Continue(outputs) | Step::Done(outputs)) = step;
            m = outputs.magnification;
            let t = self.stage.telemetry();
            if usize::from(t.step) > ends.len() {
                ends.push((self.q, m));
            }
            self.apply(&outputs);
            if let Step::Done(_) = step {
                return Ok((ends, k + 1));
            }
        }
        unreachable!()
    }
}

fn schedule(steps: &[(f32, f64)]) -> ZoomSchedule {
    steps
        .iter()
        .map(|&(magnification, dwell_s)| ZoomStep {
            magnification,
            dwell_periods: (dwell_s / CONFIG.period_s) as u32,
        })
        .collect()
}

/// From 7 mm off focus, then through two zoom changes (the focus moving 3 mm, then
/// back 1.5 mm), the axis rests at each step's peak. Bound: the law holds once its 32
/// frames (0.32 s) span less than δ = 0.1 mm, a speed below 0.31 mm/s; near the peak
/// the law is linear at a rate μ0 α κ/2 of at least 5 s⁻¹ (κ = 5e5 m⁻² at m = 1), so
/// it holds within 0.06 mm of the peak: 0.1 mm allows for the frame's latency. The
/// job ends at rest within the schedule and the ramp's limit.
#[test]
fn each_step_of_a_schedule_comes_to_rest_at_its_peak() {
    let mut bench = Bench::new(9e-3);
    let job = schedule(&[(1.0, 6.0), (2.0, 4.0), (1.5, 4.0)]);
    let (ends, periods) = bench.run(&job).unwrap();
    assert_eq!(ends.len(), 3);
    for (q, m) in &ends {
        let error = q - focus_m(*m);
        assert!(error.abs() < 1e-4, "m {m}: {:.1} um off", error * 1e6);
    }
    let schedule_periods = 14_000;
    assert!(periods > schedule_periods && periods < schedule_periods + 500);
    assert!(bench.v.abs() < 1e-4, "{} m/s", bench.v);
}

/// A stop ramps the reference to zero and ends with the axis at rest.
#[test]
fn a_stop_ends_at_rest() {
    let mut bench = Bench::new(9e-3);
    let job = schedule(&[(1.0, 10.0)]);
    bench.stage.begin_job(&job).unwrap();
    for _ in 0..500 {
        let inputs = bench.inputs(1.0, true);
        let (Step::Continue(o) | Step::Done(o)) = bench.stage.run(&job, &inputs).unwrap();
        bench.apply(&o);
    }
    assert!(bench.v.abs() > 1e-3, "moving when stopped: {} m/s", bench.v);
    bench.stage.begin_stop();
    let mut periods = 0;
    loop {
        let inputs = bench.inputs(1.0, true);
        let step = bench.stage.stop(&job, &inputs).unwrap();
        let (Step::Continue(o) | Step::Done(o)) = step;
        bench.apply(&o);
        periods += 1;
        if let Step::Done(_) = step {
            break;
        }
    }
    assert!(periods < 100, "{periods} periods");
    assert!(bench.v.abs() < 1e-4, "{} m/s", bench.v);
}

/// Runs `job` on `bench` for at most `periods`, with frames while `frames(k)`, and
/// `position(k, q)` as the position read; the fault, if one came.
fn fault_of(
    bench: &mut Bench,
    periods: u32,
    frames: impl Fn(u32) -> bool,
    position: impl Fn(u32, f64) -> f64,
) -> Option<(StageFault, u32)> {
    let job = schedule(&[(1.0, 100.0)]);
    bench.stage.begin_job(&job).unwrap();
    for k in 0..periods {
        let mut inputs = bench.inputs(1.0, frames(k));
        inputs.position_m = position(k, inputs.position_m);
        match bench.stage.run(&job, &inputs) {
            Ok(Step::Continue(o) | Step::Done(o)) => bench.apply(&o),
            Err(fault) => return Some((fault, k)),
        }
    }
    None
}

/// Frames that stop: the fault after five frame periods without one, not before.
#[test]
fn missing_frames_stop_the_stage_after_five_frame_periods() {
    let mut bench = Bench::new(5e-3);
    let (fault, at) = fault_of(&mut bench, 2000, |k| k < 1000, |_, q| q).unwrap();
    assert_eq!(fault, StageFault::FrameMissing);
    // The last frame came at period 990; 50 periods without one are allowed.
    assert_eq!(at, 990 + 5 * PERIODS_PER_FRAME + 1);
}

/// A position not finite, the axis at a hard stop: faults of their own.
#[test]
fn bad_positions_are_faults() {
    let mut bench = Bench::new(5e-3);
    let nan = |k, q| if k == 300 { f64::NAN } else { q };
    assert_eq!(
        fault_of(&mut bench, 1000, |_| true, nan),
        Some((StageFault::NotFinite, 300))
    );
    let mut bench = Bench::new(5e-3);
    let stop = |k, q| if k == 300 { 10e-3 } else { q };
    assert_eq!(
        fault_of(&mut bench, 1000, |_| true, stop),
        Some((StageFault::HardStop { upper: true }, 300))
    );
}

/// The frame itself: a dark one, a flat one (no texture), a NaN exposure position.
#[test]
fn bad_frames_are_faults_in_their_words() {
    let mut stage = FocusStage::new(&CONFIG, law()).unwrap();
    let job = schedule(&[(1.0, 1.0)]);
    let frame = |moments, exposure_position_m| StageInputs {
        position_m: 5e-3,
        frame: Some(Frame {
            moments,
            exposure_position_m,
        }),
    };
    let dark = WindowMoments {
        pixels: PIXELS,
        sum: 0,
        sum_of_squares: 0,
    };
    let flat = WindowMoments {
        pixels: PIXELS,
        sum: PIXELS * 120,
        sum_of_squares: u64::from(PIXELS) * 120 * 120,
    };
    for (inputs, fault) in [
        (frame(dark, 5e-3), StageFault::DarkFrame),
        (frame(flat, 5e-3), StageFault::NoTexture),
        (frame(moments(3.0), f64::NAN), StageFault::NotFinite),
    ] {
        stage.begin_job(&job).unwrap();
        assert_eq!(stage.run(&job, &inputs), Err(fault));
        stage.reset();
    }
}

/// A scene whose peak lies beyond the travel (at 20 mm): the law climbs to the end of
/// its travel and rests there, which is the fault that no peak was found; sooner
/// than a blind sweep of the 9.6 mm travel at the search speed (9.6 s) would say so.
#[test]
fn a_peak_beyond_the_travel_is_not_found() {
    let mut bench = Bench::new(5e-3);
    bench.focus = |_| 20e-3;
    let (fault, at) = fault_of(&mut bench, 20_000, |_| true, |_, q| q).unwrap();
    assert_eq!(fault, StageFault::NoPeak);
    assert!(bench.q > 9.6e-3 && bench.q < 10e-3, "{} m", bench.q);
    assert!(at < 9600, "after {at} periods");
}

/// Schedules the stage cannot run are refused with the step.
#[test]
fn schedules_outside_the_zoom_or_the_dwell_limit_are_refused() {
    let stage = FocusStage::new(&CONFIG, law()).unwrap();
    assert_eq!(stage.check_job(&schedule(&[])), Err(JobError::Empty));
    for (steps, error) in [
        (
            &[(1.0, 1.0), (0.5, 1.0)][..],
            JobError::Magnification { step: 1 },
        ),
        (&[(3.5, 1.0)], JobError::Magnification { step: 0 }),
        (&[(f32::NAN, 1.0)], JobError::Magnification { step: 0 }),
        (&[(2.0, 1.0), (2.0, 0.0)], JobError::Dwell { step: 1 }),
        (&[(2.0, 601.0)], JobError::Dwell { step: 0 }),
    ] {
        assert_eq!(stage.check_job(&schedule(steps)), Err(error), "{steps:?}");
    }
    assert_eq!(
        stage.check_job(&schedule(&[(1.0, 1.0), (3.0, 600.0)])),
        Ok(())
    );
}

/// A bad law or observer is named by its path; so is a window excursion that leaves
/// no room for a peak in the travel.
#[test]
fn a_bad_configuration_is_named_by_its_path() {
    let velocity = TrackingObserverConfig {
        bandwidth_rad_s: TAU * 400.0,
    };
    let e = FocusLaw::<f32>::new(&LAW, &velocity, CONFIG.period_s).unwrap_err();
    assert_eq!(std::format!("{}", e.path), "velocity.bandwidth_rad_s");
    let velocity = TrackingObserverConfig {
        bandwidth_rad_s: TAU * 100.0,
    };
    let wide = AutofocusConfig {
        window_excursion_m: 3e-3,
        ..LAW
    };
    let e = FocusLaw::<f32>::new(&wide, &velocity, CONFIG.period_s).unwrap_err();
    assert_eq!(std::format!("{}", e.path), "law.window_excursion_m");
    let mut config = CONFIG;
    config.stops_m = [10e-3, 0.0];
    let e = FocusStage::new(&config, law()).err().unwrap();
    assert_eq!(e.field(), "stops_m");
}
