//! Configuration errors shared by every `new(config)` in the crate.

/// Why a configuration was rejected. The `&'static str` names the offending field
/// (for example `"pitch_m"`), so a log line says exactly what to fix.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// The value is NaN or infinite.
    NotFinite(&'static str),
    /// The value must be strictly positive.
    NotPositive(&'static str),
    /// The value is finite and positive but outside the range the algorithm supports.
    OutOfRange(&'static str),
}

/// Checks that `value` is finite and strictly positive.
pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64, ConfigError> {
    if !value.is_finite() {
        Err(ConfigError::NotFinite(name))
    } else if value <= 0.0 {
        Err(ConfigError::NotPositive(name))
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
        Err(ConfigError::NotFinite(name))
    } else if value < lo || value > hi {
        Err(ConfigError::OutOfRange(name))
    } else {
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checks_name_the_field() {
        assert_eq!(
            positive("ts_s", f64::NAN),
            Err(ConfigError::NotFinite("ts_s"))
        );
        assert_eq!(positive("ts_s", 0.0), Err(ConfigError::NotPositive("ts_s")));
        assert_eq!(
            positive("ts_s", -1.0),
            Err(ConfigError::NotPositive("ts_s"))
        );
        assert_eq!(positive("ts_s", 1e-4), Ok(1e-4));
        assert_eq!(
            in_range("x", 2.0, 0.0, 1.0),
            Err(ConfigError::OutOfRange("x"))
        );
        assert_eq!(
            in_range("x", f64::INFINITY, 0.0, 1.0),
            Err(ConfigError::NotFinite("x"))
        );
    }
}
