//! Test contours used by the scenarios, in metres, sized for a delta workspace of a
//! few tens of millimetres and centred near the origin. They stand in for the image
//! data of T fig. 8.4 (8-lobe cam, gear, octagon: closed) and fig. 8.1–8.2 (handwritten
//! 'e' and 's': open). Closed contours do not repeat their first point.

use core::f64::consts::PI;

/// Points of [`gear`]: 12 teeth × 26.
pub const GEAR_POINTS: usize = 12 * GEAR_POINTS_PER_TOOTH;
const GEAR_POINTS_PER_TOOTH: usize = 26;
/// Points of [`cam`].
pub const CAM_POINTS: usize = 256;
/// Points of [`octagon`]: 8 sides × 8.
pub const OCTAGON_POINTS: usize = 64;
/// Points of [`letter_e`].
pub const LETTER_E_POINTS: usize = 29;
/// Points of [`letter_s`].
pub const LETTER_S_POINTS: usize = 25;

/// Tip radius of [`gear`], m.
pub const GEAR_TIP_RADIUS_M: f64 = 10e-3;
/// Root radius of [`gear`], m.
pub const GEAR_ROOT_RADIUS_M: f64 = 8e-3;
/// Circumradius of [`octagon`], m.
pub const OCTAGON_RADIUS_M: f64 = 10e-3;

fn polar(r: f64, phi: f64) -> [f64; 2] {
    [r * libm::cos(phi), r * libm::sin(phi)]
}

fn lerp(a: [f64; 2], b: [f64; 2], u: f64) -> [f64; 2] {
    [a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])]
}

/// 12-tooth gear: per tooth (pitch P = 30°) a root arc over 0.30 P, a straight rising
/// flank over 0.15 P, a tip arc over 0.40 P and a straight falling flank over 0.15 P.
/// The straight flanks are what the constraint's line fallback is for.
pub fn gear() -> [[f64; 2]; GEAR_POINTS] {
    let pitch = 2.0 * PI / 12.0;
    let (rr, rt) = (GEAR_ROOT_RADIUS_M, GEAR_TIP_RADIUS_M);
    core::array::from_fn(|i| {
        let tooth = (i / GEAR_POINTS_PER_TOOTH) as f64;
        let j = i % GEAR_POINTS_PER_TOOTH;
        let base = tooth * pitch;
        // (first point index, points in the section, start/end angle fractions)
        let at = |f: f64| base + f * pitch;
        match j {
            0..=5 => polar(rr, at(0.30 * j as f64 / 6.0)),
            6..=11 => lerp(
                polar(rr, at(0.30)),
                polar(rt, at(0.45)),
                (j - 6) as f64 / 6.0,
            ),
            12..=19 => polar(rt, at(0.45 + 0.40 * (j - 12) as f64 / 8.0)),
            _ => lerp(
                polar(rt, at(0.85)),
                polar(rr, at(1.0)),
                (j - 20) as f64 / 6.0,
            ),
        }
    })
}

/// Eight-lobe cam r(φ) = 9 mm + 0.8 mm·cos 8φ, sampled at equal angles.
pub fn cam() -> [[f64; 2]; CAM_POINTS] {
    core::array::from_fn(|i| {
        let phi = 2.0 * PI * i as f64 / CAM_POINTS as f64;
        polar(9e-3 + 0.8e-3 * libm::cos(8.0 * phi), phi)
    })
}

/// Regular octagon of circumradius [`OCTAGON_RADIUS_M`], first vertex on +x, 8 points
/// per side (vertices included): points on the edges for the resampling and fit tests.
pub fn octagon() -> [[f64; 2]; OCTAGON_POINTS] {
    regular_polygon(8, OCTAGON_RADIUS_M)
}

/// Regular `sides`-gon of circumradius `radius_m`, first vertex on +x, counter-clockwise,
/// with `P / sides` equally spaced points per side (P must be a multiple of `sides`).
/// A non-finite radius gives non-finite points (refused by every contour constructor).
/// `sides` = 0 is taken as 1 (every point on the circle's first vertex: no 2π/0).
pub fn regular_polygon<const P: usize>(sides: usize, radius_m: f64) -> [[f64; 2]; P] {
    let sides = sides.max(1);
    let per_side = (P / sides).max(1);
    core::array::from_fn(|i| {
        let side = (i / per_side) as f64;
        let u = (i % per_side) as f64 / per_side as f64;
        let step = 2.0 * PI / sides as f64;
        lerp(
            polar(radius_m, side * step),
            polar(radius_m, (side + 1.0) * step),
            u,
        )
    })
}

/// Ellipse with semi-axes `a_m` (x) and `b_m` (y) sampled at `P` equal parameter steps
/// (a circle when `a_m == b_m`). Non-finite semi-axes give non-finite points: this is
/// test data, and every contour constructor refuses them.
pub fn ellipse<const P: usize>(a_m: f64, b_m: f64) -> [[f64; 2]; P] {
    core::array::from_fn(|i| {
        let t = 2.0 * PI * i as f64 / P as f64;
        [a_m * libm::cos(t), b_m * libm::sin(t)]
    })
}

/// Handwritten 'e' (open, coarse like image data): a bar from (−6, 0) mm to (5, 0) mm,
/// then a 320° counter-clockwise loop of radius 5 mm about the origin. The loop crosses
/// the bar at (−5, 0) mm, and the bar meets the loop at a right-angle corner.
pub fn letter_e() -> [[f64; 2]; LETTER_E_POINTS] {
    const BAR: usize = 8;
    core::array::from_fn(|i| {
        if i < BAR {
            [(-6.0 + 11.0 * i as f64 / BAR as f64) * 1e-3, 0.0]
        } else {
            let u = (i - BAR) as f64 / (LETTER_E_POINTS - BAR - 1) as f64;
            polar(5e-3, u * 320.0_f64.to_radians())
        }
    })
}

/// Handwritten 's' (open): an upper bowl (radius 4 mm about (0, 4) mm) from 30° counter-
/// clockwise to 270°, then a lower bowl (about (0, −4) mm) from 90° clockwise to −150°.
/// The two bowls join tangentially at the origin, where the curvature changes sign.
pub fn letter_s() -> [[f64; 2]; LETTER_S_POINTS] {
    const UPPER: usize = 12;
    core::array::from_fn(|i| {
        let r = 4e-3;
        if i <= UPPER {
            let a = (30.0 + 240.0 * i as f64 / UPPER as f64).to_radians();
            let [x, y] = polar(r, a);
            [x, y + r]
        } else {
            let a = (90.0 - 240.0 * (i - UPPER) as f64 / (LETTER_S_POINTS - 1 - UPPER) as f64)
                .to_radians();
            let [x, y] = polar(r, a);
            [x, y - r]
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
        libm::hypot(a[0] - b[0], a[1] - b[1])
    }

    #[test]
    fn shapes_are_sized_and_have_no_repeated_points() {
        fn check(points: &[[f64; 2]], closed: bool) {
            let r = points
                .iter()
                .map(|p| libm::hypot(p[0], p[1]))
                .fold(0.0, f64::max);
            assert!(r > 4e-3 && r < 15e-3, "extent {r}");
            for w in points.windows(2) {
                assert!(dist(w[0], w[1]) > 1e-5, "repeated point");
            }
            if closed {
                assert!(dist(points[0], points[points.len() - 1]) > 1e-5);
            }
        }
        check(&gear(), true);
        check(&cam(), true);
        check(&octagon(), true);
        check(&letter_e(), false);
        check(&letter_s(), false);
    }

    #[test]
    fn gear_and_octagon_points_lie_on_their_outlines() {
        for p in gear() {
            let r = libm::hypot(p[0], p[1]);
            assert!((GEAR_ROOT_RADIUS_M - 1e-12..=GEAR_TIP_RADIUS_M + 1e-12).contains(&r));
        }
        // Every octagon point is on a side: distance from centre between the apothem
        // R cos(π/8) and R.
        for p in octagon() {
            let r = libm::hypot(p[0], p[1]);
            assert!(r >= OCTAGON_RADIUS_M * libm::cos(PI / 8.0) - 1e-12);
            assert!(r <= OCTAGON_RADIUS_M + 1e-12);
        }
        // The 's' joins at the origin.
        assert!(dist(letter_s()[12], [0.0, 0.0]) < 1e-12);
    }

    #[test]
    fn a_polygon_of_no_sides_is_finite() {
        let p: [[f64; 2]; 12] = regular_polygon(0, 0.01);
        assert!(p.iter().flatten().all(|v| v.is_finite()));
    }
}
