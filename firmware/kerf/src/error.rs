//! Configuration errors shared by every `new(config)` in the crate.
//!
//! A [`ConfigError`] says what is wrong ([`ConfigErrorKind`]) and where: the whole
//! path of the field from the machine's config down, indices included, for example
//! `slave.axes[2].dob.bandwidth_rad_s`. Leaf checks name the field; each level above
//! adds its own part with [`ConfigContext::within`] and [`ConfigContext::at`], so a
//! part validated on its own reports a short path and the same part inside a machine
//! reports the full one.

use crate::scalar::Real;
use core::fmt;

/// What is wrong with a configuration value.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigErrorKind {
    /// The value is NaN or infinite.
    NotFinite,
    /// The value must be strictly positive.
    NotPositive,
    /// The value is finite and positive but outside the range the algorithm supports.
    OutOfRange,
    /// The value is valid in `f64`, but a coefficient derived from it is infinite, NaN,
    /// zero or saturated in the target scalar (tiny periods, huge gains, tiny
    /// bandwidths in `f32` or fixed point).
    NotRepresentable,
}

impl ConfigErrorKind {
    fn describe(self) -> &'static str {
        match self {
            Self::NotFinite => "not finite",
            Self::NotPositive => "not strictly positive",
            Self::OutOfRange => "out of the supported range",
            Self::NotRepresentable => "not representable in the target scalar",
        }
    }
}

/// One step of a path into a configuration.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PathSegment {
    /// A named field (`dob`, `bandwidth_rad_s`).
    Field(&'static str),
    /// An element of an array (`[2]`).
    Index(u16),
}

/// Deepest path a [`ConfigError`] keeps; outer parts beyond it are dropped and the
/// path is shown with a leading `…`.
pub const MAX_PATH_DEPTH: usize = 6;

/// Where in a configuration the bad value is: innermost segment last.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigPath {
    segments: [PathSegment; MAX_PATH_DEPTH],
    len: u8,
    truncated: bool,
}

impl ConfigPath {
    const fn leaf(field: &'static str) -> Self {
        let mut segments = [PathSegment::Index(0); MAX_PATH_DEPTH];
        segments[0] = PathSegment::Field(field);
        Self {
            segments,
            len: 1,
            truncated: false,
        }
    }

    /// The segments, outermost first.
    pub fn segments(&self) -> &[PathSegment] {
        self.segments.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The innermost field name (the value itself).
    pub fn field(&self) -> &'static str {
        self.segments()
            .iter()
            .rev()
            .find_map(|s| match s {
                PathSegment::Field(name) => Some(*name),
                PathSegment::Index(_) => None,
            })
            .unwrap_or("")
    }

    fn prepend(mut self, segment: PathSegment) -> Self {
        let len = usize::from(self.len);
        let Some(grown) = self
            .len
            .checked_add(1)
            .filter(|&n| usize::from(n) <= MAX_PATH_DEPTH)
        else {
            self.truncated = true;
            return self;
        };
        self.segments.copy_within(0..len, 1);
        self.segments[0] = segment;
        self.len = grown;
        self
    }
}

impl fmt::Display for ConfigPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.truncated {
            f.write_str("…")?;
        }
        for (k, segment) in self.segments().iter().enumerate() {
            match segment {
                PathSegment::Field(name) if k == 0 && !self.truncated => f.write_str(name)?,
                PathSegment::Field(name) => write!(f, ".{name}")?,
                PathSegment::Index(i) => write!(f, "[{i}]")?,
            }
        }
        Ok(())
    }
}

/// Why a configuration was rejected, and the full path of the offending field, so a
/// log line says exactly what to fix (`slave.axes[2].dob.bandwidth_rad_s: not
/// strictly positive`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigError {
    /// What is wrong.
    pub kind: ConfigErrorKind,
    /// Where.
    pub path: ConfigPath,
}

impl ConfigError {
    /// `field` is NaN or infinite.
    pub const fn not_finite(field: &'static str) -> Self {
        Self::new(ConfigErrorKind::NotFinite, field)
    }
    /// `field` must be strictly positive.
    pub const fn not_positive(field: &'static str) -> Self {
        Self::new(ConfigErrorKind::NotPositive, field)
    }
    /// `field` is outside the supported range.
    pub const fn out_of_range(field: &'static str) -> Self {
        Self::new(ConfigErrorKind::OutOfRange, field)
    }
    /// A coefficient derived from `field` does not survive the target scalar.
    pub const fn not_representable(field: &'static str) -> Self {
        Self::new(ConfigErrorKind::NotRepresentable, field)
    }

    const fn new(kind: ConfigErrorKind, field: &'static str) -> Self {
        Self {
            kind,
            path: ConfigPath::leaf(field),
        }
    }

    /// The error as seen from the struct that holds the failing part in `field`.
    #[must_use]
    pub fn within(mut self, field: &'static str) -> Self {
        self.path = self.path.prepend(PathSegment::Field(field));
        self
    }

    /// The error as seen from the array that holds the failing part at `index`.
    #[must_use]
    pub fn at(mut self, index: usize) -> Self {
        let index = u16::try_from(index).unwrap_or(u16::MAX);
        self.path = self.path.prepend(PathSegment::Index(index));
        self
    }

    /// The error of element `index` of the array field it names (`travel_m[1]`).
    #[must_use]
    pub fn indexed(mut self, index: usize) -> Self {
        let index = u16::try_from(index).unwrap_or(u16::MAX);
        let len = usize::from(self.path.len);
        if let Some(slot) = self.path.segments.get_mut(len) {
            *slot = PathSegment::Index(index);
            self.path.len += 1;
        } else {
            self.path.truncated = true;
        }
        self
    }

    /// The innermost field name.
    pub fn field(&self) -> &'static str {
        self.path.field()
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path, self.kind.describe())
    }
}

impl core::error::Error for ConfigError {}

/// Adds path context to a `Result<_, ConfigError>` on the way up.
pub trait ConfigContext: Sized {
    /// See [`ConfigError::within`].
    #[must_use]
    fn within(self, field: &'static str) -> Self;
    /// See [`ConfigError::at`].
    #[must_use]
    fn at(self, index: usize) -> Self;
}

impl<T> ConfigContext for Result<T, ConfigError> {
    fn within(self, field: &'static str) -> Self {
        self.map_err(|e| e.within(field))
    }
    fn at(self, index: usize) -> Self {
        self.map_err(|e| e.at(index))
    }
}

/// Checks that `value` is finite and strictly positive.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64, ConfigError> {
    if !value.is_finite() {
        Err(ConfigError::not_finite(name))
    } else if value <= 0.0 {
        Err(ConfigError::not_positive(name))
    } else {
        Ok(value)
    }
}

/// Checks that `value` is finite and inside `[lo, hi]`.
pub(crate) fn in_range(
    name: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
) -> Result<f64, ConfigError> {
    if !value.is_finite() {
        Err(ConfigError::not_finite(name))
    } else if value < lo || value > hi {
        Err(ConfigError::out_of_range(name))
    } else {
        Ok(value)
    }
}

/// Converts a derived, necessarily non-zero coefficient to the target scalar, or
/// names `name` (the config field it comes from) as not representable.
///
/// Accepted when the value is finite and non-zero in `f64` and its rounded form in `T`
/// is within 1/16 of it (four significant bits): that rejects overflow to ∞, underflow
/// to zero or to a subnormal that has lost that much, and fixed-point saturation, while leaving room for the
/// quantization a fixed-point coefficient legitimately has (Ts²/2 at 10 kHz is 21.5
/// LSB in Q31.32, 2.3 % off).
pub(crate) fn coefficient<T: Real>(name: &'static str, value: f64) -> Result<T, ConfigError> {
    let converted = T::from_f64(value);
    let back = converted.to_f64();
    let exact_enough =
        value.is_finite() && value != 0.0 && libm::fabs(back - value) <= libm::fabs(value) / 16.0;
    if exact_enough && converted.is_finite() {
        Ok(converted)
    } else {
        Err(ConfigError::not_representable(name))
    }
}

/// Converts a derived coefficient that may be exactly zero (a gain switched off, a
/// zero noise floor) to the target scalar: zero as it is, anything else checked as by
/// [`coefficient`], so that a non-zero gain never becomes zero, infinite or NaN in `T`
/// (a derivative gain K_D/Ts of 1e300 is finite in `f64` and ∞ in `f32`, and ∞ × 0 is
/// NaN in the first period). A NaN or infinite value is named `NotFinite`.
pub(crate) fn coefficient_or_zero<T: Real>(
    name: &'static str,
    value: f64,
) -> Result<T, ConfigError> {
    if !value.is_finite() {
        Err(ConfigError::not_finite(name))
    } else if value == 0.0 {
        Ok(T::ZERO)
    } else {
        coefficient(name, value)
    }
}

/// Converts a derived, necessarily non-zero constant factor of a signal to the target
/// scalar's coefficient type ([`Real::coef`]), or names `name` as not representable.
///
/// The same test as [`coefficient`]: finite and non-zero in `f64`, and within 1/16 of
/// itself once converted. For the floats and Q31.32 the coefficient is the scalar
/// itself, so the two agree; for [`Q6_25`](crate::scalar::Q6_25) it rejects gains
/// beyond a [`Gain`](crate::scalar::Gain)'s ±2^30 and below its 2^-62 step.
pub(crate) fn factor<T: Real>(name: &'static str, value: f64) -> Result<T::Coef, ConfigError> {
    let converted = T::coef(value);
    let back = T::coef_to_f64(converted);
    if value.is_finite() && value != 0.0 && libm::fabs(back - value) <= libm::fabs(value) / 16.0 {
        Ok(converted)
    } else {
        Err(ConfigError::not_representable(name))
    }
}

/// `value` (a position, distance, speed, time in SI units; zero allowed) in the target
/// scalar: finite there, and within 1/16 of itself or within 1e-9 absolute (what the
/// scalar cannot resolve, such as f32 underflow or Q31.32's 2^-32 step, is that small),
/// or within half the step of a coarser fixed-point scalar ([`Real::FIXED_STEP`]:
/// Q6.25's 2^-25 ≈ 3e-8 m, which a position legitimately rounds to).
/// Overflow to ±inf (f32) or saturation (Q31_32) is `NotRepresentable`.
pub(crate) fn representable<T: Real>(name: &'static str, value: f64) -> Result<T, ConfigError> {
    if !value.is_finite() {
        return Err(ConfigError::not_finite(name));
    }
    let converted = T::from_f64(value);
    let error = libm::fabs(converted.to_f64() - value);
    let absolute = if T::FIXED_STEP / 2.0 > 1e-9 {
        T::FIXED_STEP / 2.0
    } else {
        1e-9
    };
    if converted.is_finite() && (error <= libm::fabs(value) / 16.0 || error <= absolute) {
        Ok(converted)
    } else {
        Err(ConfigError::not_representable(name))
    }
}

/// Every element of the array field `name` as by [`representable`]; a bad one is named
/// with its index (`home_m[1]`).
pub(crate) fn representable_each<T: Real, const N: usize>(
    name: &'static str,
    values: [f64; N],
) -> Result<[T; N], ConfigError> {
    let mut out = [T::ZERO; N];
    for (k, (o, v)) in out.iter_mut().zip(values).enumerate() {
        *o = representable(name, v).map_err(|e| e.indexed(k))?;
    }
    Ok(out)
}

/// `build` applied to each element of `parts`, in order; the first error is returned
/// (the caller names the element). The array is filled in place from its first element:
/// collecting through a vector and converting it moved every element twice more, and
/// with decoder tables of 1.7 KB per axis those moves, unrolled, were most of a
/// constructor's flash. An empty array has nothing to build from and is refused as
/// `name`.
pub(crate) fn build_each<P, U: Copy, E, const N: usize>(
    name: &'static str,
    parts: &[P; N],
    mut build: impl FnMut(usize, &P) -> Result<U, E>,
    empty: impl FnOnce(ConfigError) -> E,
) -> Result<[U; N], E> {
    let Some(first) = parts.first() else {
        return Err(empty(ConfigError::out_of_range(name)));
    };
    let mut out = [build(0, first)?; N];
    for (k, (slot, part)) in out.iter_mut().zip(parts).enumerate().skip(1) {
        *slot = build(k, part)?;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::Q31_32;
    use std::string::ToString;

    /// Every element is built, in order, with its index; the first failure is returned
    /// and nothing after it is built; an empty array is refused by the caller's name.
    #[test]
    fn build_each_builds_in_order_and_stops_at_the_first_failure() {
        let mut seen = std::vec::Vec::new();
        let built = build_each(
            "x",
            &[3.0, 5.0, 7.0],
            |k, v: &f64| {
                seen.push(k);
                Ok::<_, ConfigError>(v * 2.0 + k as f64)
            },
            |e| e,
        );
        assert_eq!(built, Ok([6.0, 11.0, 16.0]));
        assert_eq!(seen, [0, 1, 2]);
        seen.clear();
        let failed = build_each(
            "x",
            &[1.0, -1.0, -2.0],
            |k, v: &f64| {
                seen.push(k);
                positive("x", *v).map_err(|e| e.indexed(k))
            },
            |e| e,
        );
        assert_eq!(
            failed.unwrap_err().to_string(),
            ConfigError::not_positive("x").indexed(1).to_string()
        );
        assert_eq!(seen, [0, 1]);
        let empty: [f64; 0] = [];
        assert_eq!(
            build_each("x", &empty, |_, v: &f64| Ok::<_, ConfigError>(*v), |e| e),
            Err(ConfigError::out_of_range("x"))
        );
    }

    #[test]
    fn checks_name_the_field() {
        assert_eq!(
            positive("ts_s", f64::NAN),
            Err(ConfigError::not_finite("ts_s"))
        );
        assert_eq!(
            positive("ts_s", 0.0),
            Err(ConfigError::not_positive("ts_s"))
        );
        assert_eq!(
            positive("ts_s", -1.0),
            Err(ConfigError::not_positive("ts_s"))
        );
        assert_eq!(positive("ts_s", 1e-4), Ok(1e-4));
        assert_eq!(
            in_range("x", 2.0, 0.0, 1.0),
            Err(ConfigError::out_of_range("x"))
        );
        assert_eq!(
            in_range("x", f64::INFINITY, 0.0, 1.0),
            Err(ConfigError::not_finite("x"))
        );
    }

    #[test]
    fn path_is_built_outwards_and_displayed_with_indices() {
        let e = ConfigError::not_positive("bandwidth_rad_s")
            .within("dob")
            .at(2)
            .within("axes")
            .within("slave");
        assert_eq!(
            e.to_string(),
            "slave.axes[2].dob.bandwidth_rad_s: not strictly positive"
        );
        assert_eq!(e.field(), "bandwidth_rad_s");
        let r: Result<(), _> = Err(ConfigError::out_of_range("theta_rad"));
        let e = r.at(1).within("actuators").within("delta").unwrap_err();
        assert_eq!(
            e.to_string(),
            "delta.actuators[1].theta_rad: out of the supported range"
        );
        assert_eq!(
            e.path.segments(),
            &[
                PathSegment::Field("delta"),
                PathSegment::Field("actuators"),
                PathSegment::Index(1),
                PathSegment::Field("theta_rad"),
            ]
        );
    }

    #[test]
    fn too_deep_a_path_keeps_the_inner_part() {
        let mut e = ConfigError::not_finite("x");
        for k in 0..MAX_PATH_DEPTH + 3 {
            e = e.at(k);
        }
        let shown = e.to_string();
        assert!(shown.starts_with('…'), "{shown}");
        assert!(shown.ends_with("x: not finite"), "{shown}");
        assert_eq!(e.path.segments().len(), MAX_PATH_DEPTH);
    }

    #[test]
    fn derived_coefficients_are_checked_in_the_target_scalar() {
        // Fine in f64, gone in f32: overflow, underflow to zero, subnormal.
        assert_eq!(coefficient::<f64>("g", 1e300), Ok(1e300));
        assert!(coefficient::<f32>("g", 1e300).is_err());
        assert!(coefficient::<f32>("g", 1e-50).is_err());
        assert!(coefficient::<f32>("g", 3e-45).is_err());
        assert_eq!(coefficient::<f32>("g", 1e-30), Ok(1e-30));
        // Q31.32: saturation above 2^31 and quantization below 16 LSB.
        assert!(coefficient::<Q31_32>("g", 3e9).is_err());
        assert!(coefficient::<Q31_32>("g", 1e-10).is_err());
        assert!(coefficient::<Q31_32>("g", 5e-9).is_ok());
        for bad in [0.0, f64::NAN, f64::INFINITY] {
            assert_eq!(
                coefficient::<f64>("g", bad),
                Err(ConfigError::not_representable("g"))
            );
        }
        // A gain that may be off: zero passes, any other value is checked the same way.
        assert_eq!(coefficient_or_zero::<f32>("g", 0.0), Ok(0.0));
        assert_eq!(coefficient_or_zero::<f32>("g", 2.5), Ok(2.5));
        for bad in [1e300, -1e300, 1e-50, 3e-45] {
            assert_eq!(
                coefficient_or_zero::<f32>("g", bad),
                Err(ConfigError::not_representable("g"))
            );
        }
        assert_eq!(
            coefficient_or_zero::<f64>("g", f64::NAN),
            Err(ConfigError::not_finite("g"))
        );
    }
}
