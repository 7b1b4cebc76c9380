//! `hamel plan --measure`: the planned computation against the full unreduced system, both on
//! compiled cores.

use crate::integrate::Timed;
use hamel_model::ModelError;
use hamel_sim::MethodName;
use indexmap::IndexMap;
use serde::Serialize;

use crate::cache;
use crate::load::Loaded;

/// `hamel plan --measure`: the planned computation against the full unreduced system.
#[derive(Debug, Serialize)]
pub struct Measured {
    /// The integrator both ran.
    pub method: MethodName,
    /// States integrated: planned, full.
    pub states: (usize, usize),
    /// Operations of the right-hand side: planned (specialised), full (parameters as inputs).
    pub ops: (usize, usize),
    /// Median time of one integration, seconds: planned, full (measured inside each core).
    pub seconds: (f64, f64),
    /// Right-hand side evaluations: planned, full.
    pub rhs_evals: (usize, usize),
    /// Full time over planned time.
    pub speedup: f64,
    /// The largest difference of the requested outputs between the two runs, relative to
    /// max(1, |value|).
    pub max_difference: f64,
}

impl Measured {
    /// The measurement as text.
    pub fn to_text(&self) -> String {
        format!(
            "measured ({}): planned {} states, {} operations, {:.3e} s, {} RHS evaluations; full {} states, {} operations, {:.3e} s, {} RHS evaluations; full / planned = {:.2}x; largest difference of the requested outputs {:.1e}\n",
            self.method,
            self.states.0,
            self.ops.0,
            self.seconds.0,
            self.rhs_evals.0,
            self.states.1,
            self.ops.1,
            self.seconds.1,
            self.rhs_evals.1,
            self.speedup,
            self.max_difference
        )
    }
}

/// Integrate a scene on its compiled core and the full unreduced system (every coordinate,
/// η; parameters not specialised, set at run time) on its own compiled core, both with the
/// scene's integrator (DOP853 at the `[accuracy]` tolerances when it gives only a target),
/// each repeated until it has run about 0.3 s; the median times and the outputs' agreement.
pub fn measure_plan(loaded: &Loaded) -> Result<Measured, ModelError> {
    let crate::check::Integration { method, options } = loaded.integrator;
    let fail = |e: cache::CacheError| loaded.core_error(e, "");
    let repeats = |seconds: f64| ((0.3 / seconds.max(1e-9)) as usize).clamp(3, 10_000);
    let Timed {
        run: probe,
        seconds: first,
    } = (loaded.integrate_compiled(method, &options, 1)).map_err(fail)?;
    if let Some(e) = probe.failure {
        return Err(e);
    }
    let Timed {
        run: planned,
        seconds: planned_seconds,
    } = (loaded.integrate_compiled(method, &options, repeats(first))).map_err(fail)?;
    let planned_core = loaded.core().map_err(fail)?;
    let ops = (planned_core.meta.ops, planned_core.meta.ops_full);
    // The full system's core: nothing dropped, nothing specialised.
    let model = &loaded.model;
    let d = &loaded.d;
    let none = IndexMap::new();
    let key = cache::Key::new(
        model,
        &d.eta_name,
        &[],
        &none,
        &cache::Build::current().map_err(fail)?,
    );
    let command = format!(
        "hamel plan --measure (full system of {}, {})",
        model.file, d.eta_name
    );
    let entry = cache::cached(&key, || {
        let untraced = Err("the full system with its parameters as inputs".to_string());
        cache::store(
            &key,
            (d, untraced),
            &none,
            &[],
            |_| Ok(ops.1),
            ops.1,
            &command,
        )
    })
    .map_err(fail)?;
    let exe = cache::binary(&entry).map_err(fail)?.path;
    let full_job = |repeat: usize| cache::Job {
        t0: loaded.scene.t0,
        times: loaded.times.clone(),
        y0: loaded
            .q0
            .iter()
            .chain(&loaded.y0[loaded.state.len()..])
            .copied()
            .collect(),
        method,
        options,
        reference: 0.0,
        energy: loaded.request.energy,
        residual: loaded.request.constraint_residual,
        forces: false,
        repeat,
        params: loaded.fixed().into_iter().collect(),
        live: loaded.live.clone(),
        members: Vec::new(),
        save: Default::default(),
    };
    let first_full = cache::run(&exe, &full_job(1)).map_err(fail)?.seconds;
    let cache::Answer {
        solution: full,
        stopped,
        seconds: full_seconds,
        ..
    } = cache::run(&exe, &full_job(repeats(first_full))).map_err(fail)?;
    if let Some(e) = stopped {
        return Err(loaded.error("integrator", format!("the full system's run failed: {e}")));
    }
    let p = &planned.solution;
    let n = loaded.state.len();
    let mut max_difference = 0.0_f64;
    for (yp, yf) in p.y.iter().zip(&full.y) {
        let pairs = loaded
            .request
            .coordinates
            .iter()
            .map(|&k| {
                (
                    loaded
                        .state
                        .iter()
                        .position(|&s| s == k.index())
                        .expect("requested ⊆ state"),
                    k.index(),
                )
            })
            .chain((0..d.sigma).map(|i| (n + i, d.ell + i)));
        for (i, j) in pairs {
            max_difference = max_difference.max((yp[i] - yf[j]).abs() / yf[j].abs().max(1.0));
        }
    }
    if p.y.len() != full.y.len() {
        max_difference = f64::INFINITY;
    }
    Ok(Measured {
        method: method.name(),
        states: (n + d.sigma, d.ell + d.sigma),
        ops,
        seconds: (planned_seconds, full_seconds),
        rhs_evals: (p.stats.rhs_evals, full.stats.rhs_evals),
        speedup: full_seconds / planned_seconds,
        max_difference,
    })
}
