//! Circular arcs `G2` (clockwise) and `G3` (counter-clockwise) in the selected plane,
//! from a centre (`I J K`) or a radius (`R`), cut into chords.
//!
//! # Chords
//!
//! A chord subtending the angle φ on a circle of radius r stands off the arc by its
//! sagitta s = r·(1 − cos(φ/2)). Keeping s ≤ the caller's tolerance t gives
//! φ ≤ φ_max = 2·acos(1 − t/r); an arc sweeping Δθ is cut into n = ⌈|Δθ|/φ_max⌉ equal
//! chords (at least one).
//!
//! # Tolerances
//!
//! As grbl (`gcode.c`): the end of an arc given by its centre may lie off the circle
//! through its start by at most max(0.005 mm, 0.1 % of the radius); an arc given by a
//! radius shorter than half the distance to its end by at most as much is read as a
//! half circle, one shorter still is refused. An end at the start (within grbl's
//! 5·10⁻⁷ rad) is a full circle.

use super::diagnostic::GcodeErrorKind;
use core::f64::consts::PI;

/// Absolute part of the radius tolerance, m (grbl's 0.005 mm).
const RADIUS_TOLERANCE_M: f64 = 0.005e-3;

/// Relative part of the radius tolerance (grbl's 0.1 %).
const RADIUS_TOLERANCE_RATIO: f64 = 1e-3;

/// Angle under which an end is at the start: a full circle (grbl's
/// `ARC_ANGULAR_TRAVEL_EPSILON`).
const FULL_CIRCLE_RAD: f64 = 5e-7;

/// Most chords of one arc: beyond, the tolerance is too fine for the radius.
pub(super) const MAX_CHORDS: u32 = 1 << 20;

/// An arc in its plane: the two in-plane coordinates of its centre, its radius, the
/// angle of its start and its signed sweep (positive counter-clockwise).
#[derive(Copy, Clone, Debug, PartialEq)]
pub(super) struct Arc {
    pub center: [f64; 2],
    pub radius: f64,
    pub start_rad: f64,
    pub sweep_rad: f64,
}

fn tolerance(radius: f64) -> f64 {
    RADIUS_TOLERANCE_M.max(RADIUS_TOLERANCE_RATIO * radius)
}

fn hypot(v: [f64; 2]) -> f64 {
    libm::hypot(v[0], v[1])
}

/// The arc from `start` to `end` about `center` (in-plane coordinates), clockwise or
/// not, with `turns` ≥ 1 (LinuxCNC's `P`: full turns added beyond the first).
pub(super) fn about_center(
    start: [f64; 2],
    end: [f64; 2],
    center: [f64; 2],
    clockwise: bool,
    turns: u32,
) -> Result<Arc, GcodeErrorKind> {
    let [sx, sy] = [start[0] - center[0], start[1] - center[1]];
    let [ex, ey] = [end[0] - center[0], end[1] - center[1]];
    let radius = hypot([sx, sy]);
    let end_radius = hypot([ex, ey]);
    let off = libm::fabs(radius - end_radius);
    // NaN-safe: a NaN radius or difference is refused.
    if radius.is_nan() || radius <= 0.0 || off.is_nan() || off > tolerance(radius) {
        return Err(GcodeErrorKind::ArcRadiusMismatch);
    }
    Ok(sweep(center, radius, [sx, sy], [ex, ey], clockwise, turns))
}

fn sweep(
    center: [f64; 2],
    radius: f64,
    [sx, sy]: [f64; 2],
    [ex, ey]: [f64; 2],
    clockwise: bool,
    turns: u32,
) -> Arc {
    // The angle from start to end in (−π, π], as grbl.
    let mut sweep_rad = libm::atan2(sx * ey - sy * ex, sx * ex + sy * ey);
    if clockwise {
        if sweep_rad >= -FULL_CIRCLE_RAD {
            sweep_rad -= 2.0 * PI;
        }
    } else if sweep_rad <= FULL_CIRCLE_RAD {
        sweep_rad += 2.0 * PI;
    }
    let extra = f64::from(turns.saturating_sub(1)) * 2.0 * PI;
    sweep_rad += if clockwise { -extra } else { extra };
    Arc {
        center,
        radius,
        start_rad: libm::atan2(sy, sx),
        sweep_rad,
    }
}

/// The arc from `start` to `end` of radius |`radius`|: the shorter way round for a
/// positive radius, the longer for a negative one (RS-274).
pub(super) fn of_radius(
    start: [f64; 2],
    end: [f64; 2],
    radius: f64,
    clockwise: bool,
    turns: u32,
) -> Result<Arc, GcodeErrorKind> {
    let d = [end[0] - start[0], end[1] - start[1]];
    let chord = hypot(d);
    let r = libm::fabs(radius);
    if chord.is_nan() || chord <= 0.0 || r.is_nan() || r <= 0.0 {
        return Err(GcodeErrorKind::ArcUndefined);
    }
    let half = chord / 2.0;
    let h2 = r * r - half * half;
    if h2 < 0.0 && half - r > tolerance(r) {
        return Err(GcodeErrorKind::ArcRadiusMismatch);
    }
    let h = libm::sqrt(h2.max(0.0));
    // The centre of a counter-clockwise arc is on the left of its way, so on the left
    // of the chord for the shorter arc; clockwise or the longer arc, on the right.
    let left = [-d[1] / chord, d[0] / chord];
    let side = if clockwise == (radius < 0.0) {
        1.0
    } else {
        -1.0
    };
    let center = [
        (start[0] + end[0]) / 2.0 + side * h * left[0],
        (start[1] + end[1]) / 2.0 + side * h * left[1],
    ];
    let radius = r.max(half);
    let s = [start[0] - center[0], start[1] - center[1]];
    let e = [end[0] - center[0], end[1] - center[1]];
    Ok(sweep(center, radius, s, e, clockwise, turns))
}

impl Arc {
    /// Chords keeping each sagitta within `tolerance_m` (module docs).
    pub fn chords(&self, tolerance_m: f64) -> Result<u32, GcodeErrorKind> {
        let cos = (1.0 - tolerance_m / self.radius).clamp(-1.0, 1.0);
        let max_rad = 2.0 * libm::acos(cos);
        let n = libm::ceil(libm::fabs(self.sweep_rad) / max_rad);
        if n.is_nan() || n > f64::from(MAX_CHORDS) {
            return Err(GcodeErrorKind::ArcTooFine);
        }
        // Within 1..=MAX_CHORDS: the conversion is exact.
        Ok((n as u32).max(1))
    }

    /// The in-plane point at fraction `u` ∈ [0, 1] of the sweep.
    pub fn at(&self, u: f64) -> [f64; 2] {
        let a = self.start_rad + u * self.sweep_rad;
        [
            self.center[0] + self.radius * libm::cos(a),
            self.center[1] + self.radius * libm::sin(a),
        ]
    }
}
