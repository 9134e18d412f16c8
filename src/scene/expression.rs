//! Values given as expressions of named variables and constants: an initial velocity of
//! the reference coordinates x, y, z (`vy = "0.05*c*sin(PI*x/L)"`), a time law of t.
//! `exmex` parses and evaluates them in f64 (floats only: `1/2` is 0.5), with its
//! functions (sin, cos, tan, exp, ln, sqrt, abs, …) and constants (`PI`, `E`).

use exmex::{Express, FlatEx};
use std::collections::BTreeMap;

/// The reference coordinates an initial field reads, of which a `dim`-D scene has the
/// first `dim`.
pub const COORDINATES: [&str; 3] = ["x", "y", "z"];

/// A parsed expression with, for each of its variables, where its value comes from.
#[derive(Clone, Debug)]
pub struct Expression {
    ex: FlatEx<f64>,
    /// Per variable of `ex`, in its order: one of the variables or a constant.
    slots: Vec<Slot>,
}

#[derive(Clone, Copy, Debug)]
enum Slot {
    Variable(usize),
    Constant(f64),
}

impl Expression {
    /// Parses `text` over `variables` (`what` says what they are, for the errors) and
    /// `constants`; Err says what is wrong: the parser's message, or a name that is
    /// neither, with its position, and the names allowed.
    pub fn parse(
        text: &str,
        variables: &[&str],
        what: &str,
        constants: &BTreeMap<String, f64>,
    ) -> Result<Self, String> {
        let allowed = || {
            let mut names: Vec<&str> = variables.to_vec();
            names.extend(constants.keys().map(String::as_str));
            format!(
                "the names allowed are {} ({what}{}), PI, E and exmex's functions (sin, cos, \
                 exp, sqrt, …)",
                names.join(", "),
                if constants.is_empty() {
                    ""
                } else {
                    " and the constants"
                }
            )
        };
        let ex = exmex::parse::<f64>(text)
            .map_err(|e| format!("`{text}` does not parse: {}; {}", e.msg(), allowed()))?;
        let slots = ex
            .var_names()
            .iter()
            .map(|name| {
                if let Some(k) = variables.iter().position(|c| c == name) {
                    Ok(Slot::Variable(k))
                } else if let Some(&c) = constants.get(name) {
                    Ok(Slot::Constant(c))
                } else {
                    Err(format!(
                        "`{text}` names `{name}` at character {}, which is unknown; {}",
                        position(text, name),
                        allowed()
                    ))
                }
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { ex, slots })
    }

    /// The value at the given values of the variables, in their order.
    pub fn at(&self, values: &[f64]) -> f64 {
        let args: Vec<f64> = self
            .slots
            .iter()
            .map(|s| match *s {
                Slot::Variable(k) => values[k],
                Slot::Constant(c) => c,
            })
            .collect();
        self.ex.eval(&args).unwrap_or(f64::NAN)
    }
}

/// The 1-based character position of the first occurrence of `name` in `text` as a whole
/// name (not inside a longer one).
fn position(text: &str, name: &str) -> usize {
    let is_name = |c: char| c.is_alphanumeric() || c == '_';
    let whole = text.match_indices(name).find(|&(i, _)| {
        let before = text[..i].chars().next_back();
        let after = text[i + name.len()..].chars().next();
        !before.is_some_and(is_name) && !after.is_some_and(is_name)
    });
    whole.map_or(0, |(i, _)| text[..i].chars().count() + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coordinates_and_constants_take_their_values() {
        let constants = BTreeMap::from([("c".to_string(), 2.0), ("L".to_string(), 4.0)]);
        let e = Expression::parse(
            "c*sin(PI*x/L) + y^2 - 1/2",
            &COORDINATES[..2],
            "",
            &constants,
        )
        .unwrap();
        let v = e.at(&[1.0, 3.0]);
        let exact = 2.0 * (std::f64::consts::PI / 4.0).sin() + 9.0 - 0.5;
        assert!((v - exact).abs() < 1e-14, "{v} against {exact}");
    }

    #[test]
    fn an_unknown_name_is_shown_with_its_position_and_the_names_allowed() {
        let xy = &COORDINATES[..2];
        let what = "the reference coordinates";
        let e = Expression::parse("2*x + zz*y", xy, what, &BTreeMap::new()).unwrap_err();
        assert!(e.contains("`zz` at character 7"), "{e}");
        assert!(e.contains("x, y (the reference coordinates)"), "{e}");
        // z is not a coordinate of a 2D scene.
        let e = Expression::parse("z", xy, what, &BTreeMap::new()).unwrap_err();
        assert!(e.contains("`z` at character 1"), "{e}");
        let e = Expression::parse("2*(x", xy, what, &BTreeMap::new()).unwrap_err();
        assert!(e.contains("does not parse"), "{e}");
    }
}
