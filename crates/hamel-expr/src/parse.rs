//! The expression parser (recursive descent over the grammar in docs/model-format.md).

use std::ops::Range;

use num_bigint::BigInt;

use crate::ast::{Expr, Func, Rational};
use crate::limits::{MAX_BYTES, MAX_DEPTH, MAX_DIGITS, MAX_EXPONENT, MAX_NESTING};

/// An expression and the depth of its tree (a leaf has depth 1).
type Node = (Expr, usize);

/// A parse failure: the byte range of the offending text and the reason.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ParseError {
    /// Byte range in the parsed text.
    pub span: Range<usize>,
    /// What is wrong, in a sentence.
    pub message: String,
}

impl std::fmt::Display for ParseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} (at byte {})", self.message, self.span.start)
    }
}

impl std::error::Error for ParseError {}

/// How a name occurs in the text.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OccurrenceKind {
    /// A plain name: coordinate or parameter.
    Symbol,
    /// `der(q)`: the name is `q`.
    Velocity,
    /// A call of a function that is not built in, with these argument names.
    FreeFunction(Vec<String>),
}

/// A name found in the text, with its byte span, for name resolution and error messages.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Occurrence {
    /// The name.
    pub name: String,
    /// What kind of use it is.
    pub kind: OccurrenceKind,
    /// Byte range of the name (or of the whole call) in the text.
    pub span: Range<usize>,
}

/// The result of parsing: the tree and every name that occurs in it.
#[derive(Clone, Debug, PartialEq)]
pub struct Parsed {
    /// The expression.
    pub expr: Expr,
    /// Every name, in order of appearance.
    pub occurrences: Vec<Occurrence>,
}

/// Parse one expression, within the limits of [`crate::limits`] (text size, tree depth,
/// exponents, digits): beyond them, an error saying which, never an exhausted machine.
pub fn parse(text: &str) -> Result<Parsed, ParseError> {
    if text.len() > MAX_BYTES {
        return Err(ParseError {
            span: 0..0,
            message: format!(
                "the expression is {} bytes long; hamel reads at most {MAX_BYTES} bytes per expression",
                text.len()
            ),
        });
    }
    let tokens = lex(text)?;
    let mut p = Parser {
        text,
        tokens,
        pos: 0,
        occurrences: Vec::new(),
        nesting: 0,
    };
    let (expr, _) = p.expr()?;
    if let Some(t) = p.peek() {
        return Err(ParseError {
            span: t.span.clone(),
            message: format!(
                "unexpected {} after the end of the expression",
                t.describe()
            ),
        });
    }
    Ok(Parsed {
        expr,
        occurrences: p.occurrences,
    })
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(Rational),
    Name(String),
    Op(char),
}

#[derive(Clone, Debug)]
struct Token {
    tok: Tok,
    span: Range<usize>,
}

impl Token {
    fn describe(&self) -> String {
        match &self.tok {
            Tok::Num(_) => "number".to_string(),
            Tok::Name(n) => format!("name `{n}`"),
            Tok::Op(c) => format!("`{c}`"),
        }
    }
}

fn lex(text: &str) -> Result<Vec<Token>, ParseError> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i] as char;
        if c.is_ascii_whitespace() {
            i += 1;
        } else if c.is_ascii_digit()
            || (c == '.' && i + 1 < bytes.len() && bytes[i + 1].is_ascii_digit())
        {
            let start = i;
            while i < bytes.len() && bytes[i].is_ascii_digit() {
                i += 1;
            }
            if i < bytes.len() && bytes[i] == b'.' {
                i += 1;
                while i < bytes.len() && bytes[i].is_ascii_digit() {
                    i += 1;
                }
            }
            if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
                let save = i;
                i += 1;
                if i < bytes.len() && (bytes[i] == b'+' || bytes[i] == b'-') {
                    i += 1;
                }
                if i < bytes.len() && bytes[i].is_ascii_digit() {
                    while i < bytes.len() && bytes[i].is_ascii_digit() {
                        i += 1;
                    }
                } else {
                    i = save; // not an exponent: `2e` would be a number then a name
                }
            }
            let lit = &text[start..i];
            let digits = lit.bytes().take_while(|b| *b != b'e' && *b != b'E');
            if digits.filter(u8::is_ascii_digit).count() > MAX_DIGITS {
                return Err(ParseError {
                    span: start..i,
                    message: format!("the number has more than {MAX_DIGITS} digits"),
                });
            }
            let value = parse_number(lit).ok_or_else(|| ParseError {
                span: start..i,
                message: format!("malformed number `{lit}`"),
            })?;
            if too_long(&value) {
                return Err(ParseError {
                    span: start..i,
                    message: format!(
                        "the number `{lit}` has more than {MAX_DIGITS} digits when written out (its numerator or denominator)"
                    ),
                });
            }
            out.push(Token {
                tok: Tok::Num(value),
                span: start..i,
            });
        } else if c.is_ascii_alphabetic() || c == '_' {
            let start = i;
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            out.push(Token {
                tok: Tok::Name(text[start..i].to_string()),
                span: start..i,
            });
        } else if "+-*/^(),".contains(c) {
            out.push(Token {
                tok: Tok::Op(c),
                span: i..i + 1,
            });
            i += 1;
        } else {
            let ch = text[i..].chars().next().unwrap_or('?');
            return Err(ParseError {
                span: i..i + ch.len_utf8(),
                message: format!("unexpected character `{ch}`"),
            });
        }
    }
    Ok(out)
}

/// Whether the numerator or the denominator of `r` has more than [`MAX_DIGITS`] digits, so
/// that its printed form could not be read back.
fn too_long(r: &Rational) -> bool {
    let limit = num_traits::pow(BigInt::from(10), MAX_DIGITS);
    r.numer().magnitude() >= limit.magnitude() || r.denom().magnitude() >= limit.magnitude()
}

/// Parse a decimal literal exactly: `12`, `0.5`, `1e-3`, `2.5E+2`.
fn parse_number(lit: &str) -> Option<Rational> {
    let (mantissa, exponent) = match lit.find(['e', 'E']) {
        Some(k) => (&lit[..k], lit[k + 1..].parse::<i64>().ok()?),
        None => (lit, 0),
    };
    let (int_part, frac_part) = match mantissa.find('.') {
        Some(k) => (&mantissa[..k], &mantissa[k + 1..]),
        None => (mantissa, ""),
    };
    let digits = format!("{int_part}{frac_part}");
    let digits = if digits.is_empty() { "0" } else { &digits };
    let n: BigInt = digits.parse().ok()?;
    let scale = exponent - frac_part.len() as i64;
    if scale.abs() > 4000 {
        return None;
    }
    let ten = BigInt::from(10);
    let value = if scale >= 0 {
        Rational::from_integer(n * num_traits::pow(ten, scale as usize))
    } else {
        Rational::new(n, num_traits::pow(ten, (-scale) as usize))
    };
    Some(value)
}

struct Parser<'a> {
    text: &'a str,
    tokens: Vec<Token>,
    pos: usize,
    occurrences: Vec<Occurrence>,
    /// How deep the descent is (operands within operands), bounded by [`MAX_NESTING`].
    nesting: usize,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.pos)
    }

    fn peek_op(&self, c: char) -> bool {
        matches!(self.peek(), Some(Token { tok: Tok::Op(o), .. }) if *o == c)
    }

    fn end_span(&self) -> Range<usize> {
        self.text.len()..self.text.len()
    }

    /// The span of the current token (or the end).
    fn here(&self) -> Range<usize> {
        self.peek()
            .map_or_else(|| self.end_span(), |t| t.span.clone())
    }

    /// `node` if its tree is at most [`MAX_DEPTH`] deep.
    fn shallow(&self, node: Node, at: Range<usize>) -> Result<Node, ParseError> {
        if node.1 > MAX_DEPTH {
            return Err(ParseError {
                span: at,
                message: format!("the expression nests more than {MAX_DEPTH} levels deep"),
            });
        }
        Ok(node)
    }

    fn expect_op(&mut self, c: char, context: &str) -> Result<Range<usize>, ParseError> {
        match self.peek() {
            Some(Token {
                tok: Tok::Op(o),
                span,
            }) if *o == c => {
                let s = span.clone();
                self.pos += 1;
                Ok(s)
            }
            Some(t) => Err(ParseError {
                span: t.span.clone(),
                message: format!("expected `{c}` {context}, found {}", t.describe()),
            }),
            None => Err(ParseError {
                span: self.end_span(),
                message: format!("expected `{c}` {context}, found the end of the expression"),
            }),
        }
    }

    fn expr(&mut self) -> Result<Node, ParseError> {
        let (first, mut depth) = self.term()?;
        let mut terms = vec![first];
        loop {
            let negate = self.peek_op('-');
            if !negate && !self.peek_op('+') {
                break;
            }
            self.pos += 1;
            let (t, d) = self.term()?;
            let (t, d) = if negate {
                (Expr::Neg(Box::new(t)), d + 1)
            } else {
                (t, d)
            };
            depth = depth.max(d);
            terms.push(t);
        }
        let node = if terms.len() == 1 {
            (terms.pop().unwrap(), depth)
        } else {
            (Expr::Add(terms), depth + 1)
        };
        self.shallow(node, self.here())
    }

    fn term(&mut self) -> Result<Node, ParseError> {
        let (mut acc, mut depth) = self.unary()?;
        loop {
            let divide = self.peek_op('/');
            if !divide && !self.peek_op('*') {
                break;
            }
            let at = self.here();
            self.pos += 1;
            let (rhs, d) = self.unary()?;
            (acc, depth) = match acc {
                Expr::Mul(mut v) if !divide => {
                    v.push(rhs);
                    (Expr::Mul(v), depth.max(d + 1))
                }
                a if divide => (Expr::Div(Box::new(a), Box::new(rhs)), depth.max(d) + 1),
                a => (Expr::Mul(vec![a, rhs]), depth.max(d) + 1),
            };
            (acc, depth) = self.shallow((acc, depth), at)?;
        }
        Ok((acc, depth))
    }

    /// Every operand passes here: the descent's depth is counted and bounded.
    fn unary(&mut self) -> Result<Node, ParseError> {
        self.nesting += 1;
        let node = if self.nesting > MAX_NESTING {
            Err(ParseError {
                span: self.here(),
                message: format!(
                    "the text nests more than {MAX_NESTING} levels deep (operands and parentheses)"
                ),
            })
        } else if self.peek_op('-') {
            self.pos += 1;
            self.unary().map(|(e, d)| (Expr::Neg(Box::new(e)), d + 1))
        } else if self.peek_op('+') {
            self.pos += 1;
            self.unary()
        } else {
            self.power()
        };
        self.nesting -= 1;
        node
    }

    fn power(&mut self) -> Result<Node, ParseError> {
        let (base, d) = self.atom()?;
        if !self.peek_op('^') {
            return Ok((base, d));
        }
        self.pos += 1;
        let start = self.here().start;
        let (exponent, e) = self.unary()?;
        let end = self.tokens[self.pos - 1].span.end;
        check_exponent(&exponent, start..end)?;
        let node = (Expr::Pow(Box::new(base), Box::new(exponent)), d.max(e) + 1);
        self.shallow(node, start..end)
    }

    fn atom(&mut self) -> Result<Node, ParseError> {
        let Some(tok) = self.peek().cloned() else {
            return Err(ParseError {
                span: self.end_span(),
                message: "expected a number, a name or `(`, found the end of the expression"
                    .to_string(),
            });
        };
        self.pos += 1;
        match tok.tok {
            Tok::Num(r) => Ok((Expr::Num(r), 1)),
            Tok::Op('(') => {
                let e = self.expr()?;
                self.expect_op(')', "to close `(`")?;
                Ok(e)
            }
            Tok::Op(_) => Err(ParseError {
                span: tok.span.clone(),
                message: format!("expected a number, a name or `(`, found {}", tok.describe()),
            }),
            Tok::Name(name) => {
                if !self.peek_op('(') {
                    self.occurrences.push(Occurrence {
                        name: name.clone(),
                        kind: OccurrenceKind::Symbol,
                        span: tok.span.clone(),
                    });
                    return Ok((Expr::Sym(name), 1));
                }
                self.pos += 1; // '('
                let (first, mut depth) = self.expr()?;
                let mut args = vec![first];
                while self.peek_op(',') {
                    self.pos += 1;
                    let (a, d) = self.expr()?;
                    depth = depth.max(d);
                    args.push(a);
                }
                let close = self.expect_op(')', &format!("to close the call of `{name}`"))?;
                let whole = tok.span.start..close.end;
                let call = self.call(name, args, tok.span.clone(), whole.clone())?;
                self.shallow((call, depth + 1), whole)
            }
        }
    }

    fn call(
        &mut self,
        name: String,
        mut args: Vec<Expr>,
        name_span: Range<usize>,
        whole: Range<usize>,
    ) -> Result<Expr, ParseError> {
        if name == "der" {
            let arg = match (args.len(), args.first()) {
                (1, Some(Expr::Sym(q))) => q.clone(),
                (1, Some(Expr::Der(q))) => {
                    return Err(ParseError {
                        span: whole,
                        message: format!(
                            "`der(der({q}))` is an acceleration: expressions depend on the coordinates and their velocities der(q) only"
                        ),
                    });
                }
                _ => {
                    return Err(ParseError {
                        span: whole,
                        message: "`der` takes exactly one coordinate name, as in `der(theta)`"
                            .to_string(),
                    });
                }
            };
            // The coordinate inside der(...) was recorded as a plain symbol: re-tag it.
            if let Some(last) = self.occurrences.last_mut() {
                last.kind = OccurrenceKind::Velocity;
            }
            return Ok(Expr::Der(arg));
        }
        if name == "atan2" {
            let [y, x]: [Expr; 2] = args.try_into().map_err(|a: Vec<Expr>| ParseError {
                span: whole.clone(),
                message: format!(
                    "`atan2` takes two arguments, y and x (the angle of the point (x, y)), found {}",
                    a.len()
                ),
            })?;
            return Ok(Expr::atan2(y, x));
        }
        if let Some(f) = Func::from_name(&name) {
            if args.len() != 1 {
                return Err(ParseError {
                    span: whole,
                    message: format!("`{name}` takes one argument, found {}", args.len()),
                });
            }
            return Ok(Expr::Call(f, Box::new(args.pop().unwrap())));
        }
        // A free function: its arguments must be plain names (coordinates).
        let mut names = Vec::new();
        for a in &args {
            match a {
                Expr::Sym(s) => names.push(s.clone()),
                _ => {
                    return Err(ParseError {
                        span: whole,
                        message: format!(
                            "`{name}` is not a built-in function (sin cos tan sqrt exp log atan atan2 der); \
                             a free function takes coordinate names as arguments, as in `z13(phi)`"
                        ),
                    });
                }
            }
        }
        // Its argument names were recorded as symbols; keep them (they must be coordinates),
        // and record the call itself.
        self.occurrences.push(Occurrence {
            name: name.clone(),
            kind: OccurrenceKind::FreeFunction(names.clone()),
            span: name_span,
        });
        let n = names.len();
        Ok(Expr::Free {
            name,
            args: names,
            orders: vec![0; n],
        })
    }
}

/// An exponent that is a constant must be at most [`MAX_EXPONENT`] in size (numerator and
/// denominator): `x^1000000000` is refused here, before any engine expands it.
fn check_exponent(e: &Expr, span: Range<usize>) -> Result<(), ParseError> {
    let folded = e.specialise(&std::collections::HashMap::new());
    let Expr::Num(r) = folded else {
        return Ok(());
    };
    let big = |x: &BigInt| x.magnitude() > &num_bigint::BigUint::from(MAX_EXPONENT);
    if big(r.numer()) || big(r.denom()) {
        return Err(ParseError {
            span,
            message: format!(
                "the exponent {r} is too large: hamel takes exponents of at most {MAX_EXPONENT} in size"
            ),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(s: &str) -> Expr {
        parse(s).unwrap().expr
    }

    #[test]
    fn numbers_are_exact() {
        assert_eq!(p("0.5"), Expr::Num(Rational::new(1.into(), 2.into())));
        assert_eq!(p("1e-3"), Expr::Num(Rational::new(1.into(), 1000.into())));
        assert_eq!(p("2.5E+2"), Expr::int(250));
        assert_eq!(p(".25"), Expr::Num(Rational::new(1.into(), 4.into())));
    }

    #[test]
    fn precedence_and_associativity() {
        // a - b*c^2 = a + (-(b * c^2))
        let e = p("a - b*c^2");
        let expected = Expr::Add(vec![
            Expr::sym("a"),
            Expr::Neg(Box::new(Expr::Mul(vec![
                Expr::sym("b"),
                Expr::powi(Expr::sym("c"), 2),
            ]))),
        ]);
        assert_eq!(e, expected);
        // -x^2 is -(x^2); 2^3^2 is 2^(3^2)
        assert_eq!(
            p("-x^2"),
            Expr::Neg(Box::new(Expr::powi(Expr::sym("x"), 2)))
        );
        assert_eq!(
            p("2^3^2"),
            Expr::Pow(
                Box::new(Expr::int(2)),
                Box::new(Expr::powi(Expr::int(3), 2))
            )
        );
    }

    #[test]
    fn der_and_free_functions_are_recorded() {
        let parsed = parse("z13(phi)*der(theta) + sin(phi)").unwrap();
        let kinds: Vec<_> = parsed
            .occurrences
            .iter()
            .map(|o| (o.name.as_str(), o.kind.clone()))
            .collect();
        assert_eq!(
            kinds,
            vec![
                ("phi", OccurrenceKind::Symbol),
                ("z13", OccurrenceKind::FreeFunction(vec!["phi".into()])),
                ("theta", OccurrenceKind::Velocity),
                ("phi", OccurrenceKind::Symbol),
            ]
        );
    }

    #[test]
    fn errors_point_at_the_problem() {
        let e = parse("m*(x + ").unwrap_err();
        assert_eq!(e.span, 7..7);
        assert!(e.message.contains("end of the expression"), "{}", e.message);
        let e = parse("m # 2").unwrap_err();
        assert_eq!(e.span, 2..3);
        assert!(e.message.contains("unexpected character `#`"));
        let e = parse("der(2*x)").unwrap_err();
        assert!(e.message.contains("der"));
        let e = parse("-c*der(der(x))").unwrap_err();
        assert!(e.message.contains("acceleration"), "{}", e.message);
        let e = parse("sin(x, y)").unwrap_err();
        assert!(e.message.contains("one argument"));
        let e = parse("(a + b").unwrap_err();
        assert!(e.message.contains("to close `(`"));
        let e = parse("a b").unwrap_err();
        assert_eq!(e.span, 2..3);
    }

    #[test]
    fn limits_are_errors_not_exhaustion() {
        // A megabyte of text.
        let big = "x+".repeat(512 * 1024) + "x";
        let e = parse(&big).unwrap_err();
        assert!(e.message.contains("at most 262144 bytes"), "{}", e.message);
        // Just under the size limit: parsed (a flat sum is shallow).
        let ok = "x+".repeat(100_000) + "x";
        assert!(parse(&ok).is_ok());
        // Nesting: parentheses, unary minus, powers, calls, chains of divisions.
        for deep in [
            "(".repeat(10_000) + "x" + &")".repeat(10_000),
            "-".repeat(10_000) + "x",
            "x^".repeat(10_000) + "2",
            "sin(".repeat(10_000) + "x" + &")".repeat(10_000),
            "1".to_string() + &"/x".repeat(10_000),
        ] {
            let e = parse(&deep).unwrap_err();
            assert!(
                e.message.contains("more than 100 levels")
                    || e.message.contains("more than 400 levels"),
                "{}",
                e.message
            );
        }
        assert!(parse(&("(".repeat(300) + "x" + &")".repeat(300))).is_ok());
        assert!(parse(&("1".to_string() + &"/x".repeat(98))).is_ok());
        let e = parse(&("-".repeat(150) + "x")).unwrap_err();
        assert!(e.message.contains("more than 100 levels"), "{}", e.message);
        // What is printed of a tree within the depth limit reads back, though printing
        // parenthesises negative exponents (found by the `expression` fuzz target: 99 levels
        // of tree, 147 of text once printed).
        let chain = "x^-".repeat(49) + "x";
        let parsed = parse(&chain).unwrap().expr;
        let printed = parsed.to_string();
        assert!(printed.contains("^(-x^(-x"), "{printed}");
        assert_eq!(parse(&printed).unwrap().expr, parsed);
        // Exponents: literal, folded, nested.
        for (text, span) in [
            ("x^1000000000", 2..12),
            ("x^(2*500)", 2..9),
            ("x^2^2^2^2", 2..9),
            ("x^(1/1000)", 2..10),
        ] {
            let e = parse(text).unwrap_err();
            assert!(
                e.message.contains("exponents of at most 100"),
                "{text}: {}",
                e.message
            );
            assert_eq!(e.span, span, "{text}");
        }
        assert!(parse("x^100 + x^-100 + x^(1/2) + x^y").is_ok());
        // Digits.
        let e = parse(&"1".repeat(101)).unwrap_err();
        assert!(e.message.contains("more than 100 digits"), "{}", e.message);
        assert!(parse(&("0.".to_string() + &"1".repeat(99))).is_ok());
        // Written out, 5555E555 has 559 digits: its printed form could not be read back
        // (found by the `expression` fuzz target).
        for text in ["5555E555", "1e100", "1e-100"] {
            let e = parse(text).unwrap_err();
            assert!(
                e.message.contains("when written out"),
                "{text}: {}",
                e.message
            );
        }
        assert!(parse("1e99 + 1e-99 + 6.674e-11").is_ok());
    }
}
