//! `hamel simulate` on a scene with `[ensemble]`: run the members on the compiled core with a
//! progress bar, export the core and its job for a scheduler, or merge the parts it wrote
//! (`hamel_run::ensemble`; docs/ensembles.md).

use std::path::Path;
use std::sync::Arc;

use hamel_model::ModelError;
use hamel_run::Loaded;
use hamel_run::ensemble::{EnsembleRun, Settings};
use hamel_run::members::Members;
use indicatif::{ProgressBar, ProgressStyle};

use crate::cli::{EnsembleArgs, TrajectoryFormat};
use crate::output::Output;

/// An error about how the command was called, naming the scene.
fn usage(scene: &Path, message: String) -> ModelError {
    ModelError::new(
        &scene.display().to_string(),
        Arc::new(String::new()),
        None,
        None,
        message,
    )
}

/// Refuse the ensemble options for a scene without `[ensemble]`.
pub fn refuse_options(scene: &Path, args: &EnsembleArgs) -> Result<(), ModelError> {
    let given = args.shard.is_some() || args.export_ensemble.is_some() || !args.merge.is_empty();
    if given || !args.animate_members.is_empty() {
        return Err(usage(
            scene,
            "--shard, --export-ensemble, --merge and --animate-members are for a scene with [ensemble]".into(),
        ));
    }
    Ok(())
}

/// Refuse the options of a single run for an ensemble.
pub fn refuse_single(
    scene: &Path,
    plot: bool,
    estimate_error: bool,
    interpreted: bool,
) -> Result<(), ModelError> {
    let refused = [
        (plot, "--plot"),
        (estimate_error, "--estimate-error"),
        (
            interpreted,
            "--engine interpreted (ensembles run on the compiled core)",
        ),
    ];
    match refused.iter().find(|(given, _)| *given) {
        Some((_, what)) => Err(usage(
            scene,
            format!("{what}: not for a scene with [ensemble]"),
        )),
        None => Ok(()),
    }
}

/// Run, export or merge the scene's ensemble and write one result (CSV or JSON lines); with
/// `animate`, the page of the chosen members too.
pub fn simulate(
    loaded: &Loaded,
    members: &Members,
    args: &EnsembleArgs,
    format: TrajectoryFormat,
    out: Output,
    animate: Option<&Path>,
) -> Result<(), ModelError> {
    if let (Some(page), Some(_)) = (animate, &args.export_ensemble) {
        let msg = "--animate with --export-ensemble: the members are not run here; animate the scene after merging";
        return Err(usage(page, msg.into()));
    }
    // The members shown are checked before anything runs.
    let chosen = animate
        .map(|_| hamel_run::animate::chosen_members(loaded, members, &args.animate_members))
        .transpose()?;
    if let Some(dir) = &args.export_ensemble {
        let n = loaded.export_ensemble(members, dir)?;
        eprintln!("{}", export_note(dir, n));
        return Ok(());
    }
    let run = if args.merge.is_empty() {
        run_with_bar(loaded, members, args)?
    } else {
        loaded.merge_ensemble(members, &read_parts(&args.merge)?)?
    };
    out.write(&match format {
        TrajectoryFormat::Csv => run.to_csv(),
        TrajectoryFormat::Json => run.to_json_lines(),
    })?;
    eprintln!("{}", run.summary());
    if let (Some(page), Some(chosen)) = (animate, chosen) {
        let shown = loaded.run_ensemble(&chosen.members, Settings::default(), &|_, _| {})?;
        let html = hamel_run::animate::ensemble_animation(loaded, &shown, &chosen)?.html();
        hamel_run::animate::write(page, &html)?;
    }
    Ok(())
}

/// Run the members on the core with a progress bar on stderr (drawn on a terminal only).
fn run_with_bar(
    loaded: &Loaded,
    members: &Members,
    args: &EnsembleArgs,
) -> Result<EnsembleRun, ModelError> {
    let settings = Settings {
        threads: args.threads,
        shard: args.shard.unwrap_or(hamel_sim::Shard::ALL),
    };
    let bar = ProgressBar::new(0).with_style(
        ProgressStyle::with_template(
            "{elapsed_precise} [{wide_bar}] {pos}/{len} members ({eta} left)",
        )
        .expect("valid template"),
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let run = loaded.run_ensemble(members, settings, &progress);
    bar.finish_and_clear();
    run
}

/// The parts' file names and texts.
fn read_parts(paths: &[std::path::PathBuf]) -> Result<Vec<(String, String)>, ModelError> {
    paths
        .iter()
        .map(|p| {
            let name = p.display().to_string();
            std::fs::read_to_string(p)
                .map(|text| (name.clone(), text))
                .map_err(|e| usage(p, format!("cannot read the part: {e}")))
        })
        .collect()
}

/// What to run next, for stderr.
fn export_note(dir: &Path, n: usize) -> String {
    let d = dir.display();
    format!(
        "wrote {d}/core and {d}/job.json ({n} members). Run task K of N (no computer algebra, no hamel needed):\n  {d}/core --job {d}/job.json --shard K/N --threads T --output {d}/part-K.jsonl\n(Slurm: sbatch --array=0-99 --wrap '{d}/core --job {d}/job.json --shard $SLURM_ARRAY_TASK_ID/100 --threads $SLURM_CPUS_PER_TASK --output {d}/part-$SLURM_ARRAY_TASK_ID.jsonl')\nthen gather them: hamel simulate SCENE --merge {d}/part-*.jsonl --output RESULT (docs/ensembles.md)"
    )
}
