//! OpenSCENARIO 1.1+ parameter expressions, `${…}`: numbers, `$param`,
//! `true`/`false`, `+ - * / %`, unary `-`, the functions `round floor ceil
//! sqrt sin cos tan asin acos atan sign abs max min pow`, and `not and or`.
//!
//! Computed in `f64` (booleans as 0/1), as the standard says; division by
//! zero, the square root of a negative number and a result that is not a
//! finite number are errors, never a NaN passed on into a scenario.

use litesim_core::math;

/// A parameter's value as an expression reads it.
pub type Lookup<'a> = dyn Fn(&str) -> Result<f64, String> + 'a;

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(f64),
    Param(String),
    Ident(String),
    Op(char),
}

fn lex(s: &str) -> Result<Vec<Tok>, String> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i] as char;
        match c {
            ' ' | '\t' | '\n' | '\r' => i += 1,
            '0'..='9' | '.' => {
                let start = i;
                while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
                    i += 1;
                }
                // An exponent: 2e3, 1.5E-2.
                if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
                    let save = i;
                    i += 1;
                    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
                        i += 1;
                    }
                    if i < b.len() && b[i].is_ascii_digit() {
                        while i < b.len() && b[i].is_ascii_digit() {
                            i += 1;
                        }
                    } else {
                        i = save;
                    }
                }
                let text = &s[start..i];
                out.push(Tok::Num(
                    text.parse()
                        .map_err(|_| format!("'{text}' is not a number"))?,
                ));
            }
            '$' => {
                let start = i + 1;
                i += 1;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
                if i == start {
                    return Err("'$' without a parameter name".into());
                }
                out.push(Tok::Param(s[start..i].to_string()));
            }
            'a'..='z' | 'A'..='Z' | '_' => {
                let start = i;
                while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                    i += 1;
                }
                out.push(Tok::Ident(s[start..i].to_string()));
            }
            '+' | '-' | '*' | '/' | '%' | '(' | ')' | ',' => {
                out.push(Tok::Op(c));
                i += 1;
            }
            other => {
                return Err(format!(
                    "'{other}' is not allowed in an expression (numbers, $parameters, + - * / %, parentheses, functions, not/and/or)"
                ));
            }
        }
    }
    Ok(out)
}

struct Parser<'a, 'l> {
    toks: Vec<Tok>,
    i: usize,
    lookup: &'a Lookup<'l>,
    depth: usize,
}

/// Nesting beyond this is refused (a recursive descent must not overflow
/// the stack on a hostile file).
const MAX_DEPTH: usize = 64;

impl Parser<'_, '_> {
    fn peek(&self) -> Option<&Tok> {
        self.toks.get(self.i)
    }

    fn eat(&mut self, op: char) -> bool {
        if self.peek() == Some(&Tok::Op(op)) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    fn eat_word(&mut self, w: &str) -> bool {
        if matches!(self.peek(), Some(Tok::Ident(x)) if x == w) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    fn or(&mut self) -> Result<f64, String> {
        let mut v = self.and()?;
        while self.eat_word("or") {
            let r = self.and()?;
            v = f64::from(v != 0.0 || r != 0.0);
        }
        Ok(v)
    }

    fn and(&mut self) -> Result<f64, String> {
        let mut v = self.not()?;
        while self.eat_word("and") {
            let r = self.not()?;
            v = f64::from(v != 0.0 && r != 0.0);
        }
        Ok(v)
    }

    fn not(&mut self) -> Result<f64, String> {
        if self.eat_word("not") {
            let v = self.not()?;
            return Ok(f64::from(v == 0.0));
        }
        self.sum()
    }

    fn sum(&mut self) -> Result<f64, String> {
        let mut v = self.product()?;
        loop {
            if self.eat('+') {
                v += self.product()?;
            } else if self.eat('-') {
                v -= self.product()?;
            } else {
                return Ok(v);
            }
        }
    }

    fn product(&mut self) -> Result<f64, String> {
        let mut v = self.unary()?;
        loop {
            if self.eat('*') {
                v *= self.unary()?;
            } else if self.eat('/') {
                let r = self.unary()?;
                if r == 0.0 {
                    return Err("division by zero".into());
                }
                v /= r;
            } else if self.eat('%') {
                let r = self.unary()?;
                if r == 0.0 {
                    return Err("remainder of a division by zero".into());
                }
                v %= r;
            } else {
                return Ok(v);
            }
        }
    }

    fn unary(&mut self) -> Result<f64, String> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(format!("nested deeper than {MAX_DEPTH} levels"));
        }
        let v = if self.eat('-') {
            -self.unary()?
        } else {
            self.atom()?
        };
        self.depth -= 1;
        Ok(v)
    }

    fn args(&mut self, name: &str, n: usize) -> Result<Vec<f64>, String> {
        if !self.eat('(') {
            return Err(format!("{name} takes {n} argument(s) in parentheses"));
        }
        let mut out = vec![self.or()?];
        while self.eat(',') {
            out.push(self.or()?);
        }
        if !self.eat(')') {
            return Err(format!("')' expected after {name}'s arguments"));
        }
        if out.len() != n {
            return Err(format!("{name} takes {n} argument(s), {} given", out.len()));
        }
        Ok(out)
    }

    fn atom(&mut self) -> Result<f64, String> {
        let Some(t) = self.peek().cloned() else {
            return Err("the expression ends where a value was expected".into());
        };
        self.i += 1;
        match t {
            Tok::Num(v) => Ok(v),
            Tok::Param(p) => (self.lookup)(&p),
            Tok::Op('(') => {
                let v = self.or()?;
                if !self.eat(')') {
                    return Err("')' expected".into());
                }
                Ok(v)
            }
            Tok::Op(c) => Err(format!("'{c}' where a value was expected")),
            Tok::Ident(w) => match w.as_str() {
                "true" => Ok(1.0),
                "false" => Ok(0.0),
                "round" | "floor" | "ceil" | "sqrt" | "sin" | "cos" | "tan" | "asin" | "acos"
                | "atan" | "sign" | "abs" => {
                    let x = self.args(&w, 1)?[0];
                    Ok(match w.as_str() {
                        "round" => x.round(),
                        "floor" => x.floor(),
                        "ceil" => x.ceil(),
                        "sqrt" if x < 0.0 => {
                            return Err(format!("sqrt of a negative number ({x})"));
                        }
                        "sqrt" => x.sqrt(),
                        "sin" => math::sin(x),
                        "cos" => math::cos(x),
                        "tan" => math::tan(x),
                        "asin" | "acos" if !(-1.0..=1.0).contains(&x) => {
                            return Err(format!("{w} of {x}, outside [-1, 1]"));
                        }
                        "asin" => math::asin(x),
                        "acos" => math::acos(x),
                        "atan" => math::atan(x),
                        "sign" => {
                            if x > 0.0 {
                                1.0
                            } else if x < 0.0 {
                                -1.0
                            } else {
                                0.0
                            }
                        }
                        _ => x.abs(),
                    })
                }
                "max" | "min" | "pow" => {
                    let a = self.args(&w, 2)?;
                    Ok(match w.as_str() {
                        "max" => a[0].max(a[1]),
                        "min" => a[0].min(a[1]),
                        _ => math::pow(a[0], a[1]),
                    })
                }
                other => Err(format!(
                    "unknown name '{other}' (a parameter is written $name; functions: round floor ceil sqrt sin cos tan asin acos atan sign abs max min pow)"
                )),
            },
        }
    }
}

/// Evaluates the text inside `${…}`, reading parameters through `lookup`.
pub fn eval(text: &str, lookup: &Lookup<'_>) -> Result<f64, String> {
    let toks = lex(text)?;
    if toks.is_empty() {
        return Err("an empty expression".into());
    }
    let mut p = Parser {
        toks,
        i: 0,
        lookup,
        depth: 0,
    };
    let v = p.or()?;
    if p.i != p.toks.len() {
        return Err(format!(
            "unexpected {:?} after a complete expression",
            p.toks[p.i]
        ));
    }
    if !v.is_finite() {
        return Err(format!("the result is not a finite number ({v})"));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(s: &str) -> Result<f64, String> {
        eval(s, &|p: &str| match p {
            "speed" => Ok(20.0),
            "zero" => Ok(0.0),
            _ => Err(format!("unknown parameter ${p}")),
        })
    }

    #[test]
    fn precedence_functions_and_parameters() {
        assert_eq!(ev("1 + 2 * 3").unwrap(), 7.0);
        assert_eq!(ev("(1 + 2) * 3").unwrap(), 9.0);
        assert_eq!(ev("-$speed / 4").unwrap(), -5.0);
        assert_eq!(ev("max($speed, 30) - min(1, 2)").unwrap(), 29.0);
        assert_eq!(ev("pow(2, 10)").unwrap(), 1024.0);
        assert_eq!(ev("2e3 + 1.5E-1").unwrap(), 2000.15);
        assert_eq!(ev("round(2.5) + floor(-0.5) + ceil(0.2)").unwrap(), 3.0);
        assert_eq!(ev("7 % 3").unwrap(), 1.0);
        assert_eq!(ev("not true or false and true").unwrap(), 0.0);
        assert_eq!(ev("sqrt(16) * sign(-3) + abs(-1)").unwrap(), -3.0);
    }

    #[test]
    fn bad_expressions_are_errors_saying_what() {
        assert!(ev("1 / $zero").unwrap_err().contains("division by zero"));
        assert!(ev("5 % 0").unwrap_err().contains("division by zero"));
        assert!(ev("sqrt(-1)").unwrap_err().contains("negative"));
        assert!(ev("$nope").unwrap_err().contains("unknown parameter $nope"));
        assert!(ev("1 +").unwrap_err().contains("ends where a value"));
        assert!(ev("1 2").unwrap_err().contains("unexpected"));
        assert!(ev("foo(1)").unwrap_err().contains("unknown name 'foo'"));
        assert!(ev("max(1)").unwrap_err().contains("takes 2"));
        assert!(ev("1 < 2").unwrap_err().contains("not allowed"));
        assert!(ev("pow(10, 400)").unwrap_err().contains("finite"));
        let deep = format!("{}1{}", "(".repeat(10_000), ")".repeat(10_000));
        assert!(ev(&deep).unwrap_err().contains("nested deeper"));
        let neg = format!("{}1", "-".repeat(10_000));
        assert!(ev(&neg).unwrap_err().contains("nested deeper"));
    }
}
