//! Elliptic Fourier descriptors of a closed contour (T 3.2.2; docs/equations.md §11):
//! x(θ) = a0 + Σk (ak cos kθ + bk sin kθ), y(θ) = c0 + Σk (ck cos kθ + dk sin kθ).
//!
//! Coefficients come from a closed polygon by Kuhl & Giardina (1982): the parameter is
//! the chord length t from the first point (closing segment implicit, zero-length
//! segments dropped), θ = 2π t / P with P the perimeter. The polygon is piecewise
//! linear, so its Fourier coefficients are exact finite sums: integrating by parts with
//! the constant slope Δx_p/Δt_p of segment p,
//! ak = P/(2π²k²) Σp (Δx_p/Δt_p)(cos kθp − cos kθp−1), bk likewise with sin, and
//! ck, dk with Δy. a0, c0 is the mean of the curve over t.
//!
//! Evaluation returns position relative to the centre (a0, c0) — small numbers, so
//! `f32` keeps its resolution — with analytic first to third derivatives in θ. cos kθ and
//! sin kθ come from the angle-addition recurrence (one `sin` and one `cos` per call
//! instead of 2n), whose error grows only linearly in k.

use super::curve::{Curve, CurveSample};
use super::{check_finite, lit, to_f64, ContourError, Float};
use crate::error::{representable, ConfigError};
use core::f64::consts::PI;
use nalgebra::Vector2;

/// An n-harmonic EFD curve with capacity `N` harmonics. `Copy`, so that a job's curve
/// is copied in place (a plain memory copy, no stack temporary).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Efd<T: Float, const N: usize> {
    centre: Vector2<T>,
    /// (ak, bk, ck, dk) for k = 1..=harmonics; entries past `harmonics` are zero.
    coefficients: [[T; 4]; N],
    harmonics: usize,
    perimeter_m: f64,
}

/// Whether every point lies within rounding (`tolerance` times the perimeter) of the
/// line from the first point to the point farthest from it. `points` gives the
/// points afresh on each call (the check passes over them twice).
fn collinear<I: Iterator<Item = [f64; 2]>>(
    points: impl Fn() -> I,
    perimeter: f64,
    tolerance: f64,
) -> bool {
    let Some([x0, y0]) = points().next() else {
        return true;
    };
    let far = points().fold([0.0, 0.0], |best: [f64; 2], p| {
        let d = [p[0] - x0, p[1] - y0];
        if libm::hypot(d[0], d[1]) > libm::hypot(best[0], best[1]) {
            d
        } else {
            best
        }
    });
    let length = libm::hypot(far[0], far[1]);
    if length == 0.0 {
        return true;
    }
    points().all(|p| {
        let off = ((p[0] - x0) * far[1] - (p[1] - y0) * far[0]) / length;
        libm::fabs(off) <= tolerance * perimeter
    })
}

/// Rounding of a point's offset from a line, relative to the perimeter: 1e-12 for
/// points given in `f64`.
const COLLINEAR_TOLERANCE: f64 = 1e-12;

impl<T: Float, const N: usize> Efd<T, N> {
    /// Kuhl–Giardina coefficients of the closed polygon `points` (m) up to `harmonics`.
    ///
    /// Zero-length segments (repeated points, a repeated closing point) are dropped.
    /// Errors: a non-finite point, fewer than 3 distinct points, all points equal, all
    /// points on one line, `harmonics` outside 1..=N, or points so large that the
    /// perimeter or a coefficient overflows `f64` or `T` (`NotRepresentable("points")`). The polygon is the curve, so its coefficients exist
    /// for every n (T 3.2.2 counts 4n + 2 coefficients against 2M numbers for a fit
    /// through the points; here they are the exact series of the polygon itself).
    pub fn from_polygon(points: &[[f64; 2]], harmonics: usize) -> Result<Self, ContourError> {
        check_finite(points)?;
        // Segments p = 1..=M: from point p−1 to point p, the last one closing the loop.
        let segments = || {
            points
                .iter()
                .zip(points.iter().cycle().skip(1))
                .map(|(a, b)| (*a, [b[0] - a[0], b[1] - a[1]]))
                .map(|(a, d)| (a, d, libm::hypot(d[0], d[1])))
                .filter(|&(_, _, len)| len > 0.0)
        };
        let perimeter: f64 = segments().map(|(_, _, len)| len).sum();
        if !perimeter.is_finite() {
            // Finite points so far apart that their distances overflow f64.
            return Err(ConfigError::not_representable("points").into());
        }
        let distinct = segments().count();
        if distinct == 0 || perimeter <= 0.0 {
            return Err(if points.len() < 3 {
                ContourError::TooFewPoints
            } else {
                ContourError::ZeroLength
            });
        }
        if distinct < 3 {
            return Err(ContourError::TooFewPoints);
        }
        if collinear(|| points.iter().copied(), perimeter, COLLINEAR_TOLERANCE) {
            return Err(ContourError::Collinear);
        }
        if harmonics == 0 || harmonics > N {
            return Err(ContourError::TooManyHarmonics);
        }
        // Derived from finite points: what is not finite overflowed f64 on the way.
        let derived = |value: f64| {
            if value.is_finite() {
                representable::<T>("points", value)
            } else {
                Err(ConfigError::not_representable("points"))
            }
        };
        // Centre: the curve's mean over t; each segment contributes its midpoint × length.
        let (mut sx, mut sy) = (0.0, 0.0);
        for (a, d, len) in segments() {
            sx += (a[0] + 0.5 * d[0]) * len;
            sy += (a[1] + 0.5 * d[1]) * len;
        }
        let mut coefficients = [[T::ZERO; 4]; N];
        for (k, row) in coefficients.iter_mut().take(harmonics).enumerate() {
            let k = (k + 1) as f64;
            let w = 2.0 * PI * k / perimeter;
            let mut sums = [0.0f64; 4];
            let mut t = 0.0;
            let (mut c0, mut s0) = (1.0, 0.0);
            for (_, d, len) in segments() {
                t += len;
                let (s1, c1) = libm::sincos(w * t);
                let (dx, dy) = (d[0] / len, d[1] / len);
                sums[0] += dx * (c1 - c0);
                sums[1] += dx * (s1 - s0);
                sums[2] += dy * (c1 - c0);
                sums[3] += dy * (s1 - s0);
                (c0, s0) = (c1, s1);
            }
            let scale = perimeter / (2.0 * PI * PI * k * k);
            for (out, sum) in row.iter_mut().zip(sums) {
                *out = derived(scale * sum)?;
            }
        }
        let efd = Self {
            centre: Vector2::new(derived(sx / perimeter)?, derived(sy / perimeter)?),
            coefficients,
            harmonics,
            perimeter_m: perimeter,
        };
        if !efd.derivatives_fit() {
            return Err(ConfigError::not_representable("points").into());
        }
        Ok(efd)
    }

    /// A curve from known coefficients (ak, bk, ck, dk), k = 1.. (for example stored
    /// in flash), with centre `centre_m`. The perimeter is recomputed from the curve.
    /// Errors: no or more than `N` harmonics, a non-finite value, values (or the
    /// curve's perimeter) beyond the scalar `T` (`NotRepresentable`), or a curve that
    /// lies on one line (`Collinear`: a single harmonic with a1·d1 = b1·c1 is a
    /// degenerate ellipse, a stroke whose speed |C′| vanishes at both ends, where the
    /// follower stalls).
    pub fn from_coefficients(
        centre_m: [f64; 2],
        coefficients: &[[f64; 4]],
    ) -> Result<Self, ContourError> {
        let n = coefficients.len();
        if n == 0 || n > N {
            return Err(ContourError::TooManyHarmonics);
        }
        if !centre_m
            .iter()
            .chain(coefficients.iter().flatten())
            .all(|v| v.is_finite())
        {
            return Err(ContourError::NotFinitePoint(0));
        }
        let mut c = [[T::ZERO; 4]; N];
        for (row, src) in c.iter_mut().zip(coefficients) {
            for (o, v) in row.iter_mut().zip(src) {
                *o = representable("coefficients", *v)?;
            }
        }
        let mut efd = Self {
            centre: Vector2::new(
                representable("centre_m", centre_m[0])?,
                representable("centre_m", centre_m[1])?,
            ),
            coefficients: c,
            harmonics: n,
            perimeter_m: 0.0,
        };
        efd.perimeter_m = to_f64(efd.arc_length(T::ZERO, lit(2.0 * PI), 64 * n));
        if !(efd.perimeter_m.is_finite() && efd.derivatives_fit()) {
            // Each coefficient fits T, but the curve's derivatives (k·coefficient) or
            // their norm do not.
            return Err(ConfigError::not_representable("coefficients").into());
        }
        if efd.perimeter_m <= 0.0 {
            return Err(ContourError::ZeroLength);
        }
        if efd.is_collinear() {
            return Err(ContourError::Collinear);
        }
        Ok(efd)
    }

    /// The same curve in the scalar `T`, from its `f64` description (a job planned in
    /// `f64`): the coefficients are rounded to `T` and the perimeter kept, so this
    /// costs 4n conversions and a bound, not a quadrature.
    /// Errors: a coefficient or the curve's derivatives beyond `T` (`NotRepresentable`).
    pub fn from_f64(curve: &Efd<f64, N>) -> Result<Self, ContourError> {
        let mut efd = Self::empty();
        efd.assign_f64(curve)?;
        Ok(efd)
    }

    /// No harmonics, zero everywhere (a placeholder to convert a curve into).
    pub fn empty() -> Self {
        Self {
            centre: Vector2::new(T::ZERO, T::ZERO),
            coefficients: [[T::ZERO; 4]; N],
            harmonics: 0,
            perimeter_m: 0.0,
        }
    }

    /// [`Efd::from_f64`] into `self`, in place (no copy of the curve on the stack: a
    /// control period can run it). On an error `self` holds part of the curve and must
    /// not be used.
    pub fn assign_f64(&mut self, curve: &Efd<f64, N>) -> Result<(), ContourError> {
        for (row, src) in self.coefficients.iter_mut().zip(curve.coefficients.iter()) {
            for (o, v) in row.iter_mut().zip(src) {
                *o = representable("coefficients", *v)?;
            }
        }
        self.centre = Vector2::new(
            representable("centre_m", curve.centre.x)?,
            representable("centre_m", curve.centre.y)?,
        );
        self.harmonics = curve.harmonics;
        self.perimeter_m = curve.perimeter_m;
        if self.derivatives_fit() {
            Ok(())
        } else {
            Err(ConfigError::not_representable("coefficients").into())
        }
    }

    /// Whether [`Efd::evaluate`] and what the follower derives from it stay finite in
    /// `T` at every θ: B = Σk k³ (|ak| + |bk| + |ck| + |dk|) bounds every component of
    /// the position and its first three derivatives, so |C′| ≤ √2·B < 2B; the
    /// curvature's denominator |C′|³ and the arc length 2π·|C′| must be finite too
    /// (an `f32` curve of 1e30 m has finite derivatives but an infinite |C′|).
    fn derivatives_fit(&self) -> bool {
        let mut bound = T::ZERO;
        let mut k = T::ZERO;
        for row in self.coefficients.iter().take(self.harmonics) {
            k += T::one();
            let size = row.iter().fold(T::ZERO, |sum, c| sum + c.abs());
            bound += size * k * k * k;
        }
        let speed = bound * lit(2.0);
        (speed * speed * speed).is_finite() && (speed * lit(2.0 * PI)).is_finite()
    }

    /// Whether the curve lies on one line: 64 samples per harmonic, each point's
    /// offset from the line against the perimeter, to the rounding of `T` (16 ulps,
    /// at least [`COLLINEAR_TOLERANCE`]).
    fn is_collinear(&self) -> bool {
        let samples = 64 * self.harmonics.max(1);
        let step = 2.0 * PI / samples as f64;
        let tolerance = COLLINEAR_TOLERANCE.max(16.0 * to_f64(T::default_epsilon()));
        let points = || {
            (0..samples).map(|i| {
                let p = self.evaluate(lit(step * i as f64)).position;
                [to_f64(p.x), to_f64(p.y)]
            })
        };
        collinear(points, self.perimeter_m, tolerance)
    }

    /// Number of harmonics n in use.
    pub fn harmonics(&self) -> usize {
        self.harmonics
    }

    /// (ak, bk, ck, dk) for k = 1..=n.
    pub fn coefficients(&self) -> &[[T; 4]] {
        self.coefficients.get(..self.harmonics).unwrap_or(&[])
    }

    /// Centre (a0, c0), m.
    pub fn centre(&self) -> Vector2<T> {
        self.centre
    }

    /// Perimeter of the source polygon (m); θ = 2π·t/perimeter.
    pub fn polygon_perimeter_m(&self) -> f64 {
        self.perimeter_m
    }

    /// Position relative to the centre and its first three θ-derivatives.
    ///
    /// A NaN or ±∞ θ passes through to the sample (a pure kernel; the follower checks
    /// its own steps). Every finite θ gives a finite sample: the constructors refuse
    /// coefficients whose derivatives would overflow `T`.
    pub fn evaluate(&self, theta: T) -> CurveSample<T> {
        let (s1, c1) = theta.fsin_cos();
        let (mut ck, mut sk) = (c1, s1);
        let mut k = T::ZERO;
        let zero = Vector2::new(T::ZERO, T::ZERO);
        let (mut p, mut d1, mut d2, mut d3) = (zero, zero, zero, zero);
        for [a, b, c, d] in self.coefficients.iter().take(self.harmonics).copied() {
            k += T::one();
            let k2 = k * k;
            // u = harmonic value, v = its derivative / k.
            let u = Vector2::new(a * ck + b * sk, c * ck + d * sk);
            let v = Vector2::new(b * ck - a * sk, d * ck - c * sk);
            p += u;
            d1 += v * k;
            d2 -= u * k2;
            d3 -= v * (k2 * k);
            (ck, sk) = (ck * c1 - sk * s1, sk * c1 + ck * s1);
        }
        CurveSample {
            position: p,
            d1,
            d2,
            d3,
        }
    }

    /// dC/dθ only (cheaper than [`Efd::evaluate`]; used for arc length).
    pub fn tangent(&self, theta: T) -> Vector2<T> {
        let (s1, c1) = theta.fsin_cos();
        let (mut ck, mut sk) = (c1, s1);
        let mut k = T::ZERO;
        let mut d1 = Vector2::new(T::ZERO, T::ZERO);
        for [a, b, c, d] in self.coefficients.iter().take(self.harmonics).copied() {
            k += T::one();
            d1 += Vector2::new(b * ck - a * sk, d * ck - c * sk) * k;
            (ck, sk) = (ck * c1 - sk * s1, sk * c1 + ck * s1);
        }
        d1
    }

    /// Arc length of the EFD curve from θ0 to θ1 (m) by `intervals` panels of 3-point
    /// Gauss–Legendre quadrature (exact for polynomials of degree 5 per panel). A
    /// non-finite θ, or a finite one so large that the span's length overflows,
    /// passes through to the result. ([`Curve::arc_length`], as for any curve.)
    pub fn arc_length(&self, theta0: T, theta1: T, intervals: usize) -> T {
        Curve::arc_length(self, theta0, theta1, intervals)
    }

    /// Signed curvature κ(θ) = (x′y″ − y′x″)/|C′|³ (1/m); zero where |C′| = 0; a
    /// non-finite θ passes through (see [`Efd::evaluate`]).
    pub fn curvature(&self, theta: T) -> T {
        Curve::curvature(self, theta)
    }

    /// Largest |κ| over the curve (1/m): `samples` equal θ steps, then the best sample is
    /// refined by golden-section search over its two neighbouring steps
    /// ([`Curve::max_curvature`]).
    pub fn max_curvature(&self, samples: usize) -> T {
        Curve::max_curvature(self, samples)
    }
}

impl<T: Float, const N: usize> Curve<T> for Efd<T, N> {
    fn evaluate(&self, theta: T) -> CurveSample<T> {
        Efd::evaluate(self, theta)
    }
    fn tangent(&self, theta: T) -> Vector2<T> {
        Efd::tangent(self, theta)
    }
    fn span(&self) -> T {
        lit(2.0 * PI)
    }
    fn is_closed(&self) -> bool {
        true
    }
    fn pieces(&self) -> usize {
        self.harmonics()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::shapes;
    extern crate std;
    use std::println;
    use std::vec::Vec;

    /// Complex harmonic amplitudes (|Z₊k|, |Z₋k|) of harmonic k: z = x + iy =
    /// Z₊ e^{ikθ} + Z₋ e^{−ikθ}, Z± = ((a + ic) ∓ i(b + id))/2.
    fn amplitudes(h: [f64; 4]) -> (f64, f64) {
        let [a, b, c, d] = h;
        (
            0.5 * libm::hypot(a + d, c - b),
            0.5 * libm::hypot(a - d, c + b),
        )
    }

    /// Independent reference: Fourier coefficients of a closed polygon by brute-force
    /// midpoint quadrature of x(t), y(t) at `samples` points (no integration by parts).
    fn brute_force_coefficients(points: &[[f64; 2]], k: usize, samples: usize) -> [f64; 4] {
        let m = points.len();
        let lens: Vec<f64> = (0..m)
            .map(|i| {
                let (a, b) = (points[i], points[(i + 1) % m]);
                libm::hypot(b[0] - a[0], b[1] - a[1])
            })
            .collect();
        let perimeter: f64 = lens.iter().sum();
        let mut out = [0.0; 4];
        let (mut seg, mut start) = (0usize, 0.0);
        for j in 0..samples {
            let t = (j as f64 + 0.5) * perimeter / samples as f64;
            while t > start + lens[seg] {
                start += lens[seg];
                seg += 1;
            }
            let u = (t - start) / lens[seg];
            let (a, b) = (points[seg], points[(seg + 1) % m]);
            let (x, y) = (a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1]));
            let th = 2.0 * PI * k as f64 * t / perimeter;
            let w = 2.0 / samples as f64;
            out[0] += w * x * th.cos();
            out[1] += w * x * th.sin();
            out[2] += w * y * th.cos();
            out[3] += w * y * th.sin();
        }
        out
    }

    fn sinc(x: f64) -> f64 {
        x.sin() / x
    }

    #[test]
    fn regular_polygon_closed_form_holds_and_matches() {
        // Claim: a regular M-gon of circumradius R has non-zero harmonics only at k = 1 and
        // k = jM ± 1, each a circle of radius R·sinc²(π/M)/k². First checked against the
        // brute-force reference (independent of Kuhl–Giardina), then used for the EFD.
        const M: usize = 6;
        let r = 7e-3;
        let pts: [[f64; 2]; M] = shapes::regular_polygon(M, r);
        for k in 1..=13usize {
            let (zp, zm) = amplitudes(brute_force_coefficients(&pts, k, 600_000));
            let expect = if k % M == 1 || k % M == M - 1 {
                r * sinc(PI / M as f64).powi(2) / (k * k) as f64
            } else {
                0.0
            };
            // Midpoint rule on a piecewise-linear integrand: error ~ R (2πk/samples)²;
            // 1e-9 m is ≥ 10× that for k ≤ 13.
            assert!(
                (zp + zm - expect).abs() < 1e-9,
                "k {k}: {zp} {zm} vs {expect}"
            );
            assert!(zp.min(zm) < 1e-9, "one rotation sense only");
        }
        // Kuhl–Giardina on the octagon (8 points per side) against the same closed form,
        // now to rounding.
        let efd = Efd::<f64, 30>::from_polygon(&shapes::octagon(), 30).unwrap();
        for (i, h) in efd.coefficients().iter().enumerate() {
            let k = i + 1;
            let (zp, zm) = amplitudes(*h);
            let expect = if k % 8 == 1 || k % 8 == 7 {
                shapes::OCTAGON_RADIUS_M * sinc(PI / 8.0).powi(2) / (k * k) as f64
            } else {
                0.0
            };
            assert!(
                (zp + zm - expect).abs() < 1e-15,
                "k {k}: {} vs {expect}",
                zp + zm
            );
        }
        assert!(efd.centre().norm() < 1e-15);
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let efd = Efd::<f64, 30>::from_polygon(&shapes::gear(), 30).unwrap();
        let h = 1e-5;
        for i in 0..200 {
            let th = i as f64 * 0.0314159;
            let s = efd.evaluate(th);
            let (m, p) = (efd.evaluate(th - h), efd.evaluate(th + h));
            // Central differences: error ≈ h²/6·|next derivative| ≲ 1e-10·|C^(4)|; for
            // 30 harmonics of a 10 mm gear |C^(4)| ≲ 30⁴·1e-4 m ≈ 80 m, so 1e-7·scale.
            let tol = |scale: f64| 1e-7 * scale.max(1e-3);
            assert!(((p.position - m.position) / (2.0 * h) - s.d1).norm() < tol(s.d1.norm()));
            assert!(((p.d1 - m.d1) / (2.0 * h) - s.d2).norm() < tol(s.d2.norm() * 30.0));
            assert!(((p.d2 - m.d2) / (2.0 * h) - s.d3).norm() < tol(s.d3.norm() * 30.0));
            assert_eq!(efd.tangent(th), s.d1);
        }
    }

    #[test]
    fn recurrence_matches_direct_sums_in_f32() {
        // Reference written the slow way: 4n direct sin/cos calls in f64.
        let e64 = Efd::<f64, 30>::from_polygon(&shapes::cam(), 30).unwrap();
        let e32 = Efd::<f32, 30>::from_polygon(&shapes::cam(), 30).unwrap();
        for i in 0..100 {
            let th = i as f64 * 0.0628;
            let mut p = Vector2::new(0.0, 0.0);
            let mut d3 = Vector2::new(0.0, 0.0);
            for (j, [a, b, c, d]) in e64.coefficients().iter().copied().enumerate() {
                let k = (j + 1) as f64;
                let (s, co) = (libm::sin(k * th), libm::cos(k * th));
                p += Vector2::new(a * co + b * s, c * co + d * s);
                d3 += Vector2::new(a * s - b * co, c * s - d * co) * k * k * k;
            }
            let s64 = e64.evaluate(th);
            assert!((s64.position - p).norm() < 1e-17);
            assert!((s64.d3 - d3).norm() < 1e-13 * d3.norm().max(1e-3));
            // f32: θ itself rounds by ≈ 3e-7 rad; position error ≲ |C′|·3e-7 + n·ε·R.
            let s32 = e32.evaluate(th as f32);
            let err = libm::hypot(s32.position.x as f64 - p.x, s32.position.y as f64 - p.y);
            assert!(err < 2e-8, "f32 position error {err}");
        }
    }

    /// Largest distance between polygon vertices and the EFD at the same chord parameter.
    fn reconstruction_error(points: &[[f64; 2]], n: usize) -> f64 {
        let efd = Efd::<f64, 30>::from_polygon(points, n).unwrap();
        let perimeter = efd.polygon_perimeter_m();
        let mut t = 0.0;
        let mut worst: f64 = 0.0;
        for (i, p) in points.iter().enumerate() {
            let c = efd.centre() + efd.evaluate(2.0 * PI * t / perimeter).position;
            worst = worst.max(libm::hypot(c.x - p[0], c.y - p[1]));
            let q = points[(i + 1) % points.len()];
            t += libm::hypot(q[0] - p[0], q[1] - p[1]);
        }
        worst
    }

    #[test]
    fn reconstruction_error_falls_with_harmonics() {
        let circle: [[f64; 2]; 128] = shapes::ellipse(8e-3, 8e-3);
        let ellipse: [[f64; 2]; 128] = shapes::ellipse(10e-3, 5e-3);
        let cases: [(&str, &[[f64; 2]]); 5] = [
            ("circle", &circle),
            ("ellipse", &ellipse),
            ("gear", &shapes::gear()),
            ("cam", &shapes::cam()),
            ("octagon", &shapes::octagon()),
        ];
        let ns = [2usize, 5, 10, 20, 30];
        println!("EFD reconstruction error (max vertex distance, µm) vs harmonics");
        println!(
            "{:>8} {:>9} {:>9} {:>9} {:>9} {:>9}",
            "shape", 2, 5, 10, 20, 30
        );
        for (name, pts) in cases {
            let e: Vec<f64> = ns.iter().map(|&n| reconstruction_error(pts, n)).collect();
            println!(
                "{name:>8} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3}",
                e[0] * 1e6,
                e[1] * 1e6,
                e[2] * 1e6,
                e[3] * 1e6,
                e[4] * 1e6
            );
            // Adding harmonics adds energy back (Parseval), so the error must not grow by
            // more than rounding; it must fall by at least 3× from 2 to 30 harmonics.
            for w in e.windows(2) {
                assert!(w[1] <= w[0] * 1.05 + 1e-12, "{name}: {e:?}");
            }
            assert!(e[4] < e[0] / 3.0 || e[4] < 2e-6, "{name}: {e:?}");
        }
        // A 128-gon inscribed in a circle is all k = 1 below k = 127: a circle of radius
        // R sinc²(π/128), so the vertex error is R (1 − sinc²(π/128)) at every n ≤ 30
        // (the k ≥ 127 remainder, ≤ R·Σ 2/k² over that range, is what 2% allows).
        let expect = 8e-3 * (1.0 - sinc(PI / 128.0).powi(2));
        for n in [1, 30] {
            let e = reconstruction_error(&circle, n);
            assert!((e - expect).abs() < 0.02 * expect, "{e} vs {expect}");
        }
    }

    #[test]
    fn rejects_bad_input() {
        type E = Efd<f64, 10>;
        assert_eq!(
            E::from_polygon(&[[0.0, 0.0], [1.0, 0.0]], 1).err(),
            Some(ContourError::TooFewPoints)
        );
        assert_eq!(
            E::from_polygon(&[[1.0, 1.0]; 5], 1).err(),
            Some(ContourError::ZeroLength)
        );
        // Repeats collapse to 2 distinct points.
        assert_eq!(
            E::from_polygon(&[[0.0, 0.0], [0.0, 0.0], [1.0, 0.0], [1.0, 0.0]], 1).err(),
            Some(ContourError::TooFewPoints)
        );
        let tri = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(E::from_polygon(&tri, 1).is_ok());
        // The polygon is the curve: any number of harmonics up to the capacity.
        assert!(E::from_polygon(&tri, 10).is_ok());
        // Beyond the capacity N = 10.
        assert_eq!(
            E::from_polygon(&shapes::cam(), 11).err(),
            Some(ContourError::TooManyHarmonics)
        );
        assert_eq!(
            E::from_polygon(&shapes::cam(), 0).err(),
            Some(ContourError::TooManyHarmonics)
        );
        assert_eq!(
            E::from_polygon(&[[0.0, 0.0], [f64::NAN, 0.0], [0.0, 1.0]], 1).err(),
            Some(ContourError::NotFinitePoint(1))
        );
        // A repeated closing point is a zero-length segment and is dropped.
        let closed = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.0, 0.0]];
        let a = E::from_polygon(&closed, 1).unwrap();
        let b = E::from_polygon(&tri, 1).unwrap();
        assert_eq!(a.coefficients(), b.coefficients());
    }

    #[test]
    fn from_coefficients_round_trips_and_measures_perimeter() {
        // A circle of radius 5 mm: a1 = R, d1 = R; perimeter 2πR.
        let e = Efd::<f32, 30>::from_coefficients([0.01, 0.0], &[[5e-3, 0.0, 0.0, 5e-3]]).unwrap();
        assert!((e.polygon_perimeter_m() - 2.0 * PI * 5e-3).abs() < 1e-8);
        assert!((e.curvature(0.3) - 200.0).abs() < 1e-2);
        assert!(Efd::<f32, 2>::from_coefficients([0.0, 0.0], &[[1.0; 4]; 3]).is_err());
    }

    /// Kuhl–Giardina coefficients of a vertex-only polygon at n well past (M − 1)/2,
    /// against the same polygon with every edge cut into 7 (the same curve, the same
    /// arc-length parameter, 7× as many terms in every sum): equal to round-off.
    #[test]
    fn harmonics_beyond_the_vertex_count_match_a_subdivided_polygon() {
        // Vertices only, as CAD exports a polygon.
        let octagon = shapes::regular_polygon::<8>(8, shapes::OCTAGON_RADIUS_M);
        let mut fine = std::vec::Vec::new();
        for (a, b) in octagon.iter().zip(octagon.iter().cycle().skip(1)) {
            for j in 0..7 {
                let s = j as f64 / 7.0;
                fine.push([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]);
            }
        }
        let coarse = Efd::<f64, 30>::from_polygon(&octagon, 30).unwrap();
        let subdivided = Efd::<f64, 30>::from_polygon(&fine, 30).unwrap();
        let scale = coarse.coefficients()[0]
            .iter()
            .fold(0.0f64, |m, c| m.max(c.abs()));
        let mut worst = 0.0f64;
        for (a, b) in coarse.coefficients().iter().zip(subdivided.coefficients()) {
            for (x, y) in a.iter().zip(b) {
                worst = worst.max((x - y).abs());
            }
        }
        // Sums of 8 and 56 terms of size ~ scale: a few ulp of the scale.
        assert!(worst < 1e-13 * scale, "{worst} (scale {scale})");
        // And 30 harmonics trace the corners: the curve passes within 1 % of the
        // circumradius of each vertex (Gibbs-free: the curve is continuous).
        let radius = octagon[0][0].hypot(octagon[0][1]);
        let mut arc = 0.0;
        for (k, v) in octagon.iter().enumerate() {
            // θ = 2π t / P, t the arc length from vertex 0.
            let theta = 2.0 * PI * arc / coarse.polygon_perimeter_m();
            let next = octagon[(k + 1) % octagon.len()];
            arc += (next[0] - v[0]).hypot(next[1] - v[1]);
            let p = coarse.evaluate(theta).position;
            let d = (p.x - v[0]).hypot(p.y - v[1]);
            assert!(d < 0.01 * radius, "vertex {k}: {d}");
        }
    }

    /// A closed polygon whose points lie on one line is a back-and-forth stroke with
    /// cusps (infinite curvature at the ends): no contour to follow. Typed error, also
    /// when the points are off the line only by rounding.
    #[test]
    fn a_collinear_polygon_is_refused() {
        type E = Efd<f64, 10>;
        let line = [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
        assert_eq!(
            E::from_polygon(&line, 5).err(),
            Some(ContourError::Collinear)
        );
        let slanted = [[0.0, 0.0], [0.1, 0.3], [0.3, 0.9], [0.2, 0.6]];
        assert_eq!(
            E::from_polygon(&slanted, 5).err(),
            Some(ContourError::Collinear)
        );
        // A sliver 1e-9 of its length wide is still a contour.
        let sliver = [[0.0, 0.0], [1.0, 0.0], [0.5, 1e-9]];
        assert!(E::from_polygon(&sliver, 3).is_ok());
    }

    /// One harmonic with a1·d1 = b1·c1 is an ellipse of no width: a stroke whose
    /// speed |C′| vanishes at both ends, where the follower's step has no length
    /// (from θ = 0 it stalled for good). Refused as collinear from coefficients as
    /// from points, in each scalar; an ellipse 1e-4 of its length wide is not.
    #[test]
    fn a_degenerate_one_harmonic_curve_is_refused() {
        let lines = [
            [[0.01, 0.0, 0.005, 0.0]],
            [[0.01, 0.002, 0.005, 0.001]],
            [[0.0, 0.01, 0.0, -0.02]],
        ];
        for line in &lines {
            assert_eq!(
                Efd::<f64, 4>::from_coefficients([0.0, 0.0], line).err(),
                Some(ContourError::Collinear),
                "{line:?}"
            );
            assert_eq!(
                Efd::<f32, 4>::from_coefficients([0.01, 0.0], line).err(),
                Some(ContourError::Collinear),
                "{line:?}"
            );
        }
        // The same stroke traced twice (harmonics 1 and 2 on one line) is one too.
        let twice = [[0.01, 0.0, 0.005, 0.0], [0.0, 0.003, 0.0, 0.0015]];
        assert_eq!(
            Efd::<f64, 4>::from_coefficients([0.0, 0.0], &twice).err(),
            Some(ContourError::Collinear)
        );
        let thin = [[0.01, 0.0, 0.0, 1e-6]];
        assert!(Efd::<f64, 4>::from_coefficients([0.0, 0.0], &thin).is_ok());
        assert!(Efd::<f32, 4>::from_coefficients([0.0, 0.0], &thin).is_ok());
    }

    /// Finite in f64, beyond f32 (or beyond f64 once summed): typed errors, not a
    /// curve of infinities.
    #[test]
    fn coefficients_beyond_the_scalar_are_refused() {
        let not_representable =
            |field| Some(ContourError::Config(ConfigError::not_representable(field)));
        let ok = [[0.01, 0.0, 0.0, 0.01]];
        assert_eq!(
            Efd::<f32, 4>::from_coefficients([0.0, 0.0], &[[0.01, 3.5e38, 0.0, 0.01]]).err(),
            not_representable("coefficients")
        );
        assert_eq!(
            Efd::<f32, 4>::from_coefficients([1e39, 0.0], &ok).err(),
            not_representable("centre_m")
        );
        // Each coefficient fits f32, the derivative of the second harmonic does not.
        assert_eq!(
            Efd::<f32, 4>::from_coefficients(
                [0.0, 0.0],
                &[[0.01, 0.0, 0.0, 0.01], [3e38, 0.0, 0.0, 3e38]]
            )
            .err(),
            not_representable("coefficients")
        );
        assert!(Efd::<f64, 4>::from_coefficients([1e39, 0.0], &ok).is_ok());
        // Radius 10 mm × 1e41: coefficients beyond f32.
        let huge = shapes::octagon().map(|[x, y]| [x * 1e41, y * 1e41]);
        assert_eq!(
            Efd::<f32, 10>::from_polygon(&huge, 10).err(),
            not_representable("points")
        );
        assert!(Efd::<f64, 10>::from_polygon(&huge, 10).is_ok());
        // Radius 10 mm × 1e30: coefficients and derivatives fit f32, but |C′|² (its
        // speed, the arc length, the curvature's |C′|³) overflows it.
        let large = shapes::octagon().map(|[x, y]| [x * 1e30, y * 1e30]);
        assert_eq!(
            Efd::<f32, 10>::from_polygon(&large, 10).err(),
            not_representable("points")
        );
        let efd = Efd::<f64, 10>::from_polygon(&large, 10).unwrap();
        assert!(efd.arc_length(0.0, 2.0 * PI, 160).is_finite());
        // The third derivative, k³ times a coefficient, overflows f64.
        let beyond = shapes::octagon().map(|[x, y]| [x * f64::MAX, y * f64::MAX]);
        assert_eq!(
            Efd::<f64, 10>::from_polygon(&beyond, 10).err(),
            not_representable("points")
        );
    }
}
