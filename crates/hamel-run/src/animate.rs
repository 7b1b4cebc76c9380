//! `hamel simulate SCENE --animate FILE.html`: a scene's run as an animated page
//! ([`hamel_view`]): the model's bodies, wheels, blades and shapes posed at every output time,
//! the contacts' tracks, the requested outputs plotted beside, the requested contact forces
//! as arrows.
//!
//! **Inputs**: a scene loaded with [`crate::LoadOptions::every_coordinate`] (the poses need
//! whole configurations) and its run. **Output**: the page, written whole or not at all.
//! A model typed by hand (no bodies) gets its outputs plotted and a note in place of the 3D
//! view.

use std::path::Path;

use hamel_model::ModelError;
use hamel_view::{Animation, Drawing, Motion, Series};

use crate::ensemble::{EnsembleRun, MemberResult};
use crate::load::Loaded;
use crate::members::Members;
use crate::simulate::Simulated;
use crate::trajectory::Trajectory;

/// Check the page's path before any work is done: it ends in `.html` and a file can be
/// created beside it (so a bad path writes nothing and costs no simulation).
pub fn check(path: &Path) -> Result<(), ModelError> {
    let ext = path.extension().and_then(|e| e.to_str());
    if !matches!(ext, Some("html" | "htm")) {
        return Err(error(path, "the page's file must end in .html".into()));
    }
    let tmp = hamel_model::files::Temporary::beside(path);
    std::fs::write(tmp.path(), b"")
        .map_err(|e| error(path, format!("cannot write the page here: {e}")))
}

/// Write `page` to `path` whole (through a temporary file renamed into place).
pub fn write(path: &Path, page: &str) -> Result<(), ModelError> {
    hamel_model::files::write_whole(path, page.as_bytes())
        .map_err(|e| error(path, format!("cannot write the page: {e}")))
}

/// The page of a scene's run.
pub fn animation(loaded: &Loaded, run: &Simulated) -> Result<Animation, ModelError> {
    let traj = &run.trajectory;
    let model = &loaded.model;
    let subtitle = format!(
        "{} · {} · {} outputs{}",
        loaded.file.name,
        traj.method.as_str(),
        traj.t.len(),
        if traj.complete { "" } else { " (incomplete)" }
    );
    let series = series(traj);
    let Some(m) = model.mechanism.as_deref() else {
        let mut motion = Motion::outputs_only("", &traj.t);
        motion.series = series;
        return Ok(Animation {
            title: model.title.clone(),
            subtitle,
            drawing: None,
            note: Some(no_bodies(model)),
            members: vec![motion],
        });
    };
    let fail = |e: String| loaded.error("model", format!("cannot draw the model: {e}"));
    let q = run.configurations.as_ref().ok_or_else(|| {
        fail("the run does not hold every coordinate (load the scene with every_coordinate)".into())
    })?;
    let drawing = Drawing::of(m, &loaded.q0, &loaded.params).map_err(|e| fail(e.to_string()))?;
    let mut motion = Motion::place("", m, &drawing, &loaded.params, &traj.t, q)
        .map_err(|e| fail(e.to_string()))?;
    motion.series = series;
    motion
        .add_arrows(
            m,
            &drawing,
            &model.contact_forces,
            &loaded.params,
            q,
            &traj.forces,
        )
        .map_err(|e| fail(e.to_string()))?;
    Ok(Animation {
        title: model.title.clone(),
        subtitle,
        drawing: Some(drawing),
        note: None,
        members: vec![motion],
    })
}

/// The members an ensemble's page shows when none are chosen: the first four.
pub const DEFAULT_MEMBERS: usize = 4;

/// The members an ensemble's page shows.
pub struct Chosen {
    /// Them, every output time saved: what [`ensemble_animation`] needs run.
    pub members: Members,
    /// Their numbers in the whole ensemble.
    pub indices: Vec<usize>,
    /// The whole ensemble's size.
    pub of: usize,
}

/// The members of `members` at the indices `chosen` (the first [`DEFAULT_MEMBERS`] when
/// empty). Error: an index out of range, named.
pub fn chosen_members(
    loaded: &Loaded,
    members: &Members,
    chosen: &[usize],
) -> Result<Chosen, ModelError> {
    let n = members.rows.len();
    let chosen: Vec<usize> = if chosen.is_empty() {
        (0..n.min(DEFAULT_MEMBERS)).collect()
    } else {
        chosen.to_vec()
    };
    if let Some(bad) = chosen.iter().find(|&&i| i >= n) {
        let msg = format!(
            "--animate-members: the ensemble has {n} members (0 to {}); there is no member {bad}",
            n.saturating_sub(1)
        );
        return Err(loaded.error("ensemble", msg));
    }
    Ok(Chosen {
        members: Members {
            columns: members.columns.clone(),
            rows: chosen.iter().map(|&i| members.rows[i].clone()).collect(),
            source: members.source.clone(),
            save: hamel_sim::job::Save::Outputs,
        },
        indices: chosen,
        of: n,
    })
}

/// The page of an ensemble's `chosen` members, `run` their run: side by side or overlaid, at
/// the scene's parameters (a member's own parameter values move it but do not resize what is
/// drawn).
pub fn ensemble_animation(
    loaded: &Loaded,
    run: &EnsembleRun,
    chosen: &Chosen,
) -> Result<Animation, ModelError> {
    let indices = &chosen.indices;
    let model = &loaded.model;
    let h = &run.header;
    let subtitle = format!(
        "{} · {} · members {} of {}",
        h.scene,
        h.method.as_str(),
        indices
            .iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join(", "),
        chosen.of
    );
    let fail = |e: String| loaded.error("model", format!("cannot draw the model: {e}"));
    let drawing = match model.mechanism.as_deref() {
        Some(m) => {
            Some(Drawing::of(m, &loaded.q0, &loaded.params).map_err(|e| fail(e.to_string()))?)
        }
        None => None,
    };
    let mut motions = Vec::new();
    for (r, &index) in run.members.iter().zip(indices) {
        let label = member_label(index, r);
        let mut motion = match (model.mechanism.as_deref(), &drawing, &r.configurations) {
            (Some(m), Some(d), Some(q)) => Motion::place(&label, m, d, &loaded.params, &r.t, q)
                .map_err(|e| fail(e.to_string()))?,
            _ => Motion::outputs_only(&label, &r.t),
        };
        motion.series = (r.values.iter())
            .map(|(name, values)| Series {
                name: name.clone(),
                values: values.clone(),
            })
            .collect();
        motions.push(motion);
    }
    Ok(Animation {
        title: model.title.clone(),
        subtitle,
        note: drawing.is_none().then(|| no_bodies(model)),
        drawing,
        members: motions,
    })
}

/// `member 3 (theta = 0.12, eta2 = 9.8)`, or why it stopped.
fn member_label(index: usize, r: &MemberResult) -> String {
    let given: Vec<String> = r
        .given
        .iter()
        .map(|(k, v)| format!("{k} = {v:.4}"))
        .collect();
    let mut label = format!("member {index}");
    if !given.is_empty() {
        label.push_str(&format!(" ({})", given.join(", ")));
    }
    if let Some(e) = &r.error {
        label.push_str(&format!(": {e}"));
    }
    label
}

/// The note of a page whose model has no bodies.
fn no_bodies(model: &hamel_model::Model) -> String {
    format!(
        "The model `{}` is written by hand as L and α: it has no bodies, frames or wheels to draw. Its requested outputs are plotted beside; describe it by bodies and frames (docs/model-format.md) to see it move.",
        model.name
    )
}

/// The requested outputs, named as in the CSV.
fn series(traj: &Trajectory) -> Vec<Series> {
    let mut out: Vec<Series> = traj
        .q
        .iter()
        .map(|(name, v)| Series {
            name: name.clone(),
            values: v.iter().copied().map(Some).collect(),
        })
        .collect();
    let sigma = traj.eta.first().map_or(0, Vec::len);
    out.extend((0..sigma).map(|i| Series {
        name: format!("eta{}", i + 1),
        values: traj.eta.iter().map(|e| Some(e[i])).collect(),
    }));
    let optional = [
        ("energy", traj.energy.clone()),
        (
            "work",
            traj.work
                .as_ref()
                .map(|w| w.iter().copied().map(Some).collect()),
        ),
        ("constraint_residual", traj.constraint_residual.clone()),
    ];
    for (name, values) in optional {
        if let Some(values) = values {
            out.push(Series {
                name: name.into(),
                values,
            });
        }
    }
    for (name, values) in traj.expressions.iter().chain(&traj.forces) {
        out.push(Series {
            name: name.clone(),
            values: values.clone(),
        });
    }
    out
}

/// An error about the page's file.
fn error(path: &Path, message: String) -> ModelError {
    ModelError::new(
        &path.display().to_string(),
        Default::default(),
        None,
        None,
        message,
    )
}
