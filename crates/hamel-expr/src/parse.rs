//! The expression parser (recursive descent over the grammar in docs/model-format.md).

use std::ops::Range;

use num_bigint::BigInt;

use crate::ast::{Expr, Func, Rational};

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

/// Parse one expression.
pub fn parse(text: &str) -> Result<Parsed, ParseError> {
    let tokens = lex(text)?;
    let mut p = Parser {
        text,
        tokens,
        pos: 0,
        occurrences: Vec::new(),
    };
    let expr = p.expr()?;
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
            let value = parse_number(lit).ok_or_else(|| ParseError {
                span: start..i,
                message: format!("malformed number `{lit}`"),
            })?;
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

    fn expr(&mut self) -> Result<Expr, ParseError> {
        let mut terms = vec![self.term()?];
        loop {
            if self.peek_op('+') {
                self.pos += 1;
                terms.push(self.term()?);
            } else if self.peek_op('-') {
                self.pos += 1;
                terms.push(Expr::Neg(Box::new(self.term()?)));
            } else {
                break;
            }
        }
        Ok(if terms.len() == 1 {
            terms.pop().unwrap()
        } else {
            Expr::Add(terms)
        })
    }

    fn term(&mut self) -> Result<Expr, ParseError> {
        let mut acc = self.unary()?;
        loop {
            if self.peek_op('*') {
                self.pos += 1;
                let rhs = self.unary()?;
                acc = match acc {
                    Expr::Mul(mut v) => {
                        v.push(rhs);
                        Expr::Mul(v)
                    }
                    a => Expr::Mul(vec![a, rhs]),
                };
            } else if self.peek_op('/') {
                self.pos += 1;
                let rhs = self.unary()?;
                acc = Expr::Div(Box::new(acc), Box::new(rhs));
            } else {
                break;
            }
        }
        Ok(acc)
    }

    fn unary(&mut self) -> Result<Expr, ParseError> {
        if self.peek_op('-') {
            self.pos += 1;
            return Ok(Expr::Neg(Box::new(self.unary()?)));
        }
        if self.peek_op('+') {
            self.pos += 1;
            return self.unary();
        }
        self.power()
    }

    fn power(&mut self) -> Result<Expr, ParseError> {
        let base = self.atom()?;
        if self.peek_op('^') {
            self.pos += 1;
            let exponent = self.unary()?;
            return Ok(Expr::Pow(Box::new(base), Box::new(exponent)));
        }
        Ok(base)
    }

    fn atom(&mut self) -> Result<Expr, ParseError> {
        let Some(tok) = self.peek().cloned() else {
            return Err(ParseError {
                span: self.end_span(),
                message: "expected a number, a name or `(`, found the end of the expression"
                    .to_string(),
            });
        };
        self.pos += 1;
        match tok.tok {
            Tok::Num(r) => Ok(Expr::Num(r)),
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
                    return Ok(Expr::Sym(name));
                }
                self.pos += 1; // '('
                let mut args = vec![self.expr()?];
                while self.peek_op(',') {
                    self.pos += 1;
                    args.push(self.expr()?);
                }
                let close = self.expect_op(')', &format!("to close the call of `{name}`"))?;
                let whole = tok.span.start..close.end;
                self.call(name, args, tok.span.clone(), whole)
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
                            "`{name}` is not a built-in function (sin cos tan sqrt exp log der); \
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
        let e = parse("sin(x, y)").unwrap_err();
        assert!(e.message.contains("one argument"));
        let e = parse("(a + b").unwrap_err();
        assert!(e.message.contains("to close `(`"));
        let e = parse("a b").unwrap_err();
        assert_eq!(e.span, 2..3);
    }
}
