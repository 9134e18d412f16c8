//! Loading a case: the file read, the `--set` overrides applied in order (with the rule
//! for a change of `method.name`), the table parsed and validated.

use super::{Scene, overrides, validate};
use crate::case::{Case, CaseError, read_capped};
use crate::methods::{MethodTable, drop_foreign_keys};
use serde::Deserialize;
use std::path::Path;

/// `method.name` of a case table, if it is a string.
fn method_name(table: &toml::Table) -> Option<String> {
    table
        .get("method")?
        .get("name")?
        .as_str()
        .map(str::to_string)
}

/// A change of method by `--set method.name=X`, applied where it stands among the
/// overrides: the keys of the previous method that X also reads are kept, the others are
/// dropped (unless an override of the command sets them, so that a wrong one is still
/// reported), and a note names the dropped ones.
fn method_change(method: &mut toml::Table, name: &str, overrides: &[String]) -> Option<String> {
    let set: Vec<String> = overrides
        .iter()
        .filter_map(|a| a.split_once('=')?.0.trim().strip_prefix("method."))
        .map(|path| path.split('.').next().unwrap_or(path).to_string())
        .collect();
    let dropped = drop_foreign_keys(method, name, &set);
    (!dropped.is_empty()).then(|| {
        format!(
            "method.name = \"{name}\" does not read {}; dropped from the case",
            dropped
                .iter()
                .map(|k| format!("`method.{k}`"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    })
}

/// The largest case file read [bytes]: 16 MiB (a case is a few kilobytes; bulk data
/// goes in points and mesh files).
const CASE_FILE_CAP: u64 = 16 << 20;

impl Scene {
    /// Reads, overrides (`key.path=value`) and validates a case file.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Scene, CaseError> {
        let text =
            read_capped(path, CASE_FILE_CAP, "a case file").map_err(|source| CaseError::Read {
                file: path.to_path_buf(),
                source,
            })?;
        Self::from_toml(&text, path, overrides)
    }

    /// Parses case text; `file` names it in errors and anchors relative paths.
    pub fn from_toml(text: &str, file: &Path, overrides: &[String]) -> Result<Scene, CaseError> {
        let parse_error = |e: toml::de::Error| CaseError::Parse {
            file: file.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        };
        let mut notes = Vec::new();
        let mut case: Case<MethodTable> = if overrides.is_empty() {
            toml::from_str(text).map_err(parse_error)?
        } else {
            let mut table: toml::Table = toml::from_str(text).map_err(parse_error)?;
            for assignment in overrides {
                let name_before = method_name(&table);
                overrides::apply(&mut table, assignment).map_err(|message| {
                    CaseError::Override {
                        file: file.to_path_buf(),
                        assignment: assignment.clone(),
                        message,
                    }
                })?;
                if let Some(name) = method_name(&table).filter(|n| Some(n) != name_before.as_ref())
                    && let Some(toml::Value::Table(method)) = table.get_mut("method")
                {
                    notes.extend(method_change(method, &name, overrides));
                }
            }
            Case::<MethodTable>::deserialize(table).map_err(parse_error)?
        };
        case.notes = notes;
        case.file = file.to_path_buf();
        case.overrides = overrides.to_vec();
        let scene = Scene::new(case);
        validate::check(&scene).map_err(|(key, message)| CaseError::Invalid {
            file: file.to_path_buf(),
            key,
            message,
        })?;
        Ok(scene)
    }
}
