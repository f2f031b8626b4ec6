//! The G-code path as a natural cubic spline in task space (A §4.1, eq. 47–50;
//! docs/equations.md §16): one cubic per coordinate and segment through the points
//! (x, y, z in m, then the two angles in rad), C² at the points, zero second
//! derivative at both ends.
//!
//! The parameter (A's "spline abscissa", eq. 49) advances from point to point by the
//! chord raised to a power: ½ for centripetal knots, what MATLAB's `cscvn` (used by
//! A) takes, or 1 for chord-length knots. Centripetal knots keep the curve from
//! overshooting or looping where short and long chords meet (at the corners of a
//! pocket path), at the price of a parameter that is not arc length.
//!
//! Chords and arc length are measured in the metric
//! |Δ|² = Δx² + Δy² + Δz² + ρ²(Δa² + Δb²): ρ (m/rad) is the length one radian of the
//! angles counts for, a radius on the part; ρ = 0 measures the tool point alone (then a
//! move that only turns is a repeated point).
//!
//! The second derivatives come from the tridiagonal system of
//! [`super::open_path`] (the same solver, five right-hand sides):
//! hi−1 Mi−1 + 2(hi−1 + hi) Mi + hi Mi+1 = 6((pi+1 − pi)/hi − (pi − pi−1)/hi−1),
//! M0 = Mn = 0. On segment i, with t ∈ [0, hi]:
//! p = pi + si t + Mi t²/2 + (Mi+1 − Mi) t³/(6hi), si = (pi+1 − pi)/hi − hi(2Mi + Mi+1)/6
//! — A eq. 48 with a = pi, b = si, c = Mi/2, d = (Mi+1 − Mi)/(6hi).

use super::gcode::GcodePoint;
use super::open_path::{solve_natural, Knot};
use super::quadrature::gauss3;
use super::{lit, Float};
use crate::error::ConfigError;
use nalgebra::SVector;

/// A task-space pose or one of its derivatives: x, y, z (m), a, b (rad).
pub type Pose<T> = SVector<T, 5>;

/// How far the spline parameter advances from one point to the next.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum KnotSpacing {
    /// √chord (MATLAB's `cscvn`; parameter in m^½).
    Centripetal,
    /// The chord (parameter in m).
    ChordLength,
}

/// How to build a [`TaskSpline`].
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TaskSplineConfig {
    /// Knot spacing.
    pub knots: KnotSpacing,
    /// ρ: length one radian of the angles counts for in chords and arc length, m/rad
    /// (finite, ≥ 0).
    pub angle_length_m_per_rad: f64,
}

/// Why points were refused.
#[derive(Copy, Clone, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TaskSplineError {
    /// A configuration value is bad (names the field).
    Config(ConfigError),
    /// Fewer than 2 points.
    TooFewPoints,
    /// More points than the capacity `N`.
    Capacity,
    /// A coordinate of point `index` is NaN or infinite.
    NotFinitePoint(usize),
    /// Point `index` repeats point `index − 1` in the metric (or is so close that the
    /// parameter does not advance): the segment has no direction.
    RepeatedPoint(usize),
    /// A value the scalar `T` cannot hold (coordinates, parameters, or second
    /// derivatives of knots packed too closely for it).
    NotRepresentable,
}

impl From<ConfigError> for TaskSplineError {
    fn from(e: ConfigError) -> Self {
        TaskSplineError::Config(e)
    }
}

/// Position and parameter derivatives at one parameter value.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TaskSample<T: Float> {
    /// The pose, absolute.
    pub position: Pose<T>,
    /// dp/du.
    pub d1: Pose<T>,
    /// d²p/du².
    pub d2: Pose<T>,
    /// d³p/du³ (constant on a segment).
    pub d3: Pose<T>,
}

/// One knot in the scalar `T`: position relative to the centre, second derivative, and
/// the parameter length h of the segment that starts there (0 on the last).
#[derive(Copy, Clone, Debug, PartialEq)]
struct Node<T: Float> {
    p: Pose<T>,
    m: Pose<T>,
    h: T,
}

/// The natural cubic spline through up to `N` task-space points (module docs).
#[derive(Debug)]
pub struct TaskSpline<T: Float, const N: usize> {
    centre: Pose<T>,
    weights: Pose<T>,
    nodes: heapless::Vec<Node<T>, N>,
    spacing: KnotSpacing,
}

/// The empty spline: no points, every evaluation the origin. What a job holds before
/// one is loaded; anything that runs a path refuses it (fewer than 2 points).
impl<T: Float, const N: usize> Default for TaskSpline<T, N> {
    fn default() -> Self {
        Self {
            centre: Pose::zeros(),
            weights: Pose::zeros(),
            nodes: heapless::Vec::new(),
            spacing: KnotSpacing::Centripetal,
        }
    }
}

/// `clone_from` copies the nodes in place: a spline is kilobytes, and a job that
/// holds one is copied in the control period (the supervisor's `LoadJob`).
impl<T: Float, const N: usize> Clone for TaskSpline<T, N> {
    fn clone(&self) -> Self {
        let mut spline = Self::default();
        spline.clone_from(self);
        spline
    }

    fn clone_from(&mut self, source: &Self) {
        self.centre = source.centre;
        self.weights = source.weights;
        self.spacing = source.spacing;
        self.nodes.clear();
        // Same capacity on both sides: every node fits.
        let _ = self.nodes.extend_from_slice(&source.nodes);
    }
}

/// Weighted dot product of the metric (module docs): weights (1, 1, 1, ρ², ρ²).
fn dot_w<T: Float>(w: &Pose<T>, a: &Pose<T>, b: &Pose<T>) -> T {
    a.component_mul(b).dot(w)
}

impl<T: Float, const N: usize> TaskSpline<T, N> {
    /// The spline through `points` in their order.
    ///
    /// Errors: ρ negative or not finite (`Config` naming `angle_length_m_per_rad`),
    /// fewer than 2 points, more than `N`, a coordinate not finite, a point repeating
    /// the one before, values `T` cannot hold.
    pub fn through(
        points: &[Pose<f64>],
        config: &TaskSplineConfig,
    ) -> Result<Self, TaskSplineError> {
        let rho = config.angle_length_m_per_rad;
        if !rho.is_finite() {
            return Err(ConfigError::not_finite("angle_length_m_per_rad").into());
        }
        if rho < 0.0 {
            return Err(ConfigError::out_of_range("angle_length_m_per_rad").into());
        }
        if points.len() < 2 {
            return Err(TaskSplineError::TooFewPoints);
        }
        if points.len() > N {
            return Err(TaskSplineError::Capacity);
        }
        if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
            return Err(TaskSplineError::NotFinitePoint(i));
        }
        let weights = Pose::<f64>::new(1.0, 1.0, 1.0, rho * rho, rho * rho);
        let centre = points.iter().sum::<Pose<f64>>() / points.len() as f64;
        let mut knots: heapless::Vec<Knot<f64, 5>, N> = heapless::Vec::new();
        let mut u = 0.0;
        let mut previous: Option<&Pose<f64>> = None;
        for (i, p) in points.iter().enumerate() {
            if let Some(q) = previous {
                let d = p - q;
                let chord = libm::sqrt(dot_w(&weights, &d, &d));
                // Knot spacing (A eq. 49 breaks): √chord as cscvn, or the chord.
                let h = match config.knots {
                    KnotSpacing::Centripetal => libm::sqrt(chord),
                    KnotSpacing::ChordLength => chord,
                };
                if !h.is_finite() {
                    return Err(TaskSplineError::NotRepresentable);
                }
                if u + h <= u {
                    return Err(TaskSplineError::RepeatedPoint(i));
                }
                u += h;
            }
            previous = Some(p);
            let knot = Knot {
                u,
                p: p - centre,
                m: Pose::zeros(),
            };
            knots.push(knot).map_err(|_| TaskSplineError::Capacity)?;
        }
        solve_natural(&mut knots);
        let to_t = |v: &Pose<f64>| -> Result<Pose<T>, TaskSplineError> {
            let mut out = Pose::<T>::zeros();
            for (o, x) in out.iter_mut().zip(v.iter()) {
                *o = lit(*x);
                if !o.is_finite() {
                    return Err(TaskSplineError::NotRepresentable);
                }
            }
            Ok(out)
        };
        let mut nodes = heapless::Vec::new();
        for (k, next) in knots
            .iter()
            .zip(knots.iter().skip(1).map(Some).chain([None]))
        {
            let h = next.map_or(0.0, |n| n.u - k.u);
            let h_t: T = lit(h);
            if h > 0.0 && (h_t <= T::ZERO || !h_t.is_finite()) {
                return Err(TaskSplineError::NotRepresentable);
            }
            let node = Node {
                p: to_t(&k.p)?,
                m: to_t(&k.m)?,
                h: h_t,
            };
            nodes.push(node).map_err(|_| TaskSplineError::Capacity)?;
        }
        let spline = Self {
            centre: to_t(&centre)?,
            weights: to_t(&weights)?,
            nodes,
            spacing: config.knots,
        };
        // What evaluation forms must be finite in T (the jerk (Mi+1 − Mi)/hi of
        // knots packed closely is the largest).
        let all_finite = (0..spline.segments()).all(|i| {
            let s = spline.evaluate(i, spline.segment_parameter(i));
            [s.position, s.d1, s.d2, s.d3]
                .iter()
                .all(|v| v.iter().all(|x| x.is_finite()))
        });
        if all_finite {
            Ok(spline)
        } else {
            Err(TaskSplineError::NotRepresentable)
        }
    }

    /// The spline through the points of a G-code file ([`super::gcode`]), as
    /// (x, y, z, A, B).
    pub fn through_gcode(
        points: &[GcodePoint],
        config: &TaskSplineConfig,
    ) -> Result<Self, TaskSplineError> {
        let mut poses: heapless::Vec<Pose<f64>, N> = heapless::Vec::new();
        for p in points {
            let [x, y, z] = p.position_m;
            let [a, b] = p.angles_rad;
            poses
                .push(Pose::new(x, y, z, a, b))
                .map_err(|_| TaskSplineError::Capacity)?;
        }
        Self::through(&poses, config)
    }

    /// Number of points.
    pub fn points(&self) -> usize {
        self.nodes.len()
    }

    /// Number of segments (points − 1).
    pub fn segments(&self) -> usize {
        self.nodes.len().saturating_sub(1)
    }

    /// The knot spacing the spline was built with.
    pub fn spacing(&self) -> KnotSpacing {
        self.spacing
    }

    /// Parameter length hi of segment `i` (0 past the last).
    pub fn segment_parameter(&self, i: usize) -> T {
        if i < self.segments() {
            self.nodes.get(i).map_or(T::ZERO, |n| n.h)
        } else {
            T::ZERO
        }
    }

    /// Point `i` as given (absolute).
    pub fn point(&self, i: usize) -> Option<Pose<T>> {
        self.nodes.get(i).map(|n| n.p + self.centre)
    }

    /// The metric's norm of a pose difference or derivative (module docs).
    pub fn metric_norm(&self, v: &Pose<T>) -> T {
        dot_w(&self.weights, v, v).fsqrt()
    }

    /// The metric's dot product.
    pub fn metric_dot(&self, a: &Pose<T>, b: &Pose<T>) -> T {
        dot_w(&self.weights, a, b)
    }

    /// Pose and parameter derivatives on segment `i` at t (0 ≤ t ≤ hi; outside, the
    /// segment's cubic continues). A segment past the last is the last.
    pub fn evaluate(&self, i: usize, t: T) -> TaskSample<T> {
        let i = i.min(self.segments().saturating_sub(1));
        let zero = Pose::zeros();
        let (Some(a), Some(b)) = (self.nodes.get(i), self.nodes.get(i + 1)) else {
            let p = self.nodes.first().map_or(zero, |n| n.p) + self.centre;
            return TaskSample {
                position: p,
                d1: zero,
                d2: zero,
                d3: zero,
            };
        };
        let h = a.h;
        let six = lit::<T>(6.0);
        let half = lit::<T>(0.5);
        // A eq. 48 with the coefficients of the module docs.
        let jerk = (b.m - a.m) / h;
        let slope = (b.p - a.p) / h - (a.m * lit::<T>(2.0) + b.m) * (h / six);
        TaskSample {
            position: self.centre
                + a.p
                + slope * t
                + a.m * (half * t * t)
                + jerk * (t * t * t / six),
            d1: slope + a.m * t + jerk * (half * t * t),
            d2: a.m + jerk * t,
            d3: jerk,
        }
    }

    /// |dp/du| in the metric on segment `i` at t.
    pub fn speed(&self, i: usize, t: T) -> T {
        self.metric_norm(&self.evaluate(i, t).d1)
    }

    /// Arc length of segment `i` from t0 to t1 (m): 3-point Gauss–Legendre on
    /// `panels` equal panels.
    pub fn arc_length(&self, i: usize, t0: T, t1: T, panels: usize) -> T {
        let n = panels.max(1);
        let h = (t1 - t0) / lit(n as f64);
        (0..n).fold(T::ZERO, |sum, k| {
            let a = t0 + h * lit(k as f64);
            sum + gauss3(h, |u| self.speed(i, a + u))
        })
    }

    /// Length of the whole path, m: 32 Gauss–Legendre panels per segment (the error of
    /// 3-point Gauss–Legendre falls as the sixth power of the panel; the tests compare
    /// it with an extrapolated sum of 4·10⁵ chords: within 1e-10 relative).
    pub fn length_m(&self) -> T {
        (0..self.segments()).fold(T::ZERO, |sum, i| {
            sum + self.arc_length(i, T::ZERO, self.segment_parameter(i), 32)
        })
    }

    /// Largest distance (metric) of the spline from the G-code polyline: on each
    /// segment, `samples` parameter values, each measured to the straight chord
    /// between the segment's two points (the closest point of that chord). How far
    /// the smooth path strays from the programmed straight moves.
    pub fn polyline_deviation(&self, samples: usize) -> T {
        let n = samples.max(1);
        let mut worst = T::ZERO;
        for i in 0..self.segments() {
            let (Some(a), Some(b)) = (self.nodes.get(i), self.nodes.get(i + 1)) else {
                continue;
            };
            let chord = b.p - a.p;
            let len2 = self.metric_dot(&chord, &chord);
            for k in 1..n {
                let t = a.h * lit(k as f64 / n as f64);
                let rel = self.evaluate(i, t).position - self.centre - a.p;
                let along = if len2 > T::ZERO {
                    (self.metric_dot(&rel, &chord) / len2)
                        .max(T::ZERO)
                        .min(T::one())
                } else {
                    T::ZERO
                };
                worst = worst.max(self.metric_norm(&(rel - chord * along)));
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests;
