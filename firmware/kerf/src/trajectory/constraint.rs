//! Motion constraints for manual machining (T 3.3; docs/equations.md §15).
//!
//! Around the end effector x the contour data give a window of 2k + 1 points (T eq. 15),
//! a circle is fitted to it and the constraint is φ(x) = [(x−cx)² + (y−cy)² − r²,
//! z_ref − z] with Jφ = [[2(x−cx), 2(y−cy), 0], [0, 0, −1]] (with the centre the print
//! leaves out: docs/equations.md §15).
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
//!   [`Fit::spec_form`] gives the unscaled pair of docs/equations.md §15.
//! - Windows do not switch abruptly: x is projected on the nearest data segment
//!   [Pi, Pi+1] at fraction u, and φ, Jφ are blended (1 − u)·(window at Pi) + u·(window at
//!   Pi+1), which is continuous when x passes a data point.

use super::{lit, to_f64, ContourError, Float};
use crate::error::{coefficient, positive, representable};
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
    /// The unscaled form for a circle (docs/equations.md §15): (x−cx)² + (y−cy)² − r²
    /// and its gradient 2(x − c); `None` for a line (that form has no finite line
    /// limit).
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
    /// J̇φ ẋ = [this × (ẋ² + ẏ²), 0]: the rate at which φ₁'s gradient turns as the
    /// effector moves, 1/m (s/r of the windows' circles, blended like φ; zero on
    /// lines). The window's own motion (the blend weight, a switch of window) is
    /// not included: it is continuous and slow against the effector's.
    pub gradient_rate_per_m: T,
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
        // Every value in the target scalar: points valid in f64 can overflow f32.
        let scalar = |value: f64| representable::<T>("points", value);
        let origin: Vector2<T> = Vector2::new(scalar(sx / n)?, scalar(sy / n)?);
        let (ox, oy) = (to_f64(origin.x), to_f64(origin.y));
        let mut v = Vec::new();
        for p in points {
            v.push(Vector2::new(scalar(p[0] - ox)?, scalar(p[1] - oy)?))
                .map_err(|_| ContourError::Capacity)?;
        }
        Ok(Self {
            points: v,
            origin,
            config: *config,
            line_sagitta: coefficient("line_sagitta_m", sag)?,
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

    /// φ₁, its gradient and the gradient's rate per planar speed squared for a window
    /// fit (signed distance, left of `dir` positive). For a circle the gradient is
    /// s(x − c)/r, so its time derivative along ẋ gives J̇φ₁ẋ = (s/r)|ẋ|²: the third
    /// value is s/r (zero for a line).
    fn distance(fit: &Fit<T>, dir: &Vector2<T>, x: Vector2<T>) -> (T, Vector2<T>, T) {
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
                    s * inv,
                )
            }
            Fit::Line { point, normal } => (normal.dot(&(x - point)), normal, T::ZERO),
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
        let (phi0, g0, k0) = Self::distance(&fit0, &dir0, p);
        let (phi1, g1, k1) = Self::distance(&fit1, &dir1, p);
        let w = T::one() - u;
        let (phi, g) = (phi0 * w + phi1 * u, g0 * w + g1 * u);
        let value = ConstraintValue {
            phi: Vector2::new(phi, z_ref - x.z),
            jacobian: Matrix2x3::new(g.x, g.y, T::ZERO, T::ZERO, T::ZERO, -T::one()),
            gradient_rate_per_m: k0 * w + k1 * u,
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
mod tests;
