//! A scene's `[inputs]` and `[gains]`: what drives each of the model's inputs during the run.
//!
//! **Job**: sort the scene's inputs into constants (parameter values, as `[parameters]` would
//! set them), control laws (expressions of t, q, der(q), η, the parameters and the gains, which
//! [`hamel_model::Model::controlled`] puts into the forces) and tables of time (read at every
//! evaluation, [`hamel_sim::Table`]); read the tables' CSV files; check that the run stays
//! inside every table that says `outside = "error"` before anything is integrated.
//!
//! **Outputs**: a [`Driven`] (for `check`) and, once the tables are read ([`tables`]), the
//! [`hamel_sim::Live`] sources of the closed-loop model's live parameters ([`live`]).

use hamel_model::Model;
use hamel_model::{Control, Law};
use hamel_sim::{Live, Outside, Samples, Table};
use indexmap::IndexMap;

use crate::file::{InputSpec, Scene, TableSpec};

/// An error at a key of the scene file: (the key, the reason).
pub type Keyed = (String, String);

/// The scene's inputs sorted by how they are driven.
pub struct Driven {
    /// Laws, gains and the names of tabled inputs: the closed loop's control.
    pub control: Control,
    /// Inputs held constant: parameter values.
    pub constants: IndexMap<String, f64>,
}

/// Sort `scene.inputs` (nothing is checked against the model here but what needs no model:
/// a constant is finite, a table has one source of samples).
pub fn driven(scene: &Scene) -> Result<Driven, Keyed> {
    let mut d = Driven {
        control: Control {
            gains: scene.gains.clone(),
            ..Control::default()
        },
        constants: IndexMap::new(),
    };
    for (name, spec) in &scene.inputs {
        let key = format!("inputs.{name}");
        if scene.parameters.contains_key(name) {
            return Err((
                key,
                format!(
                    "{name} is given in [inputs] and also in [parameters] or by --set: give it in one place"
                ),
            ));
        }
        match spec {
            InputSpec::Constant(v) if v.is_finite() => {
                d.constants.insert(name.clone(), *v);
            }
            InputSpec::Constant(v) => return Err((key, format!("{v} is not finite"))),
            InputSpec::Law(text) => d.control.laws.push(Law {
                input: name.clone(),
                text: text.clone(),
            }),
            InputSpec::Table(t) => {
                source_of(t).map_err(|m| (key, m))?;
                d.control.tabled.push(name.clone());
            }
        }
    }
    Ok(d)
}

/// Where a table's samples come from: its file, or the samples written out.
enum TableSource<'a> {
    File(&'a str),
    Written(&'a [f64], &'a [f64]),
}

fn source_of(t: &TableSpec) -> Result<TableSource<'_>, String> {
    match (&t.file, &t.times, &t.values) {
        (Some(f), None, None) => Ok(TableSource::File(f)),
        (None, Some(times), Some(values)) if t.time.is_none() && t.column.is_none() => {
            Ok(TableSource::Written(times, values))
        }
        _ => Err(
            "a table is `{ file = \"samples.csv\" }` (with `time` and `column` naming its columns, by default t and the input's name) or `{ times = [...], values = [...] }`".into(),
        ),
    }
}

/// The scene's tables, read (CSV files relative to `dir`) and checked: increasing times,
/// finite samples, and the run's span [t0, t_end] inside each table that says `outside =
/// "error"`.
pub fn tables(scene: &Scene, dir: &std::path::Path) -> Result<IndexMap<String, Table>, Keyed> {
    let mut out = IndexMap::new();
    for (name, spec) in &scene.inputs {
        let InputSpec::Table(t) = spec else { continue };
        let key = format!("inputs.{name}");
        let samples = match source_of(t).map_err(|m| (key.clone(), m))? {
            TableSource::Written(times, values) => (times.to_vec(), values.to_vec()),
            TableSource::File(f) => {
                let path = dir.join(f);
                let text = std::fs::read_to_string(&path).map_err(|e| {
                    (
                        key.clone(),
                        format!("cannot read the table {}: {e}", path.display()),
                    )
                })?;
                let time = t.time.as_deref().unwrap_or("t");
                let column = t.column.as_deref().unwrap_or(name);
                columns(&text, time, column)
                    .map_err(|m| (key.clone(), format!("the table {}: {m}", path.display())))?
            }
        };
        let table = Table::new(Samples {
            times: samples.0,
            values: samples.1,
            interpolation: t.interpolation,
            outside: t.outside,
        })
        .map_err(|e| (key.clone(), format!("the table of {name}: {e}")))?;
        let (a, b) = table.span();
        let (lo, hi) = (scene.t0.min(scene.t_end), scene.t0.max(scene.t_end));
        if t.outside == Outside::Error && (lo < a || hi > b) {
            return Err((
                key,
                format!(
                    "the table of {name} covers t in [{a}, {b}], but the scene runs over [{lo}, {hi}]: extend the table, or say outside = \"hold\""
                ),
            ));
        }
        out.insert(name.clone(), table);
    }
    Ok(out)
}

/// The columns `time` and `column` of a CSV text with a header line (`#` lines skipped).
fn columns(text: &str, time: &str, column: &str) -> Result<(Vec<f64>, Vec<f64>), String> {
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header = reader
        .headers()
        .map_err(|e| format!("not valid CSV: {e}"))?
        .clone();
    let find = |want: &str| {
        header.iter().position(|h| h == want).ok_or_else(|| {
            let have: Vec<&str> = header.iter().collect();
            format!("no column `{want}` (its columns are {})", have.join(", "))
        })
    };
    let (ti, vi) = (find(time)?, find(column)?);
    let (mut times, mut values) = (Vec::new(), Vec::new());
    for record in reader.records() {
        let record = record.map_err(|e| format!("not valid CSV: {e}"))?;
        let line = record.position().map_or(0, |p| p.line());
        let cell = |i: usize, name: &str| -> Result<f64, String> {
            let text = record.get(i).unwrap_or("");
            text.parse::<f64>()
                .map_err(|_| format!("line {line}, column `{name}`: `{text}` is not a number"))
        };
        times.push(cell(ti, time)?);
        values.push(cell(vi, column)?);
    }
    Ok((times, values))
}

/// What sets each of `model`'s live parameters (the closed loop's: `t`, then the tabled
/// inputs), in [`Model::live`]'s order.
pub fn live(model: &Model, tables: &IndexMap<String, Table>) -> Vec<Live> {
    model
        .live
        .iter()
        .map(|name| match tables.get(name) {
            Some(t) => Live::Table {
                name: name.clone(),
                table: t.clone(),
            },
            None => Live::Time,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_columns_are_read_by_name_with_located_errors() {
        let text = "# torque\nt, T, other\n0, 1, 9\n1, 2, 9\n";
        assert_eq!(
            columns(text, "t", "T").unwrap(),
            (vec![0.0, 1.0], vec![1.0, 2.0])
        );
        let e = columns(text, "t", "U").unwrap_err();
        assert!(
            e.contains("no column `U`") && e.contains("t, T, other"),
            "{e}"
        );
        let e = columns("t,T\n0,1\n1,x\n", "t", "T").unwrap_err();
        assert!(e.contains("line 3") && e.contains("`x`"), "{e}");
    }
}
