//! Case files: loading `cases/*.toml` with `--set` overrides, and validation.
//!
//! A case is parsed completely and validated before anything runs; every error names
//! the file, the key and what is allowed. The schema the file is read into is
//! [`crate::case`]; this module adds what needs the method registry: `load` reads a file,
//! applies the overrides of `overrides` and resolves the `[method]` table; `validate`
//! checks the result, each method its own keys.

mod load;
mod overrides;
pub(crate) mod validate;
