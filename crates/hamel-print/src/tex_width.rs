//! The printed width of LaTeX math, estimated from its text (what decides what fits a line
//! and which groups are named for their width). A leaf: it reads text only.

/// The printed width of LaTeX math, roughly: a control word is one glyph (`\sin`, `\cos` and
/// the like three; `\left`, `\right`, fractions' and fonts' commands none), braces, scripts'
/// markers and spaces nothing, subscripts and superscripts count.
pub fn width(tex: &str) -> usize {
    let mut n = 0;
    let mut chars = tex.char_indices();
    while let Some((i, c)) = chars.next() {
        match c {
            '\\' => {
                let rest = &tex[i + 1..];
                let len = rest
                    .bytes()
                    .position(|b| !b.is_ascii_alphabetic())
                    .unwrap_or(rest.len());
                let word = &rest[..len];
                let silent = ["left", "right", "tfrac", "frac", "mathrm", "dot", "quad"];
                let named = ["sin", "cos", "tan", "exp", "log", "sqrt"];
                if word.is_empty() {
                    chars.next();
                    n += 1;
                } else {
                    // The word is ASCII: skip its characters.
                    for _ in 0..len {
                        chars.next();
                    }
                    if named.contains(&word) {
                        n += 3;
                    } else if !silent.contains(&word) {
                        n += 1;
                    }
                }
            }
            '{' | '}' | '^' | '_' | ' ' | '&' => {}
            _ => n += 1,
        }
    }
    n
}
