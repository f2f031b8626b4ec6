//! Motion constraints for manual machining (T 3.3, SPEC § trajectory).
//!
//! Around the end effector x the contour data give a window of 2k + 1 points (T eq. 15),
//! a circle is fitted to it and the constraint is φ(x) = [(x−cx)² + (y−cy)² − r²,
//! z_ref − z] with Jφ = [[2(x−cx), 2(y−cy), 0], [0, 0, −1]] (SPEC, with the centre).
//!
//! Choices made here, with reasons:
//! - Fits run in coordinates centred on the window mean (the circle equation squares
//!   coordinates; centring keeps `f32` from cancelling). The data are stored relative to
//!   their centroid as rounded to `T`, the value [`MotionConstraint::evaluate`] subtracts
//!   from x, so data and query share one frame wherever the contour lies. Against f64,
//!   f32 φ₁ stays within 7 nm and Jφ within 1.1e-5 sliding along the gear and the cam,
//!   also 0.36 m off the frame origin (test `f32_matches_f64_sliding_along_gear_and_cam`).
//! - The print's Kåsa fit (T eq. 17–19) is biased towards small radii on short or noisy
//!   arcs. Taubin's fit (mean gradient normalised) is solved here as a 3×3 symmetric
//!   eigenproblem, and a geometric fit (Gauss–Newton on Σ(|pᵢ − c| − r)², from Taubin)
//!   refines it; the test `circle_fit_comparison` prints the numbers behind the default.
//! - A window whose best circle would bow by less than `line_sagitta_m` over its span is
//!   a line (total least squares): gear flanks and octagon sides give r → ∞.
//! - The first row is returned divided by 2r and signed so that φ₁ > 0 on the left of the
//!   contour's direction: φ₁ ≈ the signed normal distance in metres for circles and lines
//!   alike (the line is the r → ∞ limit), so neither a change of radius nor a switch
//!   between circle and line, nor a change of bending side, makes φ jump. Scaling a row
//!   of φ and Jφ by the same constant leaves the constraint law's Jφ#φ, Jφ#J̇φ and
//!   Jφ#…Jφ terms unchanged (diagonal gains), so the law of T 5.2 is unaffected;
//!   [`Fit::spec_form`] gives the SPEC-scaled pair.
//! - Windows do not switch abruptly: x is projected on the nearest data segment
//!   [Pi, Pi+1] at fraction u, and φ, Jφ are blended (1 − u)·(window at Pi) + u·(window at
//!   Pi+1), which is continuous when x passes a data point.

use super::{lit, to_f64, ContourError, Float};
use crate::error::positive;
use heapless::Vec;
use nalgebra::{Matrix2x3, Matrix3, Vector2, Vector3};

/// Largest half-window k supported (2k + 1 = 33 points).
pub const MAX_HALF_WINDOW: usize = 16;
const MAX_WINDOW: usize = 2 * MAX_HALF_WINDOW + 1;

/// Circle-fit method.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum CircleMethod {
    /// Kåsa algebraic fit (T eq. 17–19): biased on short or noisy arcs.
    Kasa,
    /// Taubin algebraic fit.
    Taubin,
    /// Geometric (orthogonal distance) fit, started from Taubin.
    Geometric,
}

/// A fitted window, in the constraint's coordinates (relative to the data centroid).
#[derive(Copy, Clone, Debug, PartialEq)]
pub enum Fit<T: Float> {
    /// Circle with centre and radius.
    Circle {
        /// Centre, m.
        centre: Vector2<T>,
        /// Radius, m.
        radius: T,
    },
    /// Straight line through `point` with unit `normal`.
    Line {
        /// A point on the line, m.
        point: Vector2<T>,
        /// Unit normal, m/m.
        normal: Vector2<T>,
    },
}

impl<T: Float> Fit<T> {
    /// The SPEC form for a circle: (x−cx)² + (y−cy)² − r² and its gradient 2(x − c);
    /// `None` for a line (SPEC's form has no finite line limit).
    pub fn spec_form(&self, x: Vector2<T>) -> Option<(T, Vector2<T>)> {
        match *self {
            Fit::Circle { centre, radius } => {
                let d = x - centre;
                Some((d.norm_squared() - radius * radius, d * lit::<T>(2.0)))
            }
            Fit::Line { .. } => None,
        }
    }
}

/// Window mean and centred copy; `None` unless 3..=33 points.
fn centred<T: Float>(points: &[Vector2<T>]) -> Option<(Vector2<T>, Vec<Vector2<T>, MAX_WINDOW>)> {
    if !(3..=MAX_WINDOW).contains(&points.len()) {
        return None;
    }
    let n = lit::<T>(points.len() as f64);
    let mean = points.iter().fold(Vector2::zeros(), |s, p| s + p) / n;
    Some((
        mean,
        points.iter().take(MAX_WINDOW).map(|p| p - mean).collect(),
    ))
}

/// Kåsa fit of 3 to 33 points: `(centre, radius)`; `None` if degenerate.
pub fn fit_kasa<T: Float>(points: &[Vector2<T>]) -> Option<(Vector2<T>, T)> {
    let (mean, q) = centred(points)?;
    let n = lit::<T>(q.len() as f64);
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz, mut sz) =
        (T::ZERO, T::ZERO, T::ZERO, T::ZERO, T::ZERO, T::ZERO);
    for p in &q {
        let z = p.norm_squared();
        sxx += p.x * p.x;
        sxy += p.x * p.y;
        syy += p.y * p.y;
        sxz += p.x * z;
        syz += p.y * z;
        sz += z;
    }
    // Centred: η3 = −z̄ decouples; [Sxx Sxy; Sxy Syy] η = −[Sxz; Syz], c = −η/2.
    let det = sxx * syy - sxy * sxy;
    if det <= T::ZERO {
        return None;
    }
    let h = lit::<T>(0.5) / det;
    let c = Vector2::new((syy * sxz - sxy * syz) * h, (sxx * syz - sxy * sxz) * h);
    let r2 = c.norm_squared() + sz / n;
    (r2 > T::ZERO).then(|| (c + mean, r2.sqrt()))
}

/// Taubin fit (3 to 33 points) in algebraic form A(x² + y²) + Bx + Cy + D = 0 about the window mean:
/// returns `(mean, [A, B, C, D])` with B² + C² − 4AD > 0, or `None` if degenerate.
///
/// Minimises Σf² subject to mean |∇f|² = 4A² z̄ + B² + C² = 1 (centred, D = −A z̄): with
/// w = (z − z̄, x, y), S = Σ wwᵀ and N = diag(4z̄, 1, 1), the smallest eigenvector of
/// N^(−½) S N^(−½).
pub fn fit_taubin<T: Float>(points: &[Vector2<T>]) -> Option<(Vector2<T>, [T; 4])> {
    let (mean, q) = centred(points)?;
    let n = lit::<T>(q.len() as f64);
    let zbar = q.iter().fold(T::ZERO, |s, p| s + p.norm_squared()) / n;
    if zbar <= T::ZERO {
        return None;
    }
    let scale = lit::<T>(1.0) / (lit::<T>(4.0) * zbar).sqrt();
    let mut s = Matrix3::zeros();
    for p in &q {
        let w = Vector3::new((p.norm_squared() - zbar) * scale, p.x, p.y);
        s += w * w.transpose();
    }
    let u = smallest_eigenvector(&s)?;
    let (a, b, c) = (u.x * scale, u.y, u.z);
    let d = -a * zbar;
    (b * b + c * c - lit::<T>(4.0) * a * d > T::ZERO).then_some((mean, [a, b, c, d]))
}

/// Unit eigenvector of the smallest eigenvalue of a symmetric positive semi-definite
/// 3×3 matrix S, or `None` when S has rank 1 or less (no direction stands out).
///
/// adj S = det S · S⁻¹ has the eigenvalues λ2λ3 ≥ λ1λ3 ≥ λ1λ2 (λ1 ≤ λ2 ≤ λ3) on S's
/// eigenvectors, so its dominant eigenvector is S's smallest. Squaring adj S
/// [`EIGEN_SQUARINGS`] times (rescaled each time) raises the ratio of its other
/// eigenvalues to the dominant one, λ1/λ2, to the power 2^k, and the largest column of
/// the result is the eigenvector. For a window that a circle or a line fits λ1/λ2 is
/// the squared ratio of residual to spread and one squaring would do; λ1/λ2 = 0.95
/// still comes out within 10⁻⁵. A fixed, short sequence of products: no iteration
/// limit to reach and no panic path, unlike a general eigen-solver.
fn smallest_eigenvector<T: Float>(s: &Matrix3<T>) -> Option<Vector3<T>> {
    let (a, b, c) = (
        s.column(0).into_owned(),
        s.column(1).into_owned(),
        s.column(2).into_owned(),
    );
    // Columns of adj S for symmetric S.
    let mut m = Matrix3::from_columns(&[b.cross(&c), c.cross(&a), a.cross(&b)]);
    for _ in 0..EIGEN_SQUARINGS {
        let scale = m.amax();
        if !(scale > T::ZERO && scale.is_finite()) {
            return None;
        }
        m /= scale;
        m = m * m;
    }
    let largest = [m.column(0), m.column(1), m.column(2)]
        .iter()
        .map(|col| col.into_owned())
        .fold(Vector3::zeros(), |best: Vector3<T>, col| {
            if col.norm_squared() > best.norm_squared() {
                col
            } else {
                best
            }
        });
    let norm = largest.norm();
    (norm > T::ZERO && norm.is_finite()).then(|| largest / norm)
}

/// Squarings of adj S in [`smallest_eigenvector`].
const EIGEN_SQUARINGS: u32 = 8;

/// Geometric fit (3 to 33 points): Gauss–Newton on (cx, cy, r) minimising Σ(|pᵢ − c| − r)², at most
/// `iterations` steps from `start`; `None` if a step is singular or the result is not
/// finite.
pub fn fit_geometric<T: Float>(
    points: &[Vector2<T>],
    start: (Vector2<T>, T),
    iterations: usize,
) -> Option<(Vector2<T>, T)> {
    let (mean, q) = centred(points)?;
    let (mut c, mut r) = (start.0 - mean, start.1);
    for _ in 0..iterations {
        let mut jtj = Matrix3::zeros();
        let mut jte = Vector3::zeros();
        for p in &q {
            let d = p - c;
            let dist = d.norm();
            if dist <= T::ZERO {
                return None;
            }
            let j = Vector3::new(-d.x / dist, -d.y / dist, -T::one());
            jtj += j * j.transpose();
            jte += j * (dist - r);
        }
        let step = jtj.cholesky()?.solve(&jte);
        c -= Vector2::new(step.x, step.y);
        r -= step.z;
        if step.norm() <= r.abs() * T::default_epsilon() * lit(16.0) {
            break;
        }
    }
    (r > T::ZERO && c.iter().all(|v| v.is_finite())).then(|| (c + mean, r))
}

/// Constraint configuration.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ConstraintConfig {
    /// Half-window k: 2k + 1 data points per fit (1..=16).
    pub half_window: usize,
    /// A window whose circle bows less than this over its span is a line, m.
    pub line_sagitta_m: f64,
    /// Contour is closed (windows wrap around) or open (windows stop at the ends).
    pub closed: bool,
    /// Circle-fit method.
    pub method: CircleMethod,
}

impl ConstraintConfig {
    /// k = 5, lines below 0.1 µm of sagitta, Taubin fit: in `circle_fit_comparison` it is
    /// as accurate as the geometric fit (RMS radius within 2%) without iterating, and
    /// unlike Kåsa's it is not biased on short arcs.
    pub fn closed_contour() -> Self {
        Self {
            half_window: 5,
            line_sagitta_m: 1e-7,
            closed: true,
            method: CircleMethod::Taubin,
        }
    }
}

/// φ, Jφ and the fit behind them for one end-effector position.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ConstraintValue<T: Float> {
    /// [φ₁ (signed normal distance, m, > 0 left of the contour direction), z_ref − z].
    pub phi: Vector2<T>,
    /// Jφ (2×3).
    pub jacobian: Matrix2x3<T>,
    /// Fit of the nearer window, in the constraint's coordinates (see [`MotionConstraint::origin`]).
    pub fit: Fit<T>,
    /// Index of the nearest data segment's first point.
    pub segment: usize,
}

/// Circle/line motion constraint over up to `N` data points.
#[derive(Clone, Debug)]
pub struct MotionConstraint<T: Float, const N: usize> {
    points: Vec<Vector2<T>, N>,
    origin: Vector2<T>,
    config: ConstraintConfig,
    line_sagitta: T,
}

impl<T: Float, const N: usize> MotionConstraint<T, N> {
    /// Validates the data (m) and configuration. Errors: fewer than 3 or more than `N`
    /// points, fewer than 2k + 1, a non-finite or repeated consecutive point, k outside
    /// 1..=16, a non-positive sagitta.
    pub fn new(points: &[[f64; 2]], config: &ConstraintConfig) -> Result<Self, ContourError> {
        super::check_open(points)?;
        if config.closed && points.first() == points.last() {
            return Err(ContourError::RepeatedPoint(points.len() - 1));
        }
        if !(1..=MAX_HALF_WINDOW).contains(&config.half_window) {
            return Err(crate::ConfigError::out_of_range("half_window").into());
        }
        if points.len() < 2 * config.half_window + 1 {
            return Err(ContourError::TooFewPoints);
        }
        let sag = positive("line_sagitta_m", config.line_sagitta_m)?;
        let n = points.len() as f64;
        let (sx, sy) = points
            .iter()
            .fold((0.0, 0.0), |s, p| (s.0 + p[0], s.1 + p[1]));
        // `evaluate` subtracts the origin as stored in T, so the data are centred on
        // that same rounded value: centring on the exact mean instead would put the
        // query and the data in frames ½ ulp(|mean|) apart (15 nm at 0.36 m in f32).
        let origin: Vector2<T> = Vector2::new(lit(sx / n), lit(sy / n));
        let (ox, oy) = (to_f64(origin.x), to_f64(origin.y));
        let mut v = Vec::new();
        for p in points {
            v.push(Vector2::new(lit(p[0] - ox), lit(p[1] - oy)))
                .map_err(|_| ContourError::Capacity)?;
        }
        Ok(Self {
            points: v,
            origin,
            config: *config,
            line_sagitta: lit(sag),
        })
    }

    /// The data centroid, m: fits and [`ConstraintValue::fit`] are relative to it.
    pub fn origin(&self) -> Vector2<T> {
        self.origin
    }

    fn point(&self, i: usize) -> Vector2<T> {
        let n = self.points.len();
        let i = if self.config.closed { i % n.max(1) } else { i };
        self.points.get(i).copied().unwrap_or_else(Vector2::zeros)
    }

    fn segments(&self) -> usize {
        if self.config.closed {
            self.points.len()
        } else {
            self.points.len() - 1
        }
    }

    /// The window of 2k + 1 points around data point `m` (shifted inside an open contour).
    fn window(&self, m: usize) -> Vec<Vector2<T>, MAX_WINDOW> {
        let (n, k) = (self.points.len(), self.config.half_window);
        let start = if self.config.closed {
            m + n - k
        } else {
            m.saturating_sub(k).min(n - (2 * k + 1))
        };
        (start..start + 2 * k + 1)
            .take(MAX_WINDOW)
            .map(|i| self.point(i))
            .collect()
    }

    /// Fit of the window around data point `m`, with the direction of the data there.
    fn fit_window(&self, m: usize) -> (Fit<T>, Vector2<T>) {
        let w = self.window(m);
        let (first, last) = (w.first().copied(), w.last().copied());
        let dir = match (first, last) {
            (Some(a), Some(b)) => b - a,
            _ => Vector2::new(T::one(), T::ZERO),
        };
        let span2 = dir.norm_squared();
        let line = || {
            // Total least squares: direction = principal axis of the centred window.
            let (mean, q) = centred(&w).unwrap_or((Vector2::zeros(), Vec::new()));
            let (sxx, sxy, syy) = q.iter().fold((T::ZERO, T::ZERO, T::ZERO), |s, p| {
                (s.0 + p.x * p.x, s.1 + p.x * p.y, s.2 + p.y * p.y)
            });
            let angle = (sxy * lit(2.0)).atan2(sxx - syy) * lit(0.5);
            let mut t = Vector2::new(angle.cos(), angle.sin());
            if t.dot(&dir) < T::ZERO {
                t = -t;
            }
            Fit::Line {
                point: mean,
                normal: Vector2::new(-t.y, t.x),
            }
        };
        let fit = match fit_taubin(&w) {
            Some((mean, [a, b, c, d])) => {
                let g = (b * b + c * c - lit::<T>(4.0) * a * d).sqrt();
                // Curvature 2|A|/√(B² + C² − 4AD); sagitta over the span ≈ κ·span²/8.
                let kappa = lit::<T>(2.0) * a.abs() / g;
                if kappa * span2 * lit(0.125) < self.line_sagitta {
                    line()
                } else {
                    let centre = Vector2::new(-b, -c) / (lit::<T>(2.0) * a) + mean;
                    let radius = g / (lit::<T>(2.0) * a.abs());
                    let refined = match self.config.method {
                        CircleMethod::Taubin => Some((centre, radius)),
                        CircleMethod::Kasa => fit_kasa(&w),
                        CircleMethod::Geometric => fit_geometric(&w, (centre, radius), 8),
                    };
                    match refined {
                        Some((centre, radius)) => Fit::Circle { centre, radius },
                        None => Fit::Circle { centre, radius },
                    }
                }
            }
            None => line(),
        };
        (fit, dir)
    }

    /// φ₁ and its gradient for a window fit (signed distance, left of `dir` positive).
    fn distance(fit: &Fit<T>, dir: &Vector2<T>, x: Vector2<T>) -> (T, Vector2<T>) {
        match *fit {
            Fit::Circle { centre, radius } => {
                let d = x - centre;
                // Centre on the left of travel → inside is left → outside is negative.
                let left = Vector2::new(-dir.y, dir.x);
                let s = if left.dot(&(centre - x)) > T::ZERO {
                    -T::one()
                } else {
                    T::one()
                };
                let inv = T::one() / radius;
                (
                    s * (d.norm_squared() - radius * radius) * inv * lit(0.5),
                    d * (s * inv),
                )
            }
            Fit::Line { point, normal } => (normal.dot(&(x - point)), normal),
        }
    }

    /// φ and Jφ at end-effector position `x` (m, same frame as the data) with height
    /// reference `z_ref` (m). Errors: [`ContourError::FarFromContour`] for a
    /// non-finite `x` or `z_ref`, or a point so far away that the scalar overflows.
    pub fn evaluate(&self, x: Vector3<T>, z_ref: T) -> Result<ConstraintValue<T>, ContourError> {
        let p = Vector2::new(x.x, x.y) - self.origin;
        // Nearest data segment and the fraction u along it.
        let mut best = (T::max_value().unwrap_or(T::one()), 0usize, T::ZERO);
        for i in 0..self.segments() {
            let (a, b) = (self.point(i), self.point(i + 1));
            let d = b - a;
            let u = ((p - a).dot(&d) / d.norm_squared())
                .max(T::ZERO)
                .min(T::one());
            let dist2 = (a + d * u - p).norm_squared();
            if dist2 < best.0 {
                best = (dist2, i, u);
            }
        }
        let (best_distance, i, u) = best;
        let (fit0, dir0) = self.fit_window(i);
        let (fit1, dir1) = self.fit_window((i + 1) % self.points.len().max(1));
        let (phi0, g0) = Self::distance(&fit0, &dir0, p);
        let (phi1, g1) = Self::distance(&fit1, &dir1, p);
        let w = T::one() - u;
        let (phi, g) = (phi0 * w + phi1 * u, g0 * w + g1 * u);
        let value = ConstraintValue {
            phi: Vector2::new(phi, z_ref - x.z),
            jacobian: Matrix2x3::new(g.x, g.y, T::ZERO, T::ZERO, T::ZERO, -T::one()),
            fit: if u < lit(0.5) { fit0 } else { fit1 },
            segment: i,
        };
        // NaN or ±inf anywhere (a non-finite point, or one so far away that its
        // squared distance overflows the scalar) fails here: one test on the sum.
        let health = value.phi.x + value.phi.y + g.x + g.y + best_distance;
        if health.is_finite() {
            Ok(value)
        } else {
            Err(ContourError::FarFromContour)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::shapes;
    extern crate std;
    use std::println;
    use std::vec::Vec as StdVec;

    /// Deterministic Gaussian noise (xorshift64* + Box–Muller) for repeatable tests.
    struct Noise(u64);
    impl Noise {
        fn uniform(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn gauss(&mut self) -> f64 {
            let (u, v) = (self.uniform(), self.uniform());
            libm::sqrt(-2.0 * libm::log(u)) * libm::cos(2.0 * core::f64::consts::PI * v)
        }
    }

    #[test]
    fn smallest_eigenvector_matches_a_general_eigen_solver() {
        // Reference: nalgebra's symmetric QR eigen-solver, on S = Q diag(λ) Qᵀ with
        // random rotations Q and λ1/λ2 from 1e-9 (a window a circle fits) to 0.9.
        use nalgebra::{Rotation3, SymmetricEigen};
        let mut seed = 7u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for ratio in [1e-9, 1e-4, 0.1, 0.5, 0.9, 0.95] {
            for _ in 0..200 {
                let q = Rotation3::from_euler_angles(6.3 * next(), 6.3 * next(), 6.3 * next());
                let l2 = 1.0 + next();
                let l = Vector3::new(ratio * l2, l2, l2 * (1.5 + next()));
                let s = q.matrix() * Matrix3::from_diagonal(&l) * q.matrix().transpose();
                let u = smallest_eigenvector(&s).unwrap();
                let eig = SymmetricEigen::new(s);
                let i = eig.eigenvalues.imin();
                let reference = eig.eigenvectors.column(i);
                let error = (u - reference).norm().min((u + reference).norm());
                // 2^k squarings leave the other directions at (λ1/λ2)^(2^k) of the answer.
                let bound = (4.0 * ratio.powi(1 << EIGEN_SQUARINGS)).max(1e-9);
                assert!(error < bound, "λ1/λ2 = {ratio}: {error:e} > {bound:e}");
            }
        }
        // Rank 1 or 0: no smallest direction.
        let a = Vector3::new(1.0, 2.0, 3.0);
        assert!(smallest_eigenvector(&(a * a.transpose())).is_none());
        assert!(smallest_eigenvector(&Matrix3::<f64>::zeros()).is_none());
    }

    #[test]
    fn circle_fit_comparison() {
        // 21 points (k = 10) on arcs of R = 5 mm about (12, −7) mm, Gaussian noise σ on
        // both coordinates, 400 trials per case. Reported: mean signed radius error
        // (bias) and RMS radius and centre errors, all relative to R.
        let (r0, c0, trials) = (5e-3, Vector2::new(12e-3, -7e-3), 400);
        let mut noise = Noise(0x9e37_79b9_7f4a_7c15);
        println!("circle fits, 21 points, R = 5 mm; errors relative to R (bias / RMS r / RMS c)");
        println!(
            "{:>6} {:>6}  {:>26}  {:>26}  {:>26}",
            "arc", "σ µm", "Kåsa", "Taubin", "geometric"
        );
        let mut rows = StdVec::new();
        for sigma in [5e-6, 20e-6] {
            for arc_deg in [10.0f64, 30.0, 90.0, 180.0, 360.0] {
                let mut acc = [[0.0f64; 3]; 3];
                for _ in 0..trials {
                    let span = arc_deg.to_radians();
                    let n = 21;
                    let pts: StdVec<Vector2<f64>> = (0..n)
                        .map(|i| {
                            let den = if arc_deg >= 360.0 { n } else { n - 1 } as f64;
                            let a = 0.3 + span * i as f64 / den;
                            c0 + Vector2::new(r0 * a.cos(), r0 * a.sin())
                                + Vector2::new(noise.gauss(), noise.gauss()) * sigma
                        })
                        .collect();
                    let (mean, [a, b, c, d]) = fit_taubin(&pts).unwrap();
                    let taubin = (
                        Vector2::new(-b, -c) / (2.0 * a) + mean,
                        (b * b + c * c - 4.0 * a * d).sqrt() / (2.0 * a.abs()),
                    );
                    let fits = [
                        fit_kasa(&pts).unwrap(),
                        taubin,
                        fit_geometric(&pts, taubin, 20).unwrap_or(taubin),
                    ];
                    for (m, (c, r)) in fits.iter().enumerate() {
                        acc[m][0] += (r - r0) / r0;
                        acc[m][1] += ((r - r0) / r0).powi(2);
                        acc[m][2] += ((c - c0).norm() / r0).powi(2);
                    }
                }
                let t = trials as f64;
                let stats: StdVec<[f64; 3]> = acc
                    .iter()
                    .map(|a| [a[0] / t, (a[1] / t).sqrt(), (a[2] / t).sqrt()])
                    .collect();
                println!(
                    "{arc_deg:>5}° {:>6.0}  {:>8.1e} {:>8.1e} {:>8.1e}  {:>8.1e} {:>8.1e} {:>8.1e}  {:>8.1e} {:>8.1e} {:>8.1e}",
                    sigma * 1e6,
                    stats[0][0], stats[0][1], stats[0][2],
                    stats[1][0], stats[1][1], stats[1][2],
                    stats[2][0], stats[2][1], stats[2][2],
                );
                rows.push((arc_deg, stats));
            }
        }
        // rows: σ = 5 µm first (5 arcs), then σ = 20 µm.
        for (i, (arc, s)) in rows.iter().enumerate() {
            let determined = i < 5 || *arc > 10.0; // 10° at 20 µm: sagitta 19 µm ≈ σ
                                                   // Kåsa's bias is towards small radii, far larger than Taubin's on short arcs.
            if *arc <= 30.0 {
                assert!(
                    s[0][0] < 0.0 && s[0][0].abs() > 5.0 * s[1][0].abs().min(1.0) || !determined,
                    "{arc}: {s:?}"
                );
            }
            // Taubin and geometric agree within 2% (RMS radius) where the arc is determined.
            if determined {
                assert!((s[2][1] - s[1][1]).abs() <= s[1][1] * 0.02, "{arc}: {s:?}");
            }
        }
    }

    #[test]
    fn fits_are_exact_without_noise_and_in_f32() {
        let c0 = Vector2::new(20e-3, 5e-3);
        let pts: StdVec<Vector2<f64>> = (0..11)
            .map(|i| {
                c0 + Vector2::new(3e-3 * (0.1 * i as f64).cos(), 3e-3 * (0.1 * i as f64).sin())
            })
            .collect();
        let (c, r) = fit_kasa(&pts).unwrap();
        assert!((c - c0).norm() < 1e-15 && (r - 3e-3).abs() < 1e-15);
        let (c, r) = fit_geometric(&pts, (c + Vector2::new(1e-4, 0.0), r * 1.1), 20).unwrap();
        assert!((c - c0).norm() < 1e-15 && (r - 3e-3).abs() < 1e-15);
        let p32: StdVec<Vector2<f32>> = pts.iter().map(|p| p.map(|v| v as f32)).collect();
        let (mean, [a, b, cc, d]) = fit_taubin(&p32).unwrap();
        let c = Vector2::new(-b, -cc) / (2.0 * a) + mean;
        let r = (b * b + cc * cc - 4.0 * a * d).sqrt() / (2.0 * a.abs());
        // Centred f32 on a 57° arc: relative error a few 1e-6 (ε/sagitta-ratio).
        assert!(((c.x as f64 - c0.x).hypot(c.y as f64 - c0.y)) < 3e-8, "{c}");
        assert!((r as f64 - 3e-3).abs() < 3e-8, "{r}");
        assert!(fit_kasa(&pts[..2]).is_none() && fit_taubin(&pts[..2]).is_none());
    }

    /// Slides an end effector along `points` (closed) at offset `offset` to the left of
    /// the direction, `steps` between data points; returns (max |φ₁ − offset|, max |Δφ₁|,
    /// line windows seen).
    fn slide(points: &[[f64; 2]], offset: f64, steps: usize, k: usize) -> (f64, f64, usize) {
        let cfg = ConstraintConfig {
            half_window: k,
            ..ConstraintConfig::closed_contour()
        };
        let c = MotionConstraint::<f64, 512>::new(points, &cfg).unwrap();
        let n = points.len();
        let (mut worst, mut jump, mut lines) = (0.0f64, 0.0f64, 0);
        let mut prev: Option<f64> = None;
        for i in 0..n {
            let (a, b) = (points[i], points[(i + 1) % n]);
            let (a, b) = (Vector2::new(a[0], a[1]), Vector2::new(b[0], b[1]));
            let t = (b - a).normalize();
            for s in 0..steps {
                let p = a + (b - a) * (s as f64 / steps as f64) + Vector2::new(-t.y, t.x) * offset;
                let v = c.evaluate(Vector3::new(p.x, p.y, -0.1), -0.1).unwrap();
                // On a straight side, φ₁ is exactly the offset from the data line.
                worst = worst.max((v.phi.x - offset).abs());
                if let Some(q) = prev {
                    jump = jump.max((v.phi.x - q).abs());
                }
                prev = Some(v.phi.x);
                assert_eq!(v.phi.y, 0.0);
                assert_eq!(v.jacobian[(1, 2)], -1.0);
                // Jφ row 1 (gradient of φ₁) points to the left of the direction: the sign
                // convention holds in every window (circle or line, either bending side).
                let g = Vector2::new(v.jacobian[(0, 0)], v.jacobian[(0, 1)]);
                assert!(g.dot(&Vector2::new(-t.y, t.x)) > 0.5, "{g}");
                if matches!(v.fit, Fit::Line { .. }) {
                    lines += 1;
                }
            }
        }
        (worst, jump, lines)
    }

    #[test]
    fn phi_is_continuous_sliding_along_gear_cam_and_octagon() {
        // Continuity by refinement: if φ₁ is continuous (Lipschitz) along the path, 4×
        // finer steps shrink the largest step-to-step change about 4×; a jump when the
        // window moves would not shrink at all.
        println!("end effector sliding 20 µm left of the contour");
        for (name, pts, k) in [
            ("gear", shapes::gear().to_vec(), 2),
            ("cam", shapes::cam().to_vec(), 5),
            ("octagon", shapes::octagon().to_vec(), 2),
        ] {
            let (off, jump16, lines) = slide(&pts, 20e-6, 16, k);
            let (_, jump64, _) = slide(&pts, 20e-6, 64, k);
            let (on, _, _) = slide(&pts, 0.0, 16, k);
            println!(
                "{name:>8} k={k}: max |φ₁ − offset| {:7.3} µm (on the contour {:7.3} µm), max |Δφ₁| {:6.3} µm (16 steps/segment) {:6.3} µm (64), line samples {lines}",
                off * 1e6, on * 1e6, jump16 * 1e6, jump64 * 1e6
            );
            // Ideal Lipschitz behaviour is 4×; where the nearest segment switches sides at a
            // concave corner some of the change is not refined away, hence 2.5×.
            assert!(jump64 < jump16 / 2.5, "{name}: {jump16} {jump64}");
            if name == "cam" {
                // Smooth data: the error is the chord sagitta of the data (≈ 4 µm at the
                // 1.5 mm valleys) plus the fit's; no line windows on a cam.
                assert!(off < 10e-6 && lines == 0, "{name}: {off}");
            } else {
                // Straight sides use the line fallback; corners are rounded by the fit.
                assert!(lines > 0, "{name}");
            }
        }
    }

    #[test]
    fn spec_form_is_the_scaled_first_row() {
        let pts: [[f64; 2]; 64] = shapes::ellipse(6e-3, 6e-3);
        let c =
            MotionConstraint::<f64, 64>::new(&pts, &ConstraintConfig::closed_contour()).unwrap();
        let x = Vector3::new(6.3e-3, 0.2e-3, 0.0);
        let v = c.evaluate(x, 0.0).unwrap();
        let Fit::Circle { radius, .. } = v.fit else {
            panic!("circle expected")
        };
        let (spec, grad) = v
            .fit
            .spec_form(Vector2::new(x.x, x.y) - c.origin())
            .unwrap();
        // Counter-clockwise data: the centre is on the left, outside is φ₁ < 0.
        assert!(v.phi.x < 0.0);
        assert!((spec / (2.0 * radius) + v.phi.x).abs() < 1e-9);
        assert!(
            (grad / (2.0 * radius) + Vector2::new(v.jacobian[(0, 0)], v.jacobian[(0, 1)])).norm()
                < 1e-3
        );
    }

    #[test]
    fn open_contour_with_inflection_keeps_its_sign() {
        // The 's' bends both ways: φ₁ (left of travel) must not flip sign at the inflection.
        let s = crate::trajectory::resample::densify::<512>(&shapes::letter_s(), 2).unwrap();
        let cfg = ConstraintConfig {
            closed: false,
            ..ConstraintConfig::closed_contour()
        };
        let c = MotionConstraint::<f64, 512>::new(&s, &cfg).unwrap();
        for w in s.windows(2).skip(8).take(s.len() - 20) {
            let (a, b) = (
                Vector2::new(w[0][0], w[0][1]),
                Vector2::new(w[1][0], w[1][1]),
            );
            let t = (b - a).normalize();
            let p = (a + b) / 2.0 + Vector2::new(-t.y, t.x) * 30e-6;
            let v = c.evaluate(Vector3::new(p.x, p.y, 0.0), 0.0).unwrap();
            // Sign first; the size within the data's chord sagitta (≈ 4 µm at R = 4 mm,
            // 0.35 mm segments) plus the fit error of windows spanning the inflection.
            assert!(
                v.phi.x > 0.0 && (v.phi.x - 30e-6).abs() < 20e-6,
                "{}",
                v.phi.x
            );
        }
    }

    #[test]
    fn f32_matches_f64_sliding_along_gear_and_cam() {
        // The f32 path against the f64 one on the same data and the same (f32-exact)
        // end-effector positions, so only arithmetic is compared, not the rounding of
        // the caller's input. Expected size, with ε = f32::EPSILON (1.2e-7):
        // - φ₁: the centred data and query carry ε/2 · |q| (|q| ≤ 10 mm from the data
        //   centroid), and the fitted centre (or line point) c carries ε · |c|; φ₁ is
        //   formed from x − c, so |Δφ₁| ≈ a few ε (|q| + |c|) ≈ 1e-9 m for a 10 mm
        //   contour, more only where a flat window's circle has a far centre.
        // - Jφ row 1: each window's normal comes from point differences over its span,
        //   and the blend weight u = (p − a)·d/|d|² from one data segment of length ℓ,
        //   so both carry ε|q|/ℓ (span ≥ ℓ); at a gear corner u multiplies the
        //   difference of two neighbouring windows' gradients (up to ≈ 2: |Jφ| reaches
        //   1.14 in blends there), and a rounding that tips the nearest-segment tie at a
        //   vertex lands on the same scale: 2ε|q|/ℓ.
        // Bounds: 4× those scales (φ₁: 4 ε(|q| + |c|), Jφ: 8 ε|q|/ℓ). The contours are also run 0.36 m off the frame
        // origin (data in image or machine coordinates): centring must keep the same
        // bounds there, which it did not while the query was centred on the f32-rounded
        // origin and the data on the exact one (13.6 ε (|q| + |c|) on the gear).
        let eps = f64::from(f32::EPSILON);
        println!("f32 against f64, sliding on the contour and 20 µm left of it (16 steps/segment)");
        for shift in [[0.0, 0.0], [0.3, 0.2]] {
            for (name, base, k) in [
                ("gear", shapes::gear().to_vec(), 2),
                ("cam", shapes::cam().to_vec(), 5),
            ] {
                let pts: StdVec<[f64; 2]> = base
                    .iter()
                    .map(|p| [p[0] + shift[0], p[1] + shift[1]])
                    .collect();
                let cfg = ConstraintConfig {
                    half_window: k,
                    ..ConstraintConfig::closed_contour()
                };
                let c64 = MotionConstraint::<f64, 512>::new(&pts, &cfg).unwrap();
                let c32 = MotionConstraint::<f32, 512>::new(&pts, &cfg).unwrap();
                let n = pts.len();
                let (mut phi_abs, mut phi_rel, mut jac_abs, mut jac_rel) =
                    (0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for offset in [0.0, 20e-6] {
                    for i in 0..n {
                        let (a, b) = (pts[i], pts[(i + 1) % n]);
                        let (a, b) = (Vector2::new(a[0], a[1]), Vector2::new(b[0], b[1]));
                        let ell = (b - a).norm();
                        let t = (b - a) / ell;
                        for s in 0..16 {
                            let p =
                                a + (b - a) * (s as f64 / 16.0) + Vector2::new(-t.y, t.x) * offset;
                            let x32 = Vector3::new(p.x as f32, p.y as f32, -0.1f32);
                            let x64 = x32.map(f64::from);
                            let v = c64.evaluate(x64, -0.1).unwrap();
                            let w = c32.evaluate(x32, -0.1).unwrap();
                            let q = (x64.xy() - c64.origin()).norm();
                            let c = match v.fit {
                                Fit::Circle { centre, .. } => centre.norm(),
                                Fit::Line { point, .. } => point.norm(),
                            };
                            let dphi = (f64::from(w.phi.x) - v.phi.x).abs();
                            let djac = (w.jacobian.map(f64::from) - v.jacobian).abs().max();
                            phi_abs = phi_abs.max(dphi);
                            phi_rel = phi_rel.max(dphi / (eps * (q + c)));
                            jac_abs = jac_abs.max(djac);
                            jac_rel = jac_rel.max(djac / (eps * q / ell));
                            // The second row has no arithmetic: exact in both.
                            assert_eq!(w.phi.y, 0.0);
                        }
                    }
                }
                println!(
                    "{name:>5} at ({:.2}, {:.2}) m, k={k}: max |Δφ₁| {:.2} nm = {phi_rel:.2} ε(|q| + |c|), max |ΔJφ| {jac_abs:.2e} = {jac_rel:.2} ε|q|/ℓ",
                    shift[0], shift[1], phi_abs * 1e9
                );
                assert!(phi_rel < 4.0, "{name} {shift:?}: φ₁ {phi_rel} ε(|q| + |c|)");
                assert!(jac_rel < 8.0, "{name} {shift:?}: Jφ {jac_rel} ε|q|/ℓ");
            }
        }
    }

    #[test]
    fn rejects_bad_input() {
        let cfg = ConstraintConfig::closed_contour();
        type C = MotionConstraint<f32, 64>;
        assert_eq!(
            C::new(&[[0.0, 0.0], [1.0, 0.0]], &cfg).err(),
            Some(ContourError::TooFewPoints)
        );
        assert_eq!(
            C::new(&[[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]], &cfg).err(),
            Some(ContourError::RepeatedPoint(2))
        );
        // 2k + 1 = 11 points needed.
        let tri: [[f64; 2]; 8] = shapes::ellipse(1e-3, 1e-3);
        assert_eq!(C::new(&tri, &cfg).err(), Some(ContourError::TooFewPoints));
        assert_eq!(
            C::new(&shapes::cam(), &cfg).err(),
            Some(ContourError::Capacity)
        );
        let bad = ConstraintConfig {
            half_window: 0,
            ..cfg
        };
        assert!(C::new(&shapes::octagon(), &bad).is_err());
        let bad = ConstraintConfig {
            line_sagitta_m: 0.0,
            ..cfg
        };
        assert!(C::new(&shapes::octagon(), &bad).is_err());
    }

    /// Far from the contour in f32 (|p|² overflows), or a non-finite point: a typed
    /// error, never a NaN constraint.
    #[test]
    fn far_or_non_finite_points_are_typed_errors() {
        let pts: [[f64; 2]; 64] = shapes::ellipse(6e-3, 6e-3);
        let c =
            MotionConstraint::<f32, 64>::new(&pts, &ConstraintConfig::closed_contour()).unwrap();
        assert!(c.evaluate(Vector3::new(6.3e-3, 0.2e-3, 0.0), 0.0).is_ok());
        for x in [
            Vector3::new(1e20f32, 1e20, 0.0),
            Vector3::new(-3e38f32, 0.0, 0.0),
            Vector3::new(f32::NAN, 0.0, 0.0),
            Vector3::new(0.0, 0.0, f32::INFINITY),
        ] {
            assert_eq!(
                c.evaluate(x, 0.0).err(),
                Some(ContourError::FarFromContour),
                "{x:?}"
            );
        }
    }
}
