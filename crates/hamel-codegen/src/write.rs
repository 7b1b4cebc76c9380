//! `hamel codegen`: a model's equations written as a standalone Rust crate — derived, the
//! elimination checked exactly (`hamel-reduce`'s ground truth), generated and written.

use std::path::{Path, PathBuf};

use hamel_model::{Model, ModelError};
use hamel_reduce::ReduceError;

use crate::CodegenError;

/// Why a crate could not be written.
#[derive(Clone, Debug, thiserror::Error)]
pub enum WriteError {
    /// The derivation or the elimination's analysis failed.
    #[error(transparent)]
    Reduce(#[from] ReduceError),
    /// The choice does not eliminate the coordinates asked for.
    #[error("quasi-velocities `{choice}` do not eliminate {}: {why} (see `hamel reduce`)", coordinates.join(", "))]
    NotEliminated {
        /// The choice.
        choice: String,
        /// The coordinates asked for.
        coordinates: Vec<String>,
        /// Why not (the first occurrence, or what is undecided).
        why: String,
    },
    /// The code could not be generated.
    #[error(transparent)]
    Generate(#[from] CodegenError),
    /// The output directory cannot be written (or is not empty without `force`).
    #[error("{}: {why}", dir.display())]
    Output {
        /// The directory.
        dir: PathBuf,
        /// Why.
        why: String,
    },
}

impl From<ModelError> for WriteError {
    fn from(e: ModelError) -> WriteError {
        WriteError::Reduce(e.into())
    }
}

impl WriteError {
    /// The located diagnostic (the model's file, or the output directory's).
    pub fn locate(self, model: &Model) -> ModelError {
        match self {
            WriteError::Reduce(e) => e.locate(model),
            WriteError::Output { dir, why } => ModelError::new(
                &dir.display().to_string(),
                Default::default(),
                None,
                None,
                why,
            ),
            e => model.error(e.to_string()),
        }
    }
}

/// What was written.
pub struct Written {
    /// Files written.
    pub files: usize,
    /// Operations of the ingredients as trees, and with common subexpressions shared.
    pub ops_trees: usize,
    /// See `ops_trees`.
    pub ops_shared: usize,
    /// Coordinates whose derivatives of Z, α and A are taken at run time by dual numbers
    /// (a structured derivation), not written as trees; 0 when they are written.
    pub partials: usize,
}

/// How to write the crate.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteOptions {
    /// Overwrite the generated files of a non-empty directory.
    pub force: bool,
    /// Also write a `simulate` binary (vendors the integrators into the crate).
    pub with_simulator: bool,
    /// Derive anew (and store) whatever the derivation store holds (`--no-store`).
    pub fresh: bool,
}

/// Derive `model` with the choice `eta`, check exactly that `eliminate` drops out, generate,
/// and write the crate into `out`.
pub fn write_crate(
    model: &Model,
    eta: Option<&str>,
    eliminate: &[String],
    out: &Path,
    options: WriteOptions,
) -> Result<Written, WriteError> {
    let WriteOptions {
        force,
        with_simulator,
        fresh,
    } = options;
    let io_err = |why: String| WriteError::Output {
        dir: out.to_path_buf(),
        why,
    };
    if out.exists() {
        let non_empty = std::fs::read_dir(out)
            .map_err(|e| io_err(format!("cannot read the directory: {e}")))?
            .next()
            .is_some();
        if non_empty && !force {
            return Err(io_err(
                "the output directory is not empty (pass --force to overwrite its generated files)"
                    .into(),
            ));
        }
    }
    let choice = model.choice(eta)?.name.clone();
    let eliminated = match eliminate.is_empty() {
        true => Vec::new(),
        false => hamel_reduce::coordinate_indices(model, eliminate)?,
    };
    let d = derive(model, &choice, &eliminated, eliminate, fresh)?;
    let command = format!(
        "hamel codegen {} --eta {choice}{} --out DIR",
        model.file,
        if eliminate.is_empty() {
            String::new()
        } else {
            format!(" --eliminate {}", eliminate.join(","))
        }
    );
    let mut g = crate::generate(&d, &eliminated, &command)?;
    if with_simulator {
        g = crate::with_simulator(g)?;
    }
    place(out, &g.files).map_err(io_err)?;
    Ok(Written {
        files: g.files.len(),
        ops_trees: g.ops_trees,
        ops_shared: g.ops_shared,
        partials: g.partials,
    })
}

/// The one pass for the crate (from the derivation store when it holds it, made anew when
/// `fresh`), and the exact proof that `eliminated` drops out. The crate exports the constraint
/// forces (`constraint_forces`): the supports of the wheels the frames keep on the ground are
/// released for them, but for a closed loop, whose laws are in the forces, not in the
/// mechanism's loads.
fn derive(
    model: &Model,
    choice: &str,
    eliminated: &[hamel_model::Coord],
    eliminate: &[String],
    fresh: bool,
) -> Result<hamel_derive::Derivation, WriteError> {
    use hamel_reduce::pass::{Analysis, Job, obtain};
    let analysis = match eliminated.is_empty() {
        true => Analysis::Equations,
        false => Analysis::Eliminate(eliminated.to_vec()),
    };
    let job = Job::new(model, Some(choice), analysis)?
        .with_supports(model.control.is_empty())
        .for_code();
    let mut artefact = obtain(&job, fresh)?;
    let Some(r) = artefact.reduction.take() else {
        return Ok(artefact.into_derivation()?);
    };
    if !r.ground_truth.present.is_empty() || r.reduced_system.is_none() {
        let why = if let Some(w) = r.ground_truth.occurrences.first() {
            format!(
                "the true equations contain `{}` ({} {:?})",
                w.coordinate.clone().unwrap_or_default(),
                w.object,
                w.index
            )
        } else if !r.ground_truth.undecided.is_empty() {
            format!(
                "the structured form cannot decide whether the equations contain {}",
                r.ground_truth.undecided.join(", ")
            )
        } else {
            "the kinematic equations still needed contain an eliminated coordinate".into()
        };
        return Err(WriteError::NotEliminated {
            choice: choice.to_string(),
            coordinates: eliminate.to_vec(),
            why,
        });
    }
    Ok(artefact.into_derivation()?)
}

/// Write the crate's files into a temporary directory beside `out` (hamel_model::files), then
/// move them into place: the whole directory at once when `out` is new or empty, else file by
/// file (each file whole). An interrupted or failed write leaves no partial file behind.
fn place(out: &Path, files: &[(String, String)]) -> Result<(), String> {
    let tmp = hamel_model::files::Temporary::beside(out);
    for (path, text) in files {
        let p = with_parent(&tmp.path().join(path))?;
        std::fs::write(&p, text).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
    }
    if out.exists() && std::fs::remove_dir(out).is_err() {
        // Not empty (--force): the generated files replace theirs, the others stay.
        for (path, _) in files {
            let p = with_parent(&out.join(path))?;
            std::fs::rename(tmp.path().join(path), &p)
                .map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        }
        return Ok(());
    }
    tmp.commit(out)
        .map_err(|e| format!("cannot write {}: {e}", out.display()))
}

/// `p`, once its directory exists.
fn with_parent(p: &Path) -> Result<std::path::PathBuf, String> {
    if let Some(dir) = p.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    Ok(p.to_path_buf())
}
