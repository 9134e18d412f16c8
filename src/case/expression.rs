//! Values given as expressions of named variables and constants: an initial velocity of
//! the reference coordinates x, y, z (`vy = "0.05*c*sin(PI*x/L)"`), a time law of t.
//!
//! The grammar, from the loosest binding to the tightest:
//! `sum := product (('+' | '-') product)*`, `product := signed (('*' | '/') signed)*`,
//! `signed := ('+' | '-') signed | power`, `power := atom ('^' signed)?` (so `-x^2` is
//! −(x²) and `2^3^2` is 2^9), `atom := number | name | function '(' sum ')' | '(' sum ')'`.
//! Numbers are every finite decimal literal that `f64::from_str` reads (`3`, `.5`, `1e-3`,
//! `2.5E+6`); `nan` and `inf` are names, and so refused. Arithmetic is in f64 (`1/2` is
//! 0.5), `^` is `powf`. The parser is a single pass over the text and compiles to a
//! postfix program, so both parsing and evaluation take time linear in the length, which
//! [`MAX_LENGTH`] caps; parentheses nest at most [`MAX_DEPTH`] deep.

use std::collections::BTreeMap;

/// The reference coordinates an initial field reads, of which a `dim`-D scene has the
/// first `dim`.
pub const COORDINATES: [&str; 3] = ["x", "y", "z"];

/// The longest expression taken, in characters.
pub const MAX_LENGTH: usize = 4096;

/// The deepest nesting of parentheses and signs taken.
pub const MAX_DEPTH: usize = 64;

/// The named constants every expression knows.
const CONSTANTS: [(&str, f64); 5] = [
    ("PI", std::f64::consts::PI),
    ("π", std::f64::consts::PI),
    ("TAU", std::f64::consts::TAU),
    ("τ", std::f64::consts::TAU),
    ("E", std::f64::consts::E),
];

/// A function of one argument.
type Function = fn(f64) -> f64;

/// The functions of one argument every expression knows.
const FUNCTIONS: [(&str, Function); 22] = [
    ("abs", f64::abs),
    ("signum", f64::signum),
    ("sin", f64::sin),
    ("cos", f64::cos),
    ("tan", f64::tan),
    ("asin", f64::asin),
    ("acos", f64::acos),
    ("atan", f64::atan),
    ("sinh", f64::sinh),
    ("cosh", f64::cosh),
    ("tanh", f64::tanh),
    ("floor", f64::floor),
    ("ceil", f64::ceil),
    ("trunc", f64::trunc),
    ("fract", f64::fract),
    ("exp", f64::exp),
    ("sqrt", f64::sqrt),
    ("cbrt", f64::cbrt),
    ("ln", f64::ln),
    ("log", f64::ln),
    ("log2", f64::log2),
    ("log10", f64::log10),
];

/// A parsed expression: a postfix program over the values of its variables.
#[derive(Clone, Debug)]
pub struct Expression {
    program: Vec<Op>,
    /// The deepest the evaluation stack gets.
    depth: usize,
}

/// One instruction of the postfix program.
#[derive(Clone, Copy, Debug)]
enum Op {
    Number(f64),
    Variable(usize),
    Negate,
    Add,
    Subtract,
    Multiply,
    Divide,
    Power,
    Call(Function),
}

impl Op {
    /// The change of the stack's height when the instruction runs.
    fn push(self) -> isize {
        match self {
            Op::Number(_) | Op::Variable(_) => 1,
            Op::Negate | Op::Call(_) => 0,
            Op::Add | Op::Subtract | Op::Multiply | Op::Divide | Op::Power => -1,
        }
    }
}

impl Expression {
    /// Parses `text` over `variables` (`what` says what they are, for the errors) and
    /// `constants`; Err says what is wrong and at which character, with the names allowed.
    pub fn parse(
        text: &str,
        variables: &[&str],
        what: &str,
        constants: &BTreeMap<String, f64>,
    ) -> Result<Self, String> {
        let allowed = || {
            let mut names: Vec<&str> = variables.to_vec();
            names.extend(constants.keys().map(String::as_str));
            let functions: Vec<&str> = FUNCTIONS.iter().map(|f| f.0).collect();
            format!(
                "the names allowed are {} ({what}{}), PI, TAU, E and the functions {}",
                names.join(", "),
                if constants.is_empty() {
                    ""
                } else {
                    " and the constants"
                },
                functions.join(", ")
            )
        };
        let length = text.chars().count();
        if length > MAX_LENGTH {
            return Err(format!(
                "is {length} characters long; an expression takes at most {MAX_LENGTH}"
            ));
        }
        let mut parser = Parser {
            chars: text.char_indices().collect(),
            at: 0,
            variables,
            constants,
            program: Vec::new(),
            depth: 0,
        };
        let program = parser.whole().map_err(|e| match e {
            Error::Syntax { column, message } => {
                format!("`{text}` does not parse at character {column}: {message}")
            }
            Error::Unknown { column, name } => format!(
                "`{text}` names `{name}` at character {column}, which is unknown; {}",
                allowed()
            ),
        })?;
        let mut height = 0isize;
        let mut depth = 0;
        for op in &program {
            height += op.push();
            depth = depth.max(height as usize);
        }
        Ok(Self { program, depth })
    }

    /// The value at the given values of the variables, in their order.
    pub fn at(&self, values: &[f64]) -> f64 {
        let mut stack: Vec<f64> = Vec::with_capacity(self.depth);
        for &op in &self.program {
            let value = match op {
                Op::Number(c) => c,
                Op::Variable(k) => values[k],
                Op::Negate => -stack.pop().unwrap_or(f64::NAN),
                Op::Call(f) => f(stack.pop().unwrap_or(f64::NAN)),
                _ => {
                    let b = stack.pop().unwrap_or(f64::NAN);
                    let a = stack.pop().unwrap_or(f64::NAN);
                    match op {
                        Op::Add => a + b,
                        Op::Subtract => a - b,
                        Op::Multiply => a * b,
                        Op::Divide => a / b,
                        _ => a.powf(b),
                    }
                }
            };
            stack.push(value);
        }
        stack.pop().unwrap_or(f64::NAN)
    }
}

/// What stops a parse, at a 1-based character position.
enum Error {
    Syntax { column: usize, message: String },
    Unknown { column: usize, name: String },
}

/// A recursive-descent parser over the characters of one expression, writing the
/// postfix program as it goes.
struct Parser<'a> {
    chars: Vec<(usize, char)>,
    /// The index of the next character in `chars`.
    at: usize,
    variables: &'a [&'a str],
    constants: &'a BTreeMap<String, f64>,
    program: Vec<Op>,
    /// The current nesting of parentheses and signs.
    depth: usize,
}

impl Parser<'_> {
    fn whole(&mut self) -> Result<Vec<Op>, Error> {
        self.sum()?;
        match self.peek() {
            None => Ok(std::mem::take(&mut self.program)),
            Some(c) => Err(self.syntax(format!("`{c}` after a complete expression"))),
        }
    }

    /// The next character that is not white space, not consumed.
    fn peek(&mut self) -> Option<char> {
        while self.chars.get(self.at).is_some_and(|c| c.1.is_whitespace()) {
            self.at += 1;
        }
        self.chars.get(self.at).map(|c| c.1)
    }

    /// Consumes the next character if it is `c`.
    fn eat(&mut self, c: char) -> bool {
        let found = self.peek() == Some(c);
        self.at += usize::from(found);
        found
    }

    fn syntax(&self, message: String) -> Error {
        Error::Syntax {
            column: self.at + 1,
            message,
        }
    }

    /// Enters one more level of nesting, refusing past [`MAX_DEPTH`].
    fn nest(&mut self) -> Result<(), Error> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.syntax(format!(
                "parentheses and signs nest more than {MAX_DEPTH} deep"
            )));
        }
        Ok(())
    }

    /// A left-associative chain `operand (op operand)…` of the operators `ops`.
    fn chain(
        &mut self,
        ops: &[(char, Op)],
        operand: fn(&mut Self) -> Result<(), Error>,
    ) -> Result<(), Error> {
        operand(self)?;
        while let Some(&(_, op)) = ops.iter().find(|(c, _)| self.peek() == Some(*c)) {
            self.at += 1;
            operand(self)?;
            self.program.push(op);
        }
        Ok(())
    }

    fn sum(&mut self) -> Result<(), Error> {
        self.chain(&[('+', Op::Add), ('-', Op::Subtract)], Self::product)
    }

    fn product(&mut self) -> Result<(), Error> {
        self.chain(&[('*', Op::Multiply), ('/', Op::Divide)], Self::signed)
    }

    fn signed(&mut self) -> Result<(), Error> {
        let negate = match self.peek() {
            Some('-') => true,
            Some('+') => false,
            _ => return self.power(),
        };
        self.at += 1;
        self.nest()?;
        self.signed()?;
        self.depth -= 1;
        if negate {
            self.program.push(Op::Negate);
        }
        Ok(())
    }

    fn power(&mut self) -> Result<(), Error> {
        self.atom()?;
        if self.eat('^') {
            self.signed()?;
            self.program.push(Op::Power);
        }
        Ok(())
    }

    fn atom(&mut self) -> Result<(), Error> {
        match self.peek() {
            Some('(') => {
                self.at += 1;
                self.nest()?;
                self.sum()?;
                self.depth -= 1;
                if self.eat(')') {
                    Ok(())
                } else {
                    Err(self.syntax("a `(` is not closed".to_string()))
                }
            }
            Some(c) if c.is_ascii_digit() || c == '.' => self.number(),
            Some(c) if c.is_alphabetic() || c == '_' => self.name(),
            Some(c) => Err(self.syntax(format!("`{c}` where a value is expected"))),
            None => Err(self.syntax("the expression ends where a value is expected".into())),
        }
    }

    /// A decimal literal: digits with an optional point and exponent.
    fn number(&mut self) -> Result<(), Error> {
        let start = self.at;
        let digits = |p: &mut Self| {
            while p.chars.get(p.at).is_some_and(|c| c.1.is_ascii_digit()) {
                p.at += 1;
            }
        };
        digits(self);
        if self.chars.get(self.at).is_some_and(|c| c.1 == '.') {
            self.at += 1;
            digits(self);
        }
        if self
            .chars
            .get(self.at)
            .is_some_and(|c| matches!(c.1, 'e' | 'E'))
        {
            let mantissa = self.at;
            self.at += 1;
            if self
                .chars
                .get(self.at)
                .is_some_and(|c| matches!(c.1, '+' | '-'))
            {
                self.at += 1;
            }
            let exponent = self.at;
            digits(self);
            if self.at == exponent {
                // Not an exponent: `2e` or `2*e` style text is left to the caller.
                self.at = mantissa;
            }
        }
        let literal: String = self.chars[start..self.at].iter().map(|c| c.1).collect();
        match literal.parse::<f64>() {
            Ok(v) if v.is_finite() => {
                self.program.push(Op::Number(v));
                Ok(())
            }
            Ok(_) => Err(Error::Syntax {
                column: start + 1,
                message: format!("{literal} is beyond the range of f64"),
            }),
            Err(_) => Err(Error::Syntax {
                column: start + 1,
                message: format!("`{literal}` is not a number"),
            }),
        }
    }

    /// A variable, a constant, or a function applied to a parenthesised argument.
    fn name(&mut self) -> Result<(), Error> {
        let start = self.at;
        while self
            .chars
            .get(self.at)
            .is_some_and(|c| c.1.is_alphanumeric() || c.1 == '_')
        {
            self.at += 1;
        }
        let name: String = self.chars[start..self.at].iter().map(|c| c.1).collect();
        if let Some(k) = self.variables.iter().position(|v| *v == name) {
            self.program.push(Op::Variable(k));
        } else if let Some(&c) = self.constants.get(&name) {
            self.program.push(Op::Number(c));
        } else if let Some(&(_, c)) = CONSTANTS.iter().find(|c| c.0 == name) {
            self.program.push(Op::Number(c));
        } else if let Some(&(_, f)) = FUNCTIONS.iter().find(|f| f.0 == name) {
            if self.peek() != Some('(') {
                return Err(self.syntax(format!("the function `{name}` wants `(`")));
            }
            self.atom()?;
            self.program.push(Op::Call(f));
        } else {
            return Err(Error::Unknown {
                column: start + 1,
                name,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(text: &str) -> f64 {
        Expression::parse(text, &[], "", &BTreeMap::new())
            .unwrap()
            .at(&[])
    }

    fn error(text: &str) -> String {
        Expression::parse(text, &COORDINATES[..2], "", &BTreeMap::new()).unwrap_err()
    }

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
        assert!(e.contains("does not parse at character 5"), "{e}");
    }

    /// Every decimal form `f64::from_str` reads is a number, to the same bits.
    #[test]
    fn scientific_and_bare_decimal_literals_are_numbers() {
        for literal in ["1e-3", "2.5E+6", ".5", "5.", "3", "1.25e2", "7E0", "0.1"] {
            let exact: f64 = literal.parse().unwrap();
            assert_eq!(value(literal).to_bits(), exact.to_bits(), "{literal}");
        }
        assert_eq!(value("2*1e-3"), 2.0 * 1e-3);
        assert_eq!(value("-1e-3^2"), -(1e-3f64.powf(2.0)));
    }

    #[test]
    fn nan_infinity_and_overflow_are_refused() {
        for (text, column) in [("nan", 1), ("2*inf", 3), ("NaN + x", 1)] {
            assert!(
                error(text).contains(&format!("at character {column}")),
                "{text}"
            );
        }
        let e = error("x + 1e999");
        assert!(
            e.contains("at character 5: 1e999 is beyond the range of f64"),
            "{e}"
        );
    }

    #[test]
    fn precedence_and_associativity_are_the_usual_ones() {
        assert_eq!(value("-2^2"), -4.0);
        assert_eq!(value("2^3^2"), 512.0);
        assert_eq!(value("2^-1"), 0.5);
        assert_eq!(value("8/4/2"), 1.0);
        assert_eq!(value("1 - 2 - 3"), -4.0);
        assert_eq!(value("2 + 3*4"), 14.0);
        assert_eq!(value("-(3 - 5)*2"), 4.0);
        assert_eq!(value("sqrt(16) + abs(-2) + signum(-3)"), 5.0);
        assert_eq!(value("cos(0) + exp(0) + ln(E)"), 3.0);
        assert_eq!(value("TAU - 2*PI"), 0.0);
    }

    #[test]
    fn syntax_errors_point_at_the_column() {
        for (text, column) in [
            ("2*", 3),
            ("x + * y", 5),
            ("(x + y", 7),
            ("x y", 3),
            ("sin x", 5),
            ("x + 3)", 6),
            ("#", 1),
        ] {
            let e = error(text);
            assert!(
                e.contains(&format!("does not parse at character {column}:")),
                "{text}: {e}"
            );
        }
    }

    /// The length cap and the nesting cap are errors, and the time is linear: an
    /// expression of the greatest length parses and evaluates to the exact sum.
    #[test]
    fn long_and_deep_expressions_are_bounded() {
        let e = error(&"1+".repeat(MAX_LENGTH));
        assert!(e.contains(&format!("at most {MAX_LENGTH}")), "{e}");
        let ones = vec!["1"; MAX_LENGTH / 2].join("+");
        assert_eq!(value(&ones), (MAX_LENGTH / 2) as f64);
        let deep = format!("{}1{}", "(".repeat(100), ")".repeat(100));
        assert!(error(&deep).contains(&format!("nest more than {MAX_DEPTH} deep")));
        let signs = format!("{}1", "-".repeat(100));
        assert!(error(&signs).contains("nest more than"));
    }
}
