//! The LaTeX document of a derivation: its blocks (A, α, Z, q̇ = Γη, A_Γ, the equations),
//! each matrix as `pmatrix` when it fits, else entry by entry, long entries broken over lines,
//! and the where-list of the names they use.

use std::collections::BTreeSet;
use std::fmt::Write;

use hamel_derive::{Derivation, Mat};
use hamel_expr::latex_name;

use crate::layout::{LINE, width};
use crate::printing::Printing;
use crate::sheet::Sheet;

/// An object of the LaTeX document.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Object {
    /// The mass matrix A of T = ½q̇ᵀAq̇.
    A,
    /// The constraints α of αq̇ = 0.
    Alpha,
    /// The quasi-velocities' matrix Z of η = Zq̇.
    Z,
    /// The kinematic equations (6), q̇ = Γη.
    Kinematics,
    /// A_Γ = ΓᵀAΓ (8).
    AGamma,
    /// The equations of motion A_Γη̇ + Q − Γᵀ∇U = 0.
    Equations,
}

/// A block of the document: a matrix, or a list of equations `lhs = entry`.
pub(crate) enum Block {
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
    /// Every entry's id.
    pub(crate) fn ids(&self) -> Vec<usize> {
        match self {
            Block::Matrix { rows, .. } => rows.iter().flatten().map(|(_, id)| *id).collect(),
            Block::Equations { rows, .. } => rows.iter().map(|(_, id)| *id).collect(),
        }
    }

    pub(crate) fn write(&self, sheet: &Sheet, o: &mut String) {
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

/// The document's entries, in its order, by their ids in the printing, each block with the
/// object it shows.
pub(crate) fn blocks(d: &Derivation, p: &Printing) -> Vec<(Object, Block)> {
    let mut out = vec![
        (Object::A, mat_block(p, "A", &d.a)),
        (Object::Alpha, mat_block(p, "\\alpha", &d.alpha)),
    ];
    out.extend(
        dependent_blocks(d, p)
            .into_iter()
            .map(|b| (Object::Alpha, b)),
    );
    out.push((Object::Z, mat_block(p, "Z", &d.z)));
    let Some(c) = d.closed() else {
        return out;
    };
    let q: Vec<String> = d.coordinates.iter().map(|c| latex_name(c)).collect();
    let kinematics = c
        .kinematics
        .iter()
        .zip(&q)
        .map(|(e, q)| (format!("\\dot{{{q}}}"), p.id(e)))
        .collect();
    out.push((
        Object::Kinematics,
        Block::Equations {
            heading: "kinematic equations (6), $\\dot q = \\Gamma\\eta$".into(),
            rows: kinematics,
            rhs_zero: false,
        },
    ));
    out.push((Object::AGamma, mat_block(p, "A_\\Gamma", &c.a_gamma)));
    let equations = c
        .equations
        .iter()
        .enumerate()
        .map(|(i, e)| (format!("({})", i + 1), p.id(e)))
        .collect();
    out.push((Object::Equations, Block::Equations {
        heading: "equations of motion, $A_\\Gamma\\dot\\eta + Q - \\Gamma^T\\nabla U = 0$ (from (9), with the term the paper drops)".into(),
        rows: equations,
        rhs_zero: true,
    }));
    out
}

/// Each row dropped from α as the combination c_j of α's rows α_j it is (exact).
fn dependent_blocks(d: &Derivation, p: &Printing) -> Vec<Block> {
    d.dependent_rows
        .iter()
        .map(|r| {
            let rows = r
                .combination
                .iter()
                .map(|t| {
                    let j = d.constraints.iter().position(|n| *n == t.row).map_or(0, |j| j + 1);
                    (format!("c_{{{j}}}"), p.id(&t.coefficient))
                })
                .collect();
            let names: Vec<String> = (d.constraints.iter().enumerate())
                .map(|(i, n)| format!("$\\alpha_{{{}}}$ = \\texttt{{{}}}", i + 1, latex_text(n)))
                .collect();
            Block::Equations {
                heading: format!(
                    "the row \\texttt{{{}}}, dropped from $\\alpha$ as dependent: it is $\\sum_j c_j \\alpha_j$ exactly{}, with the rows {} and",
                    latex_text(&r.name),
                    match &r.on_manifold {
                        Some(h) => format!(
                            " where \\texttt{{{}}} $= 0$ holds (only there)",
                            latex_text(h)
                        ),
                        None => String::new(),
                    },
                    names.join(", ")
                ),
                rows,
                rhs_zero: false,
            }
        })
        .collect()
}

fn mat_block(p: &Printing, symbol: &str, m: &Mat) -> Block {
    let mut rows = Vec::new();
    for (i, row) in m.entries.iter().enumerate() {
        let mut r = Vec::new();
        for (j, e) in row.iter().enumerate() {
            r.push((format!("{symbol}[{}, {}]", i + 1, j + 1), p.id(e)));
        }
        rows.push(r);
    }
    Block::Matrix {
        symbol: symbol.to_string(),
        rows,
    }
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
            if let Some(d) = sheet.multiplier_latex(*id) {
                lines.push(format!(
                    "& \\qquad\\text{{(multiplied by }} {d} > 0\\text{{)}}"
                ));
            }
        } else {
            lines.extend(aligned(sheet, label, *id, "", ""));
        }
    }
    let _ = writeln!(o, "{}", lines.join(" \\\\\n"));
    let _ = writeln!(o, "\\end{{align*}}");
}

/// The named groups, once, each broken over lines where it is long.
pub(crate) fn where_list(sheet: &Sheet, used: &BTreeSet<usize>, o: &mut String) {
    if used.is_empty() {
        return;
    }
    let _ = writeln!(o, "\\noindent where\n\\begin{{align*}}");
    let mut lines = Vec::new();
    for &j in used {
        let name = sheet.name_latex(j);
        let parts = sheet.definition_lines(j, LINE.saturating_sub(width(&name)));
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
pub(crate) fn document(d: &Derivation, body: &str) -> String {
    format!(
        "\\documentclass[10pt]{{article}}\n\\usepackage[a4paper,landscape,margin=1cm]{{geometry}}\n\\usepackage{{amsmath,amssymb}}\n\\allowdisplaybreaks\n\\raggedright\n\\begin{{document}}\n\\section*{{{}: {}}}\n\\noindent Quasi-velocities \\texttt{{{}}}. Printed by hamel; every entry expands to its canonical form exactly (checked).\n\n{body}\\end{{document}}\n",
        latex_text(&d.model),
        latex_text(&d.title),
        latex_text(&d.eta_name)
    )
}

/// Plain text for LaTeX: its special characters escaped, characters beyond Latin-1 (Greek
/// letters in a title) dropped to `?`.
fn latex_text(s: &str) -> String {
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
