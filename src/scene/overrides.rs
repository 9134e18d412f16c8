//! `--set key.path=value` overrides applied to the parsed TOML tree before validation.
//!
//! Path segments are table keys or array indices (`body.0.geometry.radius`). The value
//! is read as a TOML value (`1e-6`, `"rk4"`, `[1.0, 0.0]`, `true`); a bare word that is
//! not valid TOML is taken as a string (`method.integrator=leapfrog`). An empty value
//! (`method.dt=`) removes the key.

use toml::{Table, Value};

pub fn apply(root: &mut Table, assignment: &str) -> Result<(), String> {
    let (path, raw) = assignment
        .split_once('=')
        .ok_or("expected key.path=value")?;
    let keys: Vec<&str> = path.trim().split('.').collect();
    if keys.iter().any(|k| k.is_empty()) {
        return Err(format!("empty segment in key path `{path}`"));
    }
    let raw = raw.trim();
    let value = (!raw.is_empty()).then(|| parse_value(raw));
    set(root, &keys, value, &keys)
}

fn set(
    table: &mut Table,
    keys: &[&str],
    value: Option<Value>,
    full: &[&str],
) -> Result<(), String> {
    let here = full[..full.len() - keys.len() + 1].join(".");
    let Some((key, rest)) = keys.split_first() else {
        unreachable!("apply checks that the path is not empty")
    };
    if rest.is_empty() {
        match value {
            Some(v) => table.insert((*key).to_string(), v),
            None => table.remove(*key),
        };
        return Ok(());
    }
    match table.get_mut(*key) {
        None => Err(format!("no key `{here}` in the case")),
        Some(Value::Table(t)) => set(t, rest, value, full),
        Some(Value::Array(items)) => {
            let len = items.len();
            let index: usize = rest[0].parse().map_err(|_| {
                format!("`{here}` is an array: the next segment must be an index 0..{len}")
            })?;
            let item = items
                .get_mut(index)
                .ok_or_else(|| format!("`{here}` has {len} entries, no index {index}"))?;
            match (item, &rest[1..]) {
                (slot, []) => {
                    *slot = value.ok_or("array entries cannot be removed")?;
                    Ok(())
                }
                (Value::Table(t), deeper) => set(t, deeper, value, full),
                (other, _) => Err(format!(
                    "`{here}.{index}` is of type {}, not a table",
                    other.type_str()
                )),
            }
        }
        Some(other) => Err(format!(
            "`{here}` is of type {}, not a table",
            other.type_str()
        )),
    }
}

fn parse_value(raw: &str) -> Value {
    format!("v = {raw}")
        .parse::<Table>()
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| Value::String(raw.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table() -> Table {
        "a = 1\n[m]\ndt = 1e-6\n[[body]]\nname = \"d\"\n[body.geometry]\nradius = 1.0\n"
            .parse()
            .unwrap()
    }

    #[test]
    fn sets_nested_keys_array_entries_and_removes() {
        let mut t = table();
        apply(&mut t, "m.dt=2e-6").unwrap();
        apply(&mut t, "m.integrator=leapfrog").unwrap();
        apply(&mut t, "body.0.geometry.radius=0.5").unwrap();
        apply(&mut t, "m.cfl=").unwrap();
        apply(&mut t, "m.dt=").unwrap();
        apply(&mut t, "m.correction=none").unwrap();
        assert!(t["m"].get("dt").is_none());
        assert_eq!(t["m"]["correction"].as_str(), Some("none"));
        assert_eq!(t["m"]["integrator"].as_str(), Some("leapfrog"));
        assert_eq!(t["body"][0]["geometry"]["radius"].as_float(), Some(0.5));
    }

    #[test]
    fn bad_paths_are_named() {
        let mut t = table();
        assert!(apply(&mut t, "nope.x=1").unwrap_err().contains("`nope`"));
        assert!(
            apply(&mut t, "body.3.name=x")
                .unwrap_err()
                .contains("no index 3")
        );
        assert!(
            apply(&mut t, "a.b=1")
                .unwrap_err()
                .contains("`a` is of type integer")
        );
        assert!(
            apply(&mut t, "m.dt")
                .unwrap_err()
                .contains("key.path=value")
        );
    }
}
