//! The autofocus stage as it is flashed: its control and camera periods, the window
//! its sharpness is taken over, its travel and zoom, the law's preset, the link's job
//! buffer and telemetry decimation, and how a schedule job becomes a zoom schedule.
//! The QEMU image, the simulator and the host tool take these from here.
//!
//! # The zoom schedule
//!
//! A job is a schedule file ([`crate::codec::job`], kind schedule): steps of
//! (magnification, dwell s), read by [`load_schedule`] into at most [`JOB_STEPS`]
//! steps. Each step commands the zoom to its magnification and runs the focus law for
//! its dwell; the law sees the zoom change as a change of the held sharpness and
//! searches again (docs/control.md §24, [`crate::control::autofocus`]). The loader
//! refuses another kind of job and more steps than a job holds; the machine's check
//! ([`super::FocusStage`]) refuses a magnification outside the zoom's range and a
//! dwell that is not positive or longer than [`MAX_DWELL_S`].

use super::{StageConfig, ZoomSchedule, ZoomStep};
use crate::codec::job::JobFile;
use crate::control::autofocus::AutofocusConfig;
use crate::sensing::sharpness::Window;

/// The control period, s: the focus axis' acceleration command at 1 kHz, as the law
/// was tuned for (docs/control.md §24).
pub const PERIOD_S: f64 = 1e-3;

/// The camera's frame period, s (100 frames/s).
pub const FRAME_PERIOD_S: f64 = AutofocusConfig::FOCUS_10MM_100FPS.frame_period_s;

/// Control periods per camera frame.
pub const PERIODS_PER_FRAME: u32 = periods(FRAME_PERIOD_S);

/// The camera's frame side, px: the board's camera reads out a 64 × 64 8-bit window
/// of interest (4 KiB) by DMA, once per frame.
pub const FRAME_SIDE_PX: usize = 64;

/// Bytes of a frame.
pub const FRAME_BYTES: usize = FRAME_SIDE_PX * FRAME_SIDE_PX;

/// The window the sharpness is taken over: the whole frame.
pub const WINDOW: Window = Window {
    x_px: 0,
    y_px: 0,
    width_px: FRAME_SIDE_PX,
    height_px: FRAME_SIDE_PX,
};

/// Frames in the law's gradient window (the ring of [`crate::control::autofocus`]):
/// 32 frames, 0.32 s, span δ at the slowest speed the law tracks at.
pub const RING: usize = 32;

/// The focus axis' hard stops, m: 0 and 10 mm; the law's soft travel keeps 0.2 mm
/// inside them ([`AutofocusConfig::FOCUS_10MM_100FPS`]).
pub const STOPS_M: [f64; 2] = [0.0, 10e-3];

/// The zoom's range of magnification.
pub const ZOOM_RANGE: [f64; 2] = [1.0, 3.0];

/// The magnification the zoom stands at at power-up.
pub const POWER_UP_MAGNIFICATION: f64 = 1.0;

/// Frames that may go missing in a row before the machine stops (a dropped frame is
/// survivable; five in a row is a camera that stopped).
pub const MISSED_FRAMES: u32 = 5;

/// Steps a job holds.
pub const JOB_STEPS: usize = 16;

/// The longest dwell of a step, s (ten minutes: a step's periods fit a `u32` at any
/// period the link can announce).
pub const MAX_DWELL_S: f64 = 600.0;

/// Bytes of an uploaded job the stage holds: a schedule of [`JOB_STEPS`] steps is
/// 12 + 8·16 + 4 = 144 bytes.
pub const LINK_JOB_BYTES: usize = 256;

/// The supervisor reports telemetry every this many control periods (once per frame,
/// 100 Hz); the host link decimates further to the rate the host asks for.
pub const TELEMETRY_DECIMATION: u32 = PERIODS_PER_FRAME;

/// The velocity observer's bandwidth at power-up, Hz: five times the law's velocity
/// loop (C = 50 s⁻¹ is 8 Hz) is 40 Hz; 100 Hz keeps its lag (2/ω = 3 ms at constant
/// acceleration) below a third of a frame.
pub const VELOCITY_BANDWIDTH_HZ: f64 = 100.0;

/// Whole periods of `duration_s` at [`PERIOD_S`], rounded (`const`: at build time).
const fn periods(duration_s: f64) -> u32 {
    (duration_s / PERIOD_S + 0.5) as u32
}

/// The stage as flashed.
pub const CONFIG: StageConfig = StageConfig {
    period_s: PERIOD_S,
    periods_per_frame: PERIODS_PER_FRAME,
    missed_frames: MISSED_FRAMES,
    stops_m: STOPS_M,
    zoom_range: ZOOM_RANGE,
    power_up_magnification: POWER_UP_MAGNIFICATION,
    max_dwell_periods: periods(MAX_DWELL_S),
};

/// The law at power-up: the preset of [`crate::control::autofocus`] for this camera
/// and travel (its docs say why each value).
pub const LAW: AutofocusConfig = AutofocusConfig::FOCUS_10MM_100FPS;

const _: () = assert!(PERIODS_PER_FRAME == 10 && CONFIG.max_dwell_periods == 600_000);
const _: () = assert!(LAW.travel_m[0] > STOPS_M[0] && LAW.travel_m[1] < STOPS_M[1]);

/// Refusals of [`load_schedule`] (the machine's own are the link's
/// `job_error_code`s).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ScheduleError {
    /// Not a schedule job.
    Kind,
    /// More steps than a job holds.
    TooMany,
}

/// A step's dwell in whole periods of `config`, rounded; 0 for a dwell that is not
/// finite and positive, and one period past the limit for a dwell beyond it, so that
/// the machine's check refuses both.
fn dwell_periods(config: &StageConfig, dwell_s: f64) -> u32 {
    // A NaN is refused with the rest.
    if dwell_s.is_nan() || dwell_s <= 0.0 {
        return 0;
    }
    let periods = libm::round(dwell_s / config.period_s);
    let limit = f64::from(config.max_dwell_periods);
    if periods > limit {
        config.max_dwell_periods.saturating_add(1)
    } else {
        periods as u32
    }
}

/// Reads a schedule job into `job`, in place, for the stage of `config`.
///
/// Errors: another kind of job, more than [`JOB_STEPS`] steps; `job` is then empty.
pub fn load_schedule(
    config: &StageConfig,
    file: &JobFile<'_>,
    job: &mut ZoomSchedule,
) -> Result<(), ScheduleError> {
    job.clear();
    let JobFile::Schedule { .. } = file else {
        return Err(ScheduleError::Kind);
    };
    for k in 0..file.count() {
        let Some([magnification, dwell_s]) = file.step(k) else {
            break;
        };
        let step = ZoomStep {
            magnification,
            dwell_periods: dwell_periods(config, f64::from(dwell_s)),
        };
        if job.push(step).is_err() {
            job.clear();
            return Err(ScheduleError::TooMany);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codec::job::{write_gcode, write_schedule};

    fn load(steps: &[[f64; 2]]) -> Result<ZoomSchedule, ScheduleError> {
        let mut bytes = [0u8; 512];
        let n = write_schedule(steps, &mut bytes).unwrap();
        let file = JobFile::read(&bytes[..n]).unwrap();
        let mut job = ZoomSchedule::new();
        load_schedule(&CONFIG, &file, &mut job).map(|()| job)
    }

    /// Dwell times become whole periods; a dwell the machine must refuse stays
    /// refusable (0, or past the limit) instead of wrapping or saturating into range.
    #[test]
    fn a_schedule_loads_into_steps_of_whole_periods() {
        let job = load(&[[1.0, 6.0], [2.0, 0.0104], [1.5, -1.0], [1.0, 1e9]]).unwrap();
        let periods: std::vec::Vec<u32> = job.iter().map(|s| s.dwell_periods).collect();
        assert_eq!(periods, [6000, 10, 0, CONFIG.max_dwell_periods + 1]);
        assert_eq!(job[1].magnification, 2.0);
        let mut bytes = [0u8; 64];
        let n = write_gcode(b"G0 X1\n", &mut bytes).unwrap();
        let file = JobFile::read(&bytes[..n]).unwrap();
        let mut job = load(&[[1.0, 1.0]]).unwrap();
        assert_eq!(
            load_schedule(&CONFIG, &file, &mut job),
            Err(ScheduleError::Kind)
        );
        assert!(job.is_empty());
        let many = [[1.0, 1.0]; JOB_STEPS + 1];
        assert_eq!(load(&many), Err(ScheduleError::TooMany));
        assert_eq!(load(&many[..JOB_STEPS]).map(|j| j.len()), Ok(JOB_STEPS));
    }
}
