//! `eta = "auto"`: quasi-velocities chosen by the search for what a scene requests.

use hamel_model::{Model, ModelError};

/// `eta = "auto"`: the quasi-velocities that eliminate the coordinates the scene does not
/// request, as `hamel search` finds them (its first candidate without free functions, added to
/// the model as a choice); else, or when the scene requests every coordinate, the model's
/// first choice. stderr says which and why.
pub(crate) fn auto_choice(
    model: Model,
    request: Option<&[String]>,
    fresh: bool,
) -> Result<(Model, String), ModelError> {
    let first = model.choice(None)?.name.clone();
    let eliminate: Vec<String> = match request {
        Some(r) => model
            .coordinates
            .iter()
            .filter(|c| !r.contains(c))
            .cloned()
            .collect(),
        None => Vec::new(),
    };
    if eliminate.is_empty() {
        log::info!(
            "eta = auto: every coordinate is requested, nothing to eliminate: using the model's first choice `{first}`"
        );
        return Ok((model, first));
    }
    let options = hamel_reduce::SearchOptions {
        budget: std::time::Duration::from_secs(20),
        max_candidates: 10,
    };
    let path = std::path::Path::new(&model.file);
    let report = hamel_reduce::supervised::run_search(path, &model, &eliminate, options)
        .map_err(|e| e.locate(&model))?;
    // Candidates without free functions, in the search's order (simplest first); the first
    // whose map [Z; α] is regular everywhere wins, else the first.
    let usable: Vec<(Model, String, bool)> = report
        .candidates
        .iter()
        .filter(|c| c.free_functions.is_empty())
        .filter_map(|c| {
            let text = format!("{}\n{}\n", model.source, c.toml);
            let m = Model::from_source(&model.file, &text).ok()?;
            let d = derive(&m, &c.name, fresh).ok()?;
            let regular = d.closed().is_some_and(|c| c.singular_set.is_empty());
            Some((m, c.name.clone(), regular))
        })
        .collect();
    let pick = usable
        .iter()
        .position(|c| c.2)
        .or((!usable.is_empty()).then_some(0));
    match pick.map(|i| usable.into_iter().nth(i).expect("in range")) {
        Some((m, name, regular)) => {
            log::info!(
                "eta = auto: using `{name}` (found by search; it eliminates {} from the equations{})",
                eliminate.join(", "),
                if regular {
                    "; [Z; α] is regular everywhere"
                } else {
                    "; no candidate is regular everywhere: see its singular set with hamel derive"
                }
            );
            Ok((m, name))
        }
        None => {
            log::info!(
                "eta = auto: search found no quasi-velocities without free functions that eliminate {}: using the model's first choice `{first}`",
                eliminate.join(", ")
            );
            Ok((model, first))
        }
    }
}

/// A candidate's derivation, through the one pass and the store (made in the deriving worker
/// when the caller named one).
fn derive(
    model: &Model,
    choice: &str,
    fresh: bool,
) -> Result<hamel_derive::Derivation, hamel_reduce::ReduceError> {
    use hamel_reduce::pass::{Analysis, Job, obtain};
    let job = Job::new(model, Some(choice), Analysis::Equations)?;
    obtain(&job, fresh)?.into_derivation()
}
