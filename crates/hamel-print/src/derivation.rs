//! A derivation as a LaTeX document (`hamel derive --format latex`): A, α, Z, the kinematic
//! equations q̇ = Γη, A_Γ and the equations of motion, in one sheet with one where-list.

use std::fmt::Write;

use hamel_derive::{Derivation, Mat};
use hamel_expr::latex_name;

use crate::atoms::Vocabulary;
use crate::layout::{LINE, width};
use crate::poly::PolyError;
use crate::sheet::Sheet;

/// What `hamel derive --format latex` writes.
#[derive(Clone, Copy, Debug, Default)]
pub struct Options {
    /// The equation blocks alone, without the document around them.
    pub fragment: bool,
}

/// Why a derivation could not be printed.
#[derive(Debug, thiserror::Error)]
pub enum PrintError {
    /// An entry has no rational form over its atoms.
    #[error("{0}")]
    Poly(#[from] PolyError),
    /// A printed form is not its canonical form (a bug in printing; nothing is written).
    #[error("the printed form of {0} differs from its canonical form")]
    Mismatch(String),
}

/// The names a derivation's expressions are written in.
pub fn vocabulary(d: &Derivation) -> Vocabulary {
    Vocabulary {
        parameters: d.parameters.keys().cloned().collect(),
        coordinates: d.coordinates.clone(),
        velocities: (1..=d.sigma)
            .flat_map(|i| [format!("eta{i}"), format!("eta{i}_dot")])
            .collect(),
    }
}

/// The derivation as LaTeX: a complete document (landscape A4, 1 cm margins) or, with
/// `fragment`, its equation blocks alone.
///
/// # Errors
/// [`PrintError`]: an entry that cannot be printed exactly; nothing is returned then.
pub fn latex(d: &Derivation, options: Options) -> Result<String, PrintError> {
    let mut sheet = Sheet::new(&vocabulary(d));
    let blocks = blocks(d, &mut sheet)?;
    sheet.name_groups();
    for b in &blocks {
        for (label, id) in b.ids() {
            if !sheet.check(id) {
                return Err(PrintError::Mismatch(label));
            }
        }
    }
    if !sheet.check_arguments() {
        return Err(PrintError::Mismatch("a named argument".into()));
    }
    let mut body = String::new();
    let _ = writeln!(
        body,
        "% hamel derive: model {}, quasi-velocities {}",
        d.model, d.eta_name
    );
    for b in &blocks {
        b.write(&sheet, &mut body);
    }
    where_list(&sheet, &mut body);
    Ok(if options.fragment {
        body
    } else {
        document(d, &body)
    })
}

/// A block of the document: a matrix, or a list of equations `lhs = entry`.
enum Block {
    Matrix {
        symbol: String,
        rows: Vec<Vec<(String, usize)>>,
    },
    Equations {
        heading: String,
        rows: Vec<(String, usize)>,
        rhs_zero: bool,
    },
}

impl Block {
    /// Every entry with a label for messages.
    fn ids(&self) -> Vec<(String, usize)> {
        match self {
            Block::Matrix { rows, .. } => rows.iter().flatten().cloned().collect(),
            Block::Equations { rows, .. } => rows.clone(),
        }
    }

    fn write(&self, sheet: &Sheet, o: &mut String) {
        match self {
            Block::Matrix { symbol, rows } => matrix(sheet, symbol, rows, o),
            Block::Equations {
                heading,
                rows,
                rhs_zero,
            } => equations(sheet, heading, rows, *rhs_zero, o),
        }
    }
}

/// The entries of `d` added to `sheet`, in the document's order.
fn blocks(d: &Derivation, sheet: &mut Sheet) -> Result<Vec<Block>, PrintError> {
    let mut out = vec![
        mat_block(sheet, "A", &d.a)?,
        mat_block(sheet, "\\alpha", &d.alpha)?,
        mat_block(sheet, "Z", &d.z)?,
    ];
    let Some(c) = d.closed() else {
        return Ok(out);
    };
    let q: Vec<String> = d.coordinates.iter().map(|c| latex_name(c)).collect();
    let kinematics = c
        .kinematics
        .iter()
        .zip(&q)
        .map(|(e, q)| Ok((format!("\\dot{{{q}}}"), sheet.add(&e.expr)?)))
        .collect::<Result<_, PrintError>>()?;
    out.push(Block::Equations {
        heading: "kinematic equations (6), $\\dot q = \\Gamma\\eta$".into(),
        rows: kinematics,
        rhs_zero: false,
    });
    out.push(mat_block(sheet, "A_\\Gamma", &c.a_gamma)?);
    let equations = c
        .equations
        .iter()
        .enumerate()
        .map(|(i, e)| Ok((format!("({})", i + 1), sheet.add(&e.expr)?)))
        .collect::<Result<_, PrintError>>()?;
    out.push(Block::Equations {
        heading: "equations of motion, $A_\\Gamma\\dot\\eta + Q - \\Gamma^T\\nabla U = 0$ (from (9), with the term the paper drops)".into(),
        rows: equations,
        rhs_zero: true,
    });
    Ok(out)
}

fn mat_block(sheet: &mut Sheet, symbol: &str, m: &Mat) -> Result<Block, PrintError> {
    let mut rows = Vec::new();
    for (i, row) in m.entries.iter().enumerate() {
        let mut r = Vec::new();
        for (j, e) in row.iter().enumerate() {
            r.push((
                format!("{symbol}[{}, {}]", i + 1, j + 1),
                sheet.add(&e.expr)?,
            ));
        }
        rows.push(r);
    }
    Ok(Block::Matrix {
        symbol: symbol.to_string(),
        rows,
    })
}

/// A matrix as `pmatrix` when it fits the line, else its nonzero entries one per line
/// (the upper triangle of a symmetric one).
fn matrix(sheet: &Sheet, symbol: &str, rows: &[Vec<(String, usize)>], o: &mut String) {
    let tex: Vec<Vec<String>> = rows
        .iter()
        .map(|r| r.iter().map(|(_, id)| sheet.latex(*id)).collect())
        .collect();
    let cols = tex.first().map_or(0, Vec::len);
    let widths: usize = (0..cols)
        .map(|j| tex.iter().map(|r| width(&r[j])).max().unwrap_or(0) + 3)
        .sum();
    let _ = writeln!(o, "\\begin{{align*}}");
    if rows.is_empty() || cols == 0 {
        let _ = writeln!(o, "{symbol} &= \\varnothing");
    } else if widths <= LINE {
        let body: Vec<String> = tex.iter().map(|r| r.join(" & ")).collect();
        let _ = writeln!(
            o,
            "{symbol} &= \\begin{{pmatrix}} {} \\end{{pmatrix}}",
            body.join(" \\\\ ")
        );
    } else {
        entry_list(sheet, symbol, rows, &tex, o);
    }
    let _ = writeln!(o, "\\end{{align*}}");
}

fn entry_list(
    sheet: &Sheet,
    symbol: &str,
    rows: &[Vec<(String, usize)>],
    tex: &[Vec<String>],
    o: &mut String,
) {
    let symmetric = (0..tex.len())
        .all(|i| (0..tex[i].len()).all(|j| tex.get(j).and_then(|r| r.get(i)) == Some(&tex[i][j])));
    let mut lines = Vec::new();
    for (i, row) in rows.iter().enumerate() {
        for (j, (_, id)) in row.iter().enumerate() {
            if tex[i][j] == "0" || (symmetric && j < i) {
                continue;
            }
            let lhs = format!("{{{symbol}}}_{{{}{}}}", i + 1, j + 1);
            lines.extend(aligned(sheet, &lhs, *id, "", ""));
        }
    }
    if symmetric {
        lines.push(format!(
            "&\\text{{(${symbol}$ is symmetric; the other entries are 0)}}"
        ));
    } else {
        lines.push(format!(
            "&\\text{{(the other entries of ${symbol}$ are 0)}}"
        ));
    }
    let _ = writeln!(o, "{}", lines.join(" \\\\\n"));
}

/// `lhs &= entry` broken over lines (`&\quad` before each continuation).
fn aligned(sheet: &Sheet, lhs: &str, id: usize, before: &str, after: &str) -> Vec<String> {
    let budget = LINE.saturating_sub(width(lhs) + width(after));
    let parts = sheet.latex_lines(id, budget);
    let last = parts.len() - 1;
    parts
        .into_iter()
        .enumerate()
        .map(|(k, p)| {
            let tail = if k == last { after } else { "" };
            if k == 0 {
                format!("{lhs} &= {before}{p}{tail}")
            } else {
                format!("&\\quad {p}{tail}")
            }
        })
        .collect()
}

fn equations(sheet: &Sheet, heading: &str, rows: &[(String, usize)], zero: bool, o: &mut String) {
    let _ = writeln!(o, "\\noindent {heading}:");
    let _ = writeln!(o, "\\begin{{align*}}");
    let mut lines = Vec::new();
    for (label, id) in rows {
        if zero {
            let parts = sheet.latex_lines(*id, LINE);
            let last = parts.len() - 1;
            for (k, p) in parts.into_iter().enumerate() {
                let tail = if k == last { " = 0" } else { "" };
                let tag = if k == 0 {
                    format!("{label}\\quad")
                } else {
                    String::new()
                };
                let lead = if k == 0 { "" } else { "\\quad " };
                lines.push(format!("{tag} & {lead}{p}{tail}"));
            }
        } else {
            lines.extend(aligned(sheet, label, *id, "", ""));
        }
    }
    let _ = writeln!(o, "{}", lines.join(" \\\\\n"));
    let _ = writeln!(o, "\\end{{align*}}");
}

/// The named groups, once, each broken over lines where it is long.
fn where_list(sheet: &Sheet, o: &mut String) {
    let defs = sheet.definitions_latex();
    if defs.is_empty() {
        return;
    }
    let _ = writeln!(o, "\\noindent where\n\\begin{{align*}}");
    let mut lines = Vec::new();
    for (j, (name, _)) in defs.iter().enumerate() {
        let parts = sheet.definition_lines(j, LINE.saturating_sub(width(name)));
        for (k, p) in parts.into_iter().enumerate() {
            lines.push(if k == 0 {
                format!("{name} &= {p}")
            } else {
                format!("&\\quad {p}")
            });
        }
    }
    let _ = writeln!(o, "{}", lines.join(" \\\\\n"));
    let _ = writeln!(o, "\\end{{align*}}");
}

/// The complete document around `body`.
fn document(d: &Derivation, body: &str) -> String {
    format!(
        "\\documentclass[10pt]{{article}}\n\\usepackage[a4paper,landscape,margin=1cm]{{geometry}}\n\\usepackage{{amsmath,amssymb}}\n\\allowdisplaybreaks\n\\raggedright\n\\begin{{document}}\n\\section*{{{}: {}}}\n\\noindent Quasi-velocities \\texttt{{{}}}. Printed by hamel; every entry expands to its canonical form exactly (checked).\n\n{body}\\end{{document}}\n",
        text(&d.model),
        text(&d.title),
        text(&d.eta_name)
    )
}

/// Plain text for LaTeX: its special characters escaped, characters beyond Latin-1 (Greek
/// letters in a title) dropped to `?`.
fn text(s: &str) -> String {
    s.chars()
        .map(|c| match c {
            '\\' => "\\textbackslash{}".to_string(),
            '{' | '}' | '$' | '&' | '#' | '_' | '%' => format!("\\{c}"),
            '^' => "\\^{}".to_string(),
            '~' => "\\~{}".to_string(),
            '–' => "--".to_string(),
            '—' => "---".to_string(),
            c if (c as u32) < 0x100 => c.to_string(),
            _ => "?".to_string(),
        })
        .collect()
}
