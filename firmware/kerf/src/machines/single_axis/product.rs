//! The single axis as it is flashed: its configuration, the link's job buffer and
//! telemetry decimation, the decoder installed as the stored calibration at power-up,
//! and how a G-code program becomes a job. The QEMU image, the simulator and the host
//! tool take these from here.
//!
//! # Moves in G-code
//!
//! What is read ([`load_moves`], with the parser of [`crate::trajectory::gcode`]):
//! `G0`/`G1` moves along X in machine coordinates (the axis' position, so `X10` is
//! 10 mm from the travel's origin), each a rest-to-rest minimum-jerk segment of
//! [`crate::app::joints`]:
//!
//! - a feed move (`G1` at `F`) takes 1.875·D/F, so that its peak speed (1.875 D/T for
//!   a minimum-jerk move, [`crate::trajectory::quintic`]) is the programmed feed;
//! - a rapid (`G0`) takes the shortest time within the machine's speed and
//!   acceleration limits;
//! - the first move starts where the carriage stands at `Start`, unknown when the
//!   program is read: it is timed for the farthest start in the travel (write it as a
//!   `G0` to the program's start);
//! - a move to where the carriage already is takes no time and is left out.
//!
//! Refused, with the line: what the parser refuses (among it `F0`, and a `G1` before
//! any `F`), a move of Y, Z, A or B, a target outside the travel, more moves than a job
//! holds ([`JOB_MOVES`]), no move at all. The machine's own check (speed,
//! acceleration, length) follows at the load.

use crate::app::axis::HallAxis;
use crate::app::joints::{
    JointJob, Joints, JointsConfig, Segment, MAX_SEGMENTS, PEAK_ACCEL_RATIO, PEAK_SPEED_RATIO,
};
use crate::error::{ConfigContext, ConfigError};
use crate::scalar::Real;
use crate::trajectory::gcode::{GcodeError, MoveKind, Parser};

/// The axis as flashed: the LM1247 with its payload at 10 kHz, 0–100 mm of travel.
pub const CONFIG: JointsConfig<1> = JointsConfig::LM1247;

/// The control period, s.
pub const PERIOD_S: f64 = CONFIG.period_s;

/// Moves a job holds.
pub const JOB_MOVES: usize = MAX_SEGMENTS;

/// Bytes of an uploaded job the axis holds: 16 moves are some 300 bytes of G-code;
/// 2 KiB leaves room for comments.
pub const LINK_JOB_BYTES: usize = 2048;

/// The supervisor reports telemetry every this many control periods (1 kHz at the
/// 10 kHz period); the host link decimates further to the rate the host asks for.
pub const TELEMETRY_DECIMATION: u32 = 10;

/// The single axis as flashed.
pub type Axis<T> = Joints<T, 1>;

/// A rapid's time is stretched by this much over the limits' exact bound, so that
/// the machine's check, which computes the same products the other way round, never
/// finds it a rounding error too fast.
const RAPID_MARGIN: f64 = 1.0 + 1e-9;

/// The nominal Hall decoder of the axis, in the scalar `T`: what the machine installs
/// as its stored calibration at power-up.
///
/// Errors: a decoder the scalar cannot carry, named `hall[0]…`.
pub fn nominal_calibration<T: Real>(
    config: &JointsConfig<1>,
) -> Result<[HallAxis<T>; 1], ConfigError> {
    let [hall] = &config.hall;
    Ok([HallAxis::new(hall).at(0).within("hall")?])
}

/// Why a G-code program is not a job of the axis.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MovesErrorKind {
    /// The parser's refusal.
    Gcode(GcodeError),
    /// The program has no move.
    Empty,
    /// A move changes Y, Z, A or B.
    OffAxis,
    /// A target outside the axis' travel.
    OutOfTravel,
    /// More moves than a job holds.
    TooMany,
}

/// A refused program: the 1-based line (0: the whole program) and why.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MovesError {
    /// The line.
    pub line: u32,
    /// Why.
    pub kind: MovesErrorKind,
}

/// The time of a move of `distance_m`: at `feed_m_s` as its peak speed, or for a
/// rapid (`None`) the shortest within `config`'s limits.
fn move_time(config: &JointsConfig<1>, distance_m: f64, feed_m_s: Option<f64>) -> f64 {
    match feed_m_s {
        Some(feed) => PEAK_SPEED_RATIO * distance_m / feed,
        None => {
            let by_speed = PEAK_SPEED_RATIO * distance_m / config.speed_limit_m_s;
            let by_accel = libm::sqrt(PEAK_ACCEL_RATIO * distance_m / config.accel_limit_m_s2);
            RAPID_MARGIN * by_speed.max(by_accel)
        }
    }
}

/// Reads a G-code program of moves along X (module docs) into `job`, in place, for
/// the axis of `config`, line by line without a buffer of points.
///
/// Errors: the first refused line and why; `job` is then empty.
pub fn load_moves(
    config: &JointsConfig<1>,
    text: &[u8],
    job: &mut JointJob<1>,
) -> Result<(), MovesError> {
    job.clear();
    let result = read_moves(config, text, job);
    if result.is_err() {
        job.clear();
    }
    result
}

fn read_moves(
    config: &JointsConfig<1>,
    text: &[u8],
    job: &mut JointJob<1>,
) -> Result<(), MovesError> {
    let [[lo, hi]] = config.travel_m;
    let mut parser = Parser::new();
    let mut at_m: Option<f64> = None;
    for line in text.split(|&b| b == b'\n') {
        if parser.ended() {
            break;
        }
        let moved = parser.parse_line(line).map_err(|e| MovesError {
            line: e.line,
            kind: MovesErrorKind::Gcode(e),
        })?;
        let Some(point) = moved else { continue };
        let err = |kind| MovesError {
            line: point.line,
            kind,
        };
        let [x, y, z] = point.position_m;
        if y != 0.0 || z != 0.0 || point.angles_rad != [0.0; 2] {
            return Err(err(MovesErrorKind::OffAxis));
        }
        // Not `!(lo..=hi).contains`: a NaN is refused too.
        if !(x >= lo && x <= hi) {
            return Err(err(MovesErrorKind::OutOfTravel));
        }
        // A feed move's feed is positive: the parser refuses `F0` and a `G1` before
        // any `F`.
        let feed = match point.kind {
            MoveKind::Rapid => None,
            MoveKind::Feed => Some(point.feed_m_s),
        };
        // The first move from the farthest start in the travel.
        let distance_m = match at_m {
            Some(from) => libm::fabs(x - from),
            None => (x - lo).max(hi - x),
        };
        at_m = Some(x);
        if distance_m == 0.0 {
            continue;
        }
        job.push(Segment {
            target_m: [x],
            duration_s: move_time(config, distance_m, feed),
        })
        .map_err(|_| err(MovesErrorKind::TooMany))?;
    }
    if job.is_empty() {
        return Err(MovesError {
            line: 0,
            kind: MovesErrorKind::Empty,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::app::supervisor::Machine;

    fn load(text: &str) -> Result<JointJob<1>, MovesError> {
        let mut job = JointJob::new();
        load_moves(&CONFIG, text.as_bytes(), &mut job).map(|()| job)
    }

    /// A feed move's peak speed is its feed; a rapid meets a limit exactly (to the
    /// margin); the first move is timed from the farthest end of the travel; the
    /// machine's own check accepts the job.
    #[test]
    fn moves_are_timed_by_their_feed_or_the_limits() {
        let job = load("G21\nG0 X10\nG1 X40 F600\nG1 X40\nG0 X20\nM2\n").unwrap();
        assert_eq!(job.len(), 3, "the move to where it stands is left out");
        // First: a rapid of 90 mm (from the travel's far end), speed-bound:
        // 1.875·0.09/0.5 = 0.3375 s against √(5.7735·0.09/20) = 0.161 s.
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b;
        assert_eq!(job[0].target_m, [0.010]);
        assert!(close(job[0].duration_s, 0.3375 * RAPID_MARGIN));
        // 30 mm at a peak of 10 mm/s: 1.875·3 s.
        assert!(close(job[1].duration_s, 5.625), "{}", job[1].duration_s);
        // 20 mm rapid: speed-bound 0.075 s, acceleration-bound √(5.7735·0.02/20).
        let by_accel = libm::sqrt(5.7735 * 0.02 / 20.0);
        assert!(close(job[2].duration_s, by_accel * RAPID_MARGIN));
        let axis = Axis::<f64>::new(&CONFIG).unwrap();
        assert_eq!(axis.check_job(&job), Ok(()));
    }

    #[test]
    fn programs_the_axis_cannot_run_are_refused_with_their_line() {
        let kind = |text: &str| load(text).map(|_| ()).map_err(|e| (e.line, e.kind));
        assert_eq!(kind("G1 X10 Y1 F600\n"), Err((1, MovesErrorKind::OffAxis)));
        assert!(matches!(
            kind("G0 X10\nG1 X20 F0\n"),
            Err((2, MovesErrorKind::Gcode(_)))
        ));
        assert_eq!(kind("G0 X101\n"), Err((1, MovesErrorKind::OutOfTravel)));
        assert_eq!(kind("G0 X-1\n"), Err((1, MovesErrorKind::OutOfTravel)));
        assert_eq!(kind("G21\n(nothing)\n"), Err((0, MovesErrorKind::Empty)));
        let mut many = std::string::String::new();
        for k in 0..=JOB_MOVES {
            many.push_str(&std::format!("G0 X{}\n", 10 + 10 * (k % 2)));
        }
        assert_eq!(
            kind(&many),
            Err((JOB_MOVES as u32 + 1, MovesErrorKind::TooMany))
        );
        assert!(matches!(
            kind("G1 X10 Q3\n"),
            Err((1, MovesErrorKind::Gcode(_)))
        ));
    }

    /// The stored calibration at power-up decodes as the configured decoder.
    #[test]
    fn the_nominal_calibration_is_the_configured_decoder() {
        let [stored] = nominal_calibration::<f32>(&CONFIG).unwrap();
        assert_eq!(stored, HallAxis::new(&CONFIG.hall[0]).unwrap());
        let mut bad = CONFIG;
        bad.hall[0].pitch_m = f64::NAN;
        let e = nominal_calibration::<f32>(&bad).unwrap_err();
        assert!(std::format!("{e}").starts_with("hall[0]"), "{e}");
    }
}
