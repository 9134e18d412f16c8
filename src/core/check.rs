//! The vocabulary of a case's checks, below every layer that checks its part of a case:
//! a [`Problem`] (the dotted key and what is wrong with it, which the scene reports with
//! the file) and the tests of a value that the checks share.

use serde::Serialize;

/// A check that failed: the dotted key and what is wrong with it.
pub type Problem = (String, String);

/// A check's outcome.
pub type Checked = Result<(), Problem>;

/// The problem of `key`, as a check's outcome.
pub fn fail(key: impl Into<String>, message: impl Into<String>) -> Checked {
    Err((key.into(), message.into()))
}

/// The name a unit enum variant has in case files (`neck-height`, `z`).
pub fn toml_name<T: Serialize>(value: &T) -> String {
    serde_json::to_value(value)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| "?".to_string())
}

/// Finite and strictly positive.
pub fn positive(key: &str, value: f64) -> Checked {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        fail(key, format!("must be a finite number > 0, got {value:?}"))
    }
}

/// Finite and ≥ 0.
pub fn non_negative(key: &str, value: f64) -> Checked {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        fail(key, format!("must be a finite number ≥ 0, got {value:?}"))
    }
}
