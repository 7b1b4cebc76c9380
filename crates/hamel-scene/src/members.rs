//! The members of an ensemble as the scene gives them (`[ensemble]`): read from a file (CSV
//! with a header line, or JSON lines) or drawn from distributions with a seed. Each member is
//! a set of values by name — coordinates, `eta1`…`etaσ`, parameters — on top of the scene's
//! `[initial]` and `[parameters]`. Nothing is derived here ([`crate::ensemble`] turns members
//! into initial states); every error names the file, the line and the column, or the key.

use hamel_model::Coord;
use std::sync::Arc;

use hamel_model::{Model, ModelError};
use indexmap::IndexMap;
use rand::SeedableRng;
use rand_distr::Distribution as _;

use crate::file::{Distribution, Ensemble, Save};

/// At most this many members in one ensemble (a shard of a larger one is its own ensemble).
pub const MAX_MEMBERS: usize = 10_000_000;

/// What a member's value sets.
#[derive(Clone, Debug, PartialEq)]
pub enum Target {
    /// The initial value of a coordinate.
    Coordinate(Coord),
    /// The initial value of η_{i+1}.
    Eta(usize),
    /// A parameter, by name.
    Parameter(String),
}

/// Where the members come from.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Source {
    /// A file, as the scene names it.
    File(String),
    /// Drawn from the scene's distributions with this seed.
    Drawn {
        /// The seed.
        seed: u64,
        /// The distributions, by name.
        vary: IndexMap<String, Distribution>,
    },
}

/// The members: named columns, and per member a value or nothing (the scene's) per column.
#[derive(Clone, Debug)]
pub struct Members {
    /// The names and what they set, in the order given.
    pub columns: Vec<(String, Target)>,
    /// `rows[i][c]`: member i's value of column c (None: not given, the scene's).
    pub rows: Vec<Vec<Option<f64>>>,
    /// Where they come from.
    pub source: Source,
    /// What is kept of each.
    pub save: Save,
}

impl Members {
    /// Member `i`'s own values by name (those it gives).
    pub fn given(&self, i: usize) -> IndexMap<String, f64> {
        (self.columns.iter().zip(&self.rows[i]))
            .filter_map(|((name, _), v)| v.map(|v| (name.clone(), v)))
            .collect()
    }
}

/// What a name sets in `model` (σ quasi-velocities): a coordinate, `eta1`…, or a parameter
/// that may be set (not a derived one). Error: why it is none.
pub fn target(name: &str, model: &Model) -> Result<Target, String> {
    if let Some(k) = model.coordinate(name) {
        return Ok(Target::Coordinate(k));
    }
    if let Some(i) = name
        .strip_prefix("eta")
        .and_then(|i| i.parse::<usize>().ok())
        && (1..=model.sigma()).contains(&i)
    {
        return Ok(Target::Eta(i - 1));
    }
    if model.parameters.contains_key(name) {
        let probe = IndexMap::from([(name.to_string(), model.parameters[name])]);
        return model
            .parameter_values(&probe)
            .map(|_| Target::Parameter(name.to_string()))
            .map_err(|e| e.to_string());
    }
    Err(format!(
        "`{name}` is not a coordinate ({}), a quasi-velocity (eta1…eta{}) or a parameter ({}) of the model",
        model.coordinates.join(", "),
        model.sigma(),
        model
            .parameters
            .keys()
            .cloned()
            .collect::<Vec<_>>()
            .join(", ")
    ))
}

/// Check `[ensemble]` without reading its file: one source of members, known names, valid
/// distributions. Errors: (the key, the reason).
pub fn check_spec(spec: &Ensemble, model: &Model) -> Result<(), (String, String)> {
    let key = |k: &str| format!("ensemble.{k}");
    match (&spec.file, spec.vary.is_empty(), spec.members) {
        (Some(_), true, None) => return Ok(()),
        (Some(_), _, _) => {
            return Err((
                key("file"),
                "give the members either as a `file` or as `members` drawn from `vary`, not both"
                    .into(),
            ));
        }
        (None, false, Some(n)) if (1..=MAX_MEMBERS).contains(&n) => {}
        (None, false, Some(n)) => {
            return Err((
                key("members"),
                format!("must be between 1 and {MAX_MEMBERS}, got {n}"),
            ));
        }
        (None, _, _) => {
            return Err((
                "ensemble".into(),
                "needs `file = \"members.csv\"` (or .jsonl), or `members = N` with distributions in `[ensemble.vary]`".into(),
            ));
        }
    }
    for (name, d) in &spec.vary {
        let k = key(&format!("vary.{name}"));
        target(name, model).map_err(|m| (k.clone(), m))?;
        sampler(*d).map_err(|m| (k, m))?;
    }
    Ok(())
}

/// A distribution ready to draw from. Error: why its parameters are not valid.
fn sampler(d: Distribution) -> Result<Sampler, String> {
    match d {
        Distribution::Uniform([a, b]) => rand_distr::Uniform::new(a, b)
            .ok()
            .filter(|_| a.is_finite() && b.is_finite())
            .map(Sampler::Uniform)
            .ok_or(format!("uniform needs finite low < high, got [{a}, {b}]")),
        Distribution::Normal([mean, sd]) => rand_distr::Normal::new(mean, sd)
            .ok()
            .filter(|_| mean.is_finite() && sd.is_finite() && sd > 0.0)
            .map(Sampler::Normal)
            .ok_or(format!(
                "normal needs a finite mean and a finite standard deviation > 0, got [{mean}, {sd}]"
            )),
    }
}

enum Sampler {
    Uniform(rand_distr::Uniform<f64>),
    Normal(rand_distr::Normal<f64>),
}

/// The members drawn from `spec.vary`: member by member, name by name in the order written,
/// from ChaCha8 seeded with `spec.seed` (checked by [`check_spec`]).
pub fn draw(spec: &Ensemble, model: &Model) -> Result<Members, String> {
    let n = spec.members.unwrap_or(0);
    let mut columns = Vec::new();
    let mut samplers = Vec::new();
    for (name, &d) in &spec.vary {
        columns.push((name.clone(), target(name, model)?));
        samplers.push(sampler(d)?);
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(spec.seed);
    let rows = (0..n)
        .map(|_| {
            samplers
                .iter()
                .map(|s| {
                    Some(match s {
                        Sampler::Uniform(u) => u.sample(&mut rng),
                        Sampler::Normal(g) => g.sample(&mut rng),
                    })
                })
                .collect()
        })
        .collect();
    Ok(Members {
        columns,
        rows,
        source: Source::Drawn {
            seed: spec.seed,
            vary: spec.vary.clone(),
        },
        save: spec.save,
    })
}

/// The members in the file `name` with contents `text`: CSV (`.csv`) with a header line of
/// names, or JSON lines (`.jsonl`, `.ndjson`) of objects from names to numbers. Lines that
/// start with `#` and empty lines are skipped; an empty cell (CSV) or a missing name (JSON)
/// is the scene's value. Errors are located in the file.
pub fn read(name: &str, text: &str, model: &Model, save: Save) -> Result<Members, ModelError> {
    let source = Arc::new(text.to_string());
    let at = |span: Option<std::ops::Range<usize>>, m: String| {
        ModelError::new(name, source.clone(), span, None, m)
    };
    let (columns, rows) = if name.ends_with(".csv") {
        read_csv(text, model, &at)?
    } else if name.ends_with(".jsonl") || name.ends_with(".ndjson") {
        read_json_lines(text, model, &at)?
    } else {
        return Err(at(
            None,
            "the members file must be CSV (.csv) or JSON lines (.jsonl, .ndjson)".into(),
        ));
    };
    if rows.is_empty() || rows.len() > MAX_MEMBERS {
        return Err(at(
            None,
            format!(
                "needs between 1 and {MAX_MEMBERS} members, found {}",
                rows.len()
            ),
        ));
    }
    Ok(Members {
        columns,
        rows,
        source: Source::File(name.to_string()),
        save,
    })
}

type Located<'a> = dyn Fn(Option<std::ops::Range<usize>>, String) -> ModelError + 'a;
type Table = (Vec<(String, Target)>, Vec<Vec<Option<f64>>>);

fn read_csv(text: &str, model: &Model, at: &Located<'_>) -> Result<Table, ModelError> {
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_reader(text.as_bytes());
    let csv_error = |e: csv::Error| {
        let span = e
            .position()
            .map(|p| p.byte() as usize..p.byte() as usize + 1);
        at(span, format!("not valid CSV: {e}"))
    };
    let header = reader.byte_headers().map_err(csv_error)?.clone();
    let header_at = header.position().map_or(0, |p| p.byte() as usize);
    let mut columns: Vec<(String, Target)> = Vec::new();
    for (c, field) in header.iter().enumerate() {
        let span = header
            .range(c)
            .map(|r| header_at + r.start..header_at + r.end);
        let name = String::from_utf8_lossy(field).trim().to_string();
        if columns.iter().any(|(n, _)| *n == name) {
            return Err(at(span, format!("column `{name}` appears twice")));
        }
        let t = target(&name, model).map_err(|m| at(span, m))?;
        columns.push((name, t));
    }
    let mut rows = Vec::new();
    for record in reader.byte_records() {
        let record = record.map_err(csv_error)?;
        let start = record.position().map_or(0, |p| p.byte() as usize);
        let line = record.position().map_or(0, |p| p.line());
        let mut row = Vec::with_capacity(columns.len());
        for (c, field) in record.iter().enumerate() {
            let span = record.range(c).map(|r| start + r.start..start + r.end);
            let cell = String::from_utf8_lossy(field);
            row.push(
                number(cell.trim()).map_err(|m| {
                    at(span, format!("line {line}, column `{}`: {m}", columns[c].0))
                })?,
            );
        }
        if rows.len() == MAX_MEMBERS {
            return Err(at(None, format!("more than {MAX_MEMBERS} members")));
        }
        rows.push(row);
    }
    Ok((columns, rows))
}

/// A cell: empty (the scene's value) or a finite number.
fn number(cell: &str) -> Result<Option<f64>, String> {
    if cell.is_empty() {
        return Ok(None);
    }
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        Ok(v) => Err(format!("{v} is not finite")),
        Err(_) => Err(format!("`{cell}` is not a number")),
    }
}

fn read_json_lines(text: &str, model: &Model, at: &Located<'_>) -> Result<Table, ModelError> {
    let mut columns: Vec<(String, Target)> = Vec::new();
    let mut values: Vec<IndexMap<usize, f64>> = Vec::new();
    let mut offset = 0;
    for (l, line) in text.split_inclusive('\n').enumerate() {
        let span = offset..offset + line.trim_end().len();
        offset += line.len();
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let object: IndexMap<String, serde_json::Value> =
            serde_json::from_str(trimmed).map_err(|e| {
                at(
                    Some(span.clone()),
                    format!("line {}: not a JSON object: {e}", l + 1),
                )
            })?;
        let mut row = IndexMap::new();
        for (name, v) in object {
            let located = |m: String| at(Some(span.clone()), format!("line {}: {m}", l + 1));
            let c = match columns.iter().position(|(n, _)| *n == name) {
                Some(c) => c,
                None => {
                    columns.push((name.clone(), target(&name, model).map_err(&located)?));
                    columns.len() - 1
                }
            };
            let x = v
                .as_f64()
                .filter(|x| x.is_finite())
                .ok_or_else(|| located(format!("`{name}` must be a finite number, got {v}")))?;
            row.insert(c, x);
        }
        if values.len() == MAX_MEMBERS {
            return Err(at(None, format!("more than {MAX_MEMBERS} members")));
        }
        values.push(row);
    }
    let rows = values
        .iter()
        .map(|r| (0..columns.len()).map(|c| r.get(&c).copied()).collect())
        .collect();
    Ok((columns, rows))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn knife() -> Model {
        Model::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../models/knife.toml"
        ))
        .unwrap()
    }

    #[test]
    fn csv_and_json_lines_give_the_same_members() {
        let model = knife();
        let csv = "# members\ntheta,eta2,m\n0.1,0.5,2\n0.2,,3\n";
        let jsonl = "{\"theta\": 0.1, \"eta2\": 0.5, \"m\": 2}\n\n{\"theta\": 0.2, \"m\": 3}\n";
        let a = read("m.csv", csv, &model, Save::Final).unwrap();
        let b = read("m.jsonl", jsonl, &model, Save::Final).unwrap();
        assert_eq!(a.columns, b.columns);
        assert_eq!(a.rows, b.rows);
        assert_eq!(a.rows[1], vec![Some(0.2), None, Some(3.0)]);
        assert_eq!(a.columns[1].1, Target::Eta(1));
    }

    #[test]
    fn a_bad_cell_is_located_by_line_and_column() {
        let model = knife();
        let e = read("m.csv", "theta,m\n0.1,2\n0.2,heavy\n", &model, Save::Final).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("line 3") && text.contains("`m`"), "{text}");
        assert!(text.contains("`heavy` is not a number"), "{text}");
        let e = read("m.csv", "theta,mass\n0.1,2\n", &model, Save::Final).unwrap_err();
        assert!(e.to_string().contains("`mass` is not a coordinate"), "{e}");
        let e = read("m.jsonl", "{\"theta\": \"x\"}\n", &model, Save::Final).unwrap_err();
        assert!(e.to_string().contains("line 1"), "{e}");
        let e = read("m.txt", "theta\n1\n", &model, Save::Final).unwrap_err();
        assert!(e.to_string().contains("CSV (.csv) or JSON lines"), "{e}");
    }

    #[test]
    fn draws_follow_the_seed_and_the_distributions() {
        let model = knife();
        let spec = |seed| Ensemble {
            file: None,
            members: Some(2000),
            seed,
            vary: IndexMap::from([
                ("theta".into(), Distribution::Uniform([0.0, 0.5])),
                ("eta1".into(), Distribution::Normal([1.0, 0.1])),
            ]),
            save: Save::Final,
        };
        let a = draw(&spec(7), &model).unwrap();
        assert_eq!(a.rows, draw(&spec(7), &model).unwrap().rows);
        assert_ne!(a.rows, draw(&spec(8), &model).unwrap().rows);
        let theta: Vec<f64> = a.rows.iter().map(|r| r[0].unwrap()).collect();
        assert!(theta.iter().all(|&t| (0.0..0.5).contains(&t)));
        let eta: Vec<f64> = a.rows.iter().map(|r| r[1].unwrap()).collect();
        let mean = eta.iter().sum::<f64>() / eta.len() as f64;
        let sd = (eta.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / eta.len() as f64).sqrt();
        // 2000 draws: the mean within 5 standard errors, the deviation within 10 %.
        assert!((mean - 1.0).abs() < 5.0 * 0.1 / 2000f64.sqrt(), "{mean}");
        assert!((sd - 0.1).abs() < 0.01, "{sd}");
        let bad = Ensemble {
            vary: IndexMap::from([("theta".into(), Distribution::Normal([0.0, -1.0]))]),
            ..spec(1)
        };
        let (key, why) = check_spec(&bad, &model).unwrap_err();
        assert_eq!(key, "ensemble.vary.theta");
        assert!(why.contains("standard deviation > 0"), "{why}");
    }
}
