//! `Scene.ensemble`: members given from Python (columns of numbers) or by the scene, and the
//! run's results as arrays.

use indexmap::IndexMap;
use numpy::{PyArray1, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use hamel_model::ModelError;
use hamel_run::Loaded;
use hamel_run::ensemble::EnsembleRun;
use hamel_run::file::Save;
use hamel_run::members::Members;

/// The members given as columns `{name: values}`: written as the CSV a members file would
/// hold (every value exactly, NaN an empty cell: the scene's) and read by the scene's reader,
/// so that names and values are checked as a file's are.
pub fn members(
    loaded: &Loaded,
    columns: &IndexMap<String, Vec<f64>>,
    save: Save,
) -> Result<Members, ModelError> {
    let name = "<members given in Python>.csv";
    let lengths: Vec<usize> = columns.values().map(Vec::len).collect();
    if columns.is_empty() || lengths.iter().any(|&n| n != lengths[0]) {
        let m =
            format!("members: give one or more columns of equal length, got lengths {lengths:?}");
        return Err(loaded.error("members", m));
    }
    let mut text = columns
        .keys()
        .map(|k| csv_cell(k))
        .collect::<Vec<_>>()
        .join(",")
        + "\n";
    for i in 0..lengths[0] {
        let row: Vec<String> = columns
            .values()
            .map(|v| match v[i] {
                x if x.is_nan() => String::new(),
                x => format!("{x:?}"),
            })
            .collect();
        text += &(row.join(",") + "\n");
    }
    hamel_run::members::read(name, &text, loaded.model(), save)
}

/// A name as one CSV cell (quoted, quotes doubled): the reader then refuses it by name.
fn csv_cell(name: &str) -> String {
    format!("\"{}\"", name.replace('"', "\"\""))
}

/// The scene's own members (`[ensemble]`), kept as `save` says.
pub fn scene_members(loaded: &Loaded, save: Save) -> Result<Members, ModelError> {
    match loaded.members()? {
        Some(mut m) => {
            m.save = save;
            Ok(m)
        }
        None => Err(loaded.error(
            "ensemble",
            "the scene has no [ensemble]: give the members, Scene.ensemble({name: values})".into(),
        )),
    }
}

/// The run as a dict of arrays.
pub fn to_dict<'py>(
    py: Python<'py>,
    run: &EnsembleRun,
    save: Save,
) -> PyResult<Bound<'py, PyDict>> {
    let m = &run.members;
    let out = PyDict::new(py);
    let ints = |f: &dyn Fn(&hamel_run::ensemble::MemberResult) -> usize| {
        PyArray1::from_vec(py, m.iter().map(f).collect::<Vec<usize>>())
    };
    out.set_item("member", ints(&|r| r.member))?;
    out.set_item("steps", ints(&|r| r.steps))?;
    out.set_item("rhs_evals", ints(&|r| r.rhs_evals))?;
    out.set_item(
        "complete",
        m.iter().map(|r| r.complete).collect::<Vec<bool>>(),
    )?;
    out.set_item(
        "errors",
        m.iter().map(|r| r.error.clone()).collect::<Vec<_>>(),
    )?;
    let given = PyDict::new(py);
    for name in &run.header.given {
        let column: Vec<f64> = m
            .iter()
            .map(|r| r.given.get(name).copied().unwrap_or(f64::NAN))
            .collect();
        given.set_item(name, PyArray1::from_vec(py, column))?;
    }
    out.set_item("given", given)?;
    let times = m.iter().map(|r| r.t.len()).max().unwrap_or(0);
    let t = m
        .iter()
        .find(|r| r.t.len() == times)
        .map(|r| r.t.clone())
        .unwrap_or_default();
    let names: Vec<&String> = m
        .first()
        .map(|r| r.values.keys().collect())
        .unwrap_or_default();
    let values = PyDict::new(py);
    for name in names {
        let mut flat = Vec::with_capacity(m.len() * times);
        for r in m {
            let v = r.values.get(name).map(Vec::as_slice).unwrap_or_default();
            flat.extend((0..times).map(|j| v.get(j).copied().flatten().unwrap_or(f64::NAN)));
        }
        let array = PyArray1::from_vec(py, flat);
        match save {
            Save::Final => values.set_item(name, array)?,
            Save::Outputs => values.set_item(name, array.reshape([m.len(), times])?)?,
        }
    }
    out.set_item("values", values)?;
    out.set_item("t", PyArray1::from_vec(py, t))?;
    let header = serde_json::to_string(&run.header).expect("serialisable");
    out.set_item(
        "header",
        py.import("json")?.call_method1("loads", (header,))?,
    )?;
    Ok(out)
}
