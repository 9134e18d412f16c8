//! The error of a case: a file that cannot be read or parsed, an override that does not
//! apply, a key whose value is not allowed, or, on several ranks, another rank's failed
//! set-up of it.

use std::path::PathBuf;
use thiserror::Error;

/// What is wrong with a case file.
#[derive(Debug, Error)]
pub enum CaseError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: {message}")]
    Parse { file: PathBuf, message: String },
    #[error("{file}: --set {assignment}: {message}")]
    Override {
        file: PathBuf,
        assignment: String,
        message: String,
    },
    #[error("{file}: key `{key}`: {message}")]
    Invalid {
        file: PathBuf,
        key: String,
        message: String,
    },
    /// Rank `rank` of a distributed run could not set up its particles (it reports its
    /// own error); the other ranks stop with this one rather than wait for it.
    #[error("{file}: rank {rank} could not set up its particles: its error says why")]
    OtherRank { file: PathBuf, rank: usize },
    /// The run cannot be split among its ranks (more ranks than particles).
    #[error("{file}: {reason}")]
    Ranks { file: PathBuf, reason: String },
    /// An environment variable the run reads has a value it cannot use.
    #[error("{variable}={value}: {message}")]
    Environment {
        variable: &'static str,
        value: String,
        message: String,
    },
}

/// A positive size in bytes that an environment variable states: a number, then an
/// optional unit, B, kB, MB, GB, TB (powers of 1000) or KiB, MiB, GiB, TiB (powers of
/// 1024).
pub fn parse_bytes(text: &str) -> Option<f64> {
    let text = text.trim();
    let split = text
        .find(|c: char| c.is_ascii_alphabetic() && c != 'e' && c != 'E')
        .unwrap_or(text.len());
    let (number, unit) = text.split_at(split);
    let scale = match unit.trim() {
        "" | "B" => 1.0,
        "kB" | "KB" => 1e3,
        "MB" => 1e6,
        "GB" => 1e9,
        "TB" => 1e12,
        "KiB" => 1024.0,
        "MiB" => 1024.0f64.powi(2),
        "GiB" => 1024.0f64.powi(3),
        "TiB" => 1024.0f64.powi(4),
        _ => return None,
    };
    let bytes = number.trim().parse::<f64>().ok()? * scale;
    (bytes.is_finite() && bytes > 0.0).then_some(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stated_size_reads_bytes_and_units() {
        // Decimal and binary units, a space before the unit, an exponent; nothing else.
        assert_eq!(parse_bytes("80GB"), Some(80e9));
        assert_eq!(parse_bytes("141 GB"), Some(141e9));
        assert_eq!(parse_bytes("24GiB"), Some(24.0 * 1024f64.powi(3)));
        assert_eq!(parse_bytes("512MiB"), Some(512.0 * 1024f64.powi(2)));
        assert_eq!(parse_bytes("1.5e9"), Some(1.5e9));
        assert_eq!(parse_bytes("4096"), Some(4096.0));
        for bad in ["", "GB", "-1GB", "0", "80 gigabytes", "inf", "1e400"] {
            assert_eq!(parse_bytes(bad), None, "{bad}");
        }
    }
}
