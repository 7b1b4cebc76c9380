//! Text from users and the environment, made safe for the place where it lands in generated
//! source.
//!
//! **Job**: hamel writes Rust source (and a Python function, and Cargo manifests) and then
//! compiles and runs it, so any text that reaches that source is code unless it is escaped for
//! its place. Every piece of free text the generators write (paths, the command line, names,
//! descriptions, printed expressions) goes through exactly one function of this module, chosen
//! by where it lands:
//!
//! | where | function | what it guarantees |
//! |---|---|---|
//! | Rust doc or line comment | [`doc_comment`], [`comment_text`] | one line per call, no line break, no control or bidirectional character |
//! | Rust string literal | [`rust_str`] | a `"…"` literal whose value is the text exactly |
//! | Rust identifier | [`rust_ident`] | an ASCII identifier, or an error |
//! | Cargo package name | [`package_name`] | ASCII letters, digits and `-` only |
//! | TOML value | [`toml_str`] | a TOML string whose value is the text exactly |
//! | Python comment | [`python_comment`] | one `#` line |
//! | Python string literal | [`python_str`] | a `"…"` literal whose value is the text exactly |
//!
//! **Invariant**: the output of every function is inert in its place, whatever the input:
//! newlines, carriage returns, `*/`, quotes, backslashes, raw-string delimiters, bidirectional
//! overrides (CVE-2021-42574), Unicode line separators, very long text. Comments are cut to
//! [`MAX_COMMENT`] characters (the cut is said). Tested with `syn` in `tests/hostile_text.rs`:
//! a crate generated with hostile text in every free-text slot parses to the same items as one
//! generated with plain text.

use crate::CodegenError;

/// At most this many characters of free text go into one comment; the rest is replaced by a
/// note of how many were left out.
pub const MAX_COMMENT: usize = 1000;

/// Whether `c` must not appear verbatim in generated source: control characters (C0, DEL, C1),
/// the Unicode line and paragraph separators, the byte-order mark, and the bidirectional
/// formatting characters that can make source read differently from how it compiles.
fn unsafe_char(c: char) -> bool {
    c.is_control()
        || matches!(
            c,
            '\u{2028}' | '\u{2029}' | '\u{feff}' | '\u{061c}' | '\u{200e}' | '\u{200f}'
        )
        || ('\u{202a}'..='\u{202e}').contains(&c)
        || ('\u{2066}'..='\u{2069}').contains(&c)
}

/// The text on one line: unsafe characters and backslashes written as Rust-style escapes
/// (`\n`, `\u{202e}`, `\\`), cut to [`MAX_COMMENT`] characters.
pub fn comment_text(text: &str) -> String {
    let mut out = String::new();
    for (count, c) in text.chars().enumerate() {
        if count == MAX_COMMENT {
            let rest = text.chars().count() - count;
            out.push_str(&format!("… ({rest} more characters)"));
            break;
        }
        push_escaped(&mut out, c, rust_unicode);
    }
    out
}

/// `\u{…}`, Rust's escape of a character.
fn rust_unicode(c: char) -> String {
    format!("\\u{{{:x}}}", c as u32)
}

/// Push `c`, with backslash, newline, carriage return and tab as `\\`, `\n`, `\r`, `\t` and
/// every other unsafe character written by `unicode` (the escapes common to Rust and Python).
fn push_escaped(out: &mut String, c: char, unicode: impl Fn(char) -> String) {
    match c {
        '\\' => out.push_str("\\\\"),
        '\n' => out.push_str("\\n"),
        '\r' => out.push_str("\\r"),
        '\t' => out.push_str("\\t"),
        c if unsafe_char(c) => out.push_str(&unicode(c)),
        c => out.push(c),
    }
}

/// One line of a Rust comment: `marker` (`//!`, `///` or `//`), a space unless the text is
/// empty, [`comment_text`] of `text`, and a newline.
pub fn doc_comment(marker: &str, text: &str) -> String {
    if text.is_empty() {
        format!("{marker}\n")
    } else {
        format!("{marker} {}\n", comment_text(text))
    }
}

/// A Rust string literal whose value is `text`.
pub fn rust_str(text: &str) -> String {
    quoted(text, rust_unicode)
}

/// `text` in double quotes, `"` and what [`push_escaped`] escapes escaped.
fn quoted(text: &str, unicode: impl Fn(char) -> String + Copy) -> String {
    let mut out = String::from("\"");
    for c in text.chars() {
        if c == '"' {
            out.push_str("\\\"");
        } else {
            push_escaped(&mut out, c, unicode);
        }
    }
    out.push('"');
    out
}

/// `text` if it is an ASCII Rust identifier (letters, digits, `_`, not starting with a digit,
/// not a keyword hamel's code uses), else an error naming it.
pub fn rust_ident(text: &str) -> Result<&str, CodegenError> {
    const KEYWORDS: [&str; 12] = [
        "self", "Self", "super", "crate", "type", "fn", "let", "mut", "pub", "use", "mod", "_",
    ];
    let mut chars = text.chars();
    let ok = matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !KEYWORDS.contains(&text);
    if ok {
        Ok(text)
    } else {
        Err(CodegenError::NotAnIdentifier(text.to_string()))
    }
}

/// A Cargo package name made of the parts: ASCII letters and digits kept, every other
/// character becomes `-`, runs of `-` collapsed.
pub fn package_name(parts: &[&str]) -> String {
    let mut out = String::new();
    for c in parts.join("-").chars() {
        let c = if c.is_ascii_alphanumeric() { c } else { '-' };
        if !(c == '-' && out.ends_with('-')) {
            out.push(c);
        }
    }
    let out = out.trim_matches('-');
    if out.is_empty() {
        "hamel-generated".into()
    } else {
        out.to_ascii_lowercase()
    }
}

/// A TOML string (basic or literal, as `toml_edit` chooses) whose value is `text`.
pub fn toml_str(text: &str) -> String {
    toml_edit::Value::from(text).to_string().trim().to_string()
}

/// One line of a Python comment: `# ` and [`comment_text`] of `text`, and a newline.
pub fn python_comment(text: &str) -> String {
    doc_comment("#", text)
}

/// A Python string literal whose value is `text`.
pub fn python_str(text: &str) -> String {
    quoted(text, |c| format!("\\U{:08x}", c as u32))
}

#[cfg(test)]
mod tests {
    use super::*;

    const HOSTILE: &str =
        "a\nfn injected() {}\r\n*/ \"# r#\"x\"# \\ \u{202e}evil\u{2066} \u{2028}end\u{0}";

    #[test]
    fn comments_stay_on_one_line_without_unsafe_characters() {
        let line = doc_comment("//!", HOSTILE);
        assert_eq!(line.matches('\n').count(), 1);
        assert!(line.ends_with('\n'));
        assert!(!line.trim_end_matches('\n').chars().any(unsafe_char));
        assert!(line.contains("\\u{202e}") && line.contains("\\n"));
        let long = "x".repeat(10 * MAX_COMMENT);
        let cut = comment_text(&long);
        assert!(cut.contains(&format!("({} more characters)", 9 * MAX_COMMENT)));
        assert!(cut.chars().count() < MAX_COMMENT + 40);
        assert_eq!(doc_comment("///", ""), "///\n");
    }

    #[test]
    fn rust_and_python_strings_escape_what_would_end_them() {
        for s in [rust_str(HOSTILE), python_str(HOSTILE)] {
            assert!(s.starts_with('"') && s.ends_with('"'));
            let inner = &s[1..s.len() - 1];
            // Every quote inside is escaped, and no unsafe character is left verbatim.
            let bytes = inner.as_bytes();
            for (i, b) in bytes.iter().enumerate() {
                if *b == b'"' {
                    let slashes = bytes[..i].iter().rev().take_while(|&&c| c == b'\\').count();
                    assert_eq!(slashes % 2, 1, "unescaped quote in {s}");
                }
            }
            assert!(!inner.chars().any(unsafe_char), "{s}");
        }
        // Rust's own parser reads the literal back as the text.
        assert_eq!(rust_str("a\"b\\c\n"), "\"a\\\"b\\\\c\\n\"");
        assert!(python_str("\u{202e}").contains("\\U0000202e"));
    }

    #[test]
    fn identifiers_and_package_names() {
        assert_eq!(rust_ident("theta_1"), Ok("theta_1"));
        for bad in ["", "1x", "a b", "x\n", "θ", "self", "a-b"] {
            assert!(rust_ident(bad).is_err(), "{bad:?}");
        }
        assert_eq!(
            package_name(&["hamel", "model", "knife_edge", "paper"]),
            "hamel-model-knife-edge-paper"
        );
        assert_eq!(package_name(&["a\n\"]", "b"]), "a-b");
        assert_eq!(package_name(&["\n"]), "hamel-generated");
    }

    #[test]
    fn toml_values_read_back_as_the_text() {
        let doc: toml::Table = format!("v = {}\n", toml_str(HOSTILE)).parse().unwrap();
        assert_eq!(doc["v"].as_str(), Some(HOSTILE));
    }
}
