//! A scene from Rust: load it, read its plan, simulate it, and measure the speed–accuracy
//! trade of the integrators — what `hamel plan`, `hamel simulate` and `hamel tradeoff` do.
//!
//! ```sh
//! cargo run --release --example scene            # the knife edge of section 3.1
//! cargo run --release --example scene -- scenes/chaplygin_sleigh.toml
//! ```
//!
//! The interpreted evaluator is used throughout, so nothing is compiled with cargo at run time;
//! pass `Engine::Compiled` to run the scene's generated, cached core instead.

use std::path::PathBuf;

use hamel_model::ModelError;
use hamel_run::Engine;
use hamel_run::tradeoff::{self, Range};

fn main() -> Result<(), ModelError> {
    let path = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("scenes/knife.toml"));

    // Load: the scene and its model are read and checked, the equations derived, the plan
    // made (exactly) and the initial state set up.
    let loaded = hamel_run::load(&path)?;
    let plan = &loaded.plan;
    println!(
        "{}: integrated {:?}, reconstructed {:?}, dropped {:?}",
        path.display(),
        plan.integrated,
        plan.reconstructed,
        plan.dropped
    );

    // Simulate with the scene's integrator.
    let hamel_run::simulate::Simulated {
        trajectory,
        failure,
        ..
    } = hamel_run::simulate::run_loaded(&loaded, Engine::Interpreted, false)?;
    if let Some(e) = failure {
        return Err(e);
    }
    let last = trajectory.t.len() - 1;
    for (name, values) in &trajectory.q {
        println!("{name}(t = {}) = {:.12}", trajectory.t[last], values[last]);
    }
    println!("{}", trajectory.summary());

    // Trade off: the adaptive explicit integrators over a range of tolerances against a tight
    // reference; the recommendation is the fastest setting that meets the scene's tolerances.
    let table = tradeoff::table(&loaded, Range::Adaptive, Engine::Interpreted)?;
    match table.recommended {
        Some(i) => println!(
            "fastest setting that meets the target: {}",
            table.rows[i].setting()
        ),
        None => println!("no adaptive setting meets the target"),
    }
    Ok(())
}
