//! Checking what a file says before any work starts: each field against its range, the error
//! naming the file, the field, the value and the range ([`Check`]); and TOML files parsed,
//! refused when they set nothing, then validated ([`load_toml`] for any [`Validate`] format:
//! sensors and recipes).

use serde::de::DeserializeOwned;

use crate::error::{Result, SimError};

/// A file format whose values are checked after parsing.
pub(crate) trait Validate: DeserializeOwned {
    /// The field and the reason of the error for a file that sets nothing (an empty or
    /// truncated file, which would otherwise silently be the defaults).
    const EMPTY: (&'static str, &'static str);

    /// Checks every value, naming `source_name` and the field of the first bad one.
    fn validate(&self, source_name: &str) -> Result<()>;
}

/// Parses the TOML `text` of `source_name` (a file name, for errors) into `T`: missing fields
/// take their defaults, unknown ones and a file that sets nothing are errors, and the values
/// are validated.
/// (The typed parse comes first: its errors name the field, where a plain table parse fails
/// on values only the field type accepts, such as an integer beyond i64.)
pub(crate) fn load_toml<T: Validate>(text: &str, source_name: &str) -> Result<T> {
    let toml_error =
        |e: toml::de::Error| SimError::Toml { source_name: source_name.to_owned(), message: e.to_string() };
    let value: T = toml::from_str(text).map_err(toml_error)?;
    if toml::from_str::<toml::Table>(text).is_ok_and(|t| t.is_empty()) {
        return Err(SimError::invalid(source_name, T::EMPTY.0, T::EMPTY.1));
    }
    value.validate(source_name)?;
    Ok(value)
}

/// Field checks of one file (its name), each an error naming the field on failure.
pub(crate) struct Check<'a>(pub(crate) &'a str);

impl Check<'_> {
    /// An error for `field`.
    pub(crate) fn bad(&self, field: &str, reason: String) -> Result<()> {
        Err(SimError::invalid(self.0, field, reason))
    }

    /// `v` must be finite.
    pub(crate) fn finite(&self, field: &str, v: f64) -> Result<()> {
        if v.is_finite() { Ok(()) } else { self.bad(field, format!("must be a finite number, got {v}")) }
    }

    /// `v` must be finite and within `[lo, hi]` (`unit` follows the bounds in the message).
    pub(crate) fn within(&self, field: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<()> {
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(())
        } else {
            self.bad(field, format!("must be in [{lo}, {hi}]{unit}, got {v}"))
        }
    }

    /// `v` must be a fraction in `[0, 1]`.
    pub(crate) fn fraction(&self, field: &str, v: f64) -> Result<()> {
        if v.is_finite() && (0.0..=1.0).contains(&v) {
            Ok(())
        } else {
            self.bad(field, format!("must be a fraction in [0, 1], got {v}"))
        }
    }

    /// The range `r = [low, high]` must be finite, not inverted, and within `[lo, hi]`.
    pub(crate) fn range(&self, field: &str, r: [f64; 2], lo: f64, hi: f64) -> Result<()> {
        if !r.iter().all(|v| v.is_finite()) {
            return self.bad(field, format!("must be finite, got {r:?}"));
        }
        if r[0] > r[1] {
            return self.bad(field, format!("is inverted: [{}, {}] has low above high", r[0], r[1]));
        }
        if r[0] < lo || r[1] > hi {
            return self.bad(field, format!("must lie within [{lo}, {hi}], got {r:?}"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_name_the_file_field_and_bounds() {
        let c = Check("a.toml");
        let text = |r: Result<()>| r.expect_err("bad").to_string();
        assert!(c.range("x", [0.0, 1.0], 0.0, 2.0).is_ok());
        let e = text(c.range("poses.x_mm", [2.0, 1.0], 0.0, 5.0));
        assert!(e.contains("a.toml") && e.contains("poses.x_mm") && e.contains("inverted"), "{e}");
        assert!(text(c.range("x", [0.0, 9.0], 0.0, 5.0)).contains("[0, 5]"));
        assert!(text(c.range("x", [f64::NAN, 1.0], 0.0, 5.0)).contains("finite"));
        assert!(text(c.within("step", 20.0, 0.01, 10.0, " mm")).contains("[0.01, 10] mm, got 20"));
        assert!(text(c.fraction("f", -0.1)).contains("[0, 1]"));
        assert!(c.fraction("f", 1.0).is_ok() && c.finite("f", 1.0).is_ok() && c.finite("f", f64::INFINITY).is_err());
    }
}
