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
