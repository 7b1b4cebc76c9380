//! The command line: every subcommand and its options (clap). What each does is in
//! `main.rs`; the work itself is in the library crates.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

#[derive(Parser)]
#[command(
    name = "hamel",
    version,
    about = "Boltzmann–Hamel equations of nonholonomic systems: derive, reduce, generate code, simulate"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// Derive anew instead of reading the derivation store; the new derivation replaces the
    /// stored one (docs/design/derivation-store.md).
    #[arg(long, global = true)]
    pub no_store: bool,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum Format {
    Text,
    Json,
    Latex,
}

/// An object of `hamel derive --format latex`.
#[derive(Clone, Copy, ValueEnum)]
pub enum ObjectArg {
    /// The mass matrix A.
    A,
    /// The constraints α.
    Alpha,
    /// The matrix Z of the quasi-velocities.
    Z,
    /// The kinematic equations q̇ = Γη.
    Kinematics,
    /// A_Γ = ΓᵀAΓ.
    AGamma,
    /// The equations of motion.
    Equations,
}

impl From<ObjectArg> for hamel_print::derivation::Object {
    fn from(o: ObjectArg) -> Self {
        use hamel_print::derivation::Object;
        match o {
            ObjectArg::A => Object::A,
            ObjectArg::Alpha => Object::Alpha,
            ObjectArg::Z => Object::Z,
            ObjectArg::Kinematics => Object::Kinematics,
            ObjectArg::AGamma => Object::AGamma,
            ObjectArg::Equations => Object::Equations,
        }
    }
}

/// Which form of the equations `hamel derive` computes.
#[derive(Clone, Copy, ValueEnum)]
pub enum FormArg {
    /// The closed form when exact elimination of [Z; α] stays within its budget, else
    /// structured.
    Auto,
    /// The closed form (Γ, A_Γ, Q, … expanded), or an error when it is too large.
    Closed,
    /// The structured form: A, α, Z, U exact, the equations evaluated from them.
    Structured,
}

impl From<FormArg> for hamel_derive::FormRequest {
    fn from(f: FormArg) -> Self {
        match f {
            FormArg::Auto => hamel_derive::FormRequest::Auto,
            FormArg::Closed => hamel_derive::FormRequest::Closed,
            FormArg::Structured => hamel_derive::FormRequest::Structured,
        }
    }
}

/// Output of `hamel bench`.
#[derive(Clone, Copy, ValueEnum)]
pub enum TableFormat {
    /// A Markdown table.
    Markdown,
    Json,
}

/// Output of `hamel simulate`.
#[derive(Clone, Copy, ValueEnum)]
pub enum TrajectoryFormat {
    Csv,
    Json,
}

/// Output of `hamel reduce` and `hamel search`.
#[derive(Clone, Copy, ValueEnum)]
pub enum ReportFormat {
    Text,
    Json,
}

#[derive(Subcommand)]
pub enum Command {
    /// Derive the Boltzmann–Hamel equations of a model: Γ, Θ, δ, A_Γ, Q (true, paper's,
    /// correction), the equations, the kinematic equations, the energy and the singular set.
    Derive {
        /// The model file (TOML).
        model: PathBuf,
        /// The quasi-velocity choice (a `[quasi_velocities.NAME]` of the model; default: the first).
        #[arg(long)]
        eta: Option<String>,
        /// Output format. `latex` is a complete document (landscape A4) with the entries
        /// collected and factored and recurring groups named once.
        #[arg(long, value_enum, default_value = "text")]
        format: Format,
        /// With `--format latex`: the equation blocks alone, without the document around them.
        #[arg(long)]
        fragment: bool,
        /// With `--format latex`: one object alone, with the names it uses.
        #[arg(long, value_enum)]
        only: Option<ObjectArg>,
        /// Closed form (every object expanded and canonical) or structured form (the
        /// ingredients A, α, Z, U exact; for models too large to expand, such as the bicycle).
        #[arg(long, value_enum, default_value = "auto")]
        form: FormArg,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// Print a model in the hand-typed form: T as its mass matrix, U, the rows of α and the
    /// holonomic constraints. For a model of bodies, frames and wheels, this is what hamel
    /// derives from them; the output loads like any model file.
    Expand {
        /// The model file (TOML).
        model: PathBuf,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// Decide which coordinates drop out of the equations: classification (31), block structure
    /// (17)/(18), Properties 2.1–2.2, hypotheses H0–H6 with witnesses, the ground truth and the
    /// reduced system.
    Reduce {
        /// The model file (TOML).
        model: PathBuf,
        /// The quasi-velocity choice (default: the first).
        #[arg(long)]
        eta: Option<String>,
        /// Coordinates to eliminate, comma-separated (e.g. `x,y,theta`).
        #[arg(long, value_delimiter = ',', required = true)]
        eliminate: Vec<String>,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: ReportFormat,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// Write the equations as a standalone Rust crate (straight-line f64 code, an engine-free
    /// runtime, an `eval` binary): the full and, with --eliminate, the reduced system.
    Codegen {
        /// The model file (TOML).
        model: PathBuf,
        /// The quasi-velocity choice (default: the first).
        #[arg(long)]
        eta: Option<String>,
        /// Coordinates to eliminate (checked exactly, as `hamel reduce` does).
        #[arg(long, value_delimiter = ',')]
        eliminate: Vec<String>,
        /// Directory of the crate to write.
        #[arg(long)]
        out: PathBuf,
        /// Overwrite the generated files of a non-empty directory.
        #[arg(long)]
        force: bool,
        /// Also write a `simulate` binary (vendors the integrators into the crate).
        #[arg(long)]
        with_simulator: bool,
    },
    /// Integrate a scene (model, quasi-velocities, parameters, initial state, integrator) and
    /// write the trajectory; a one-line summary goes to stderr.
    Simulate(SimulateArgs),
    /// Plan a scene: from the outputs it requests, which coordinates are integrated,
    /// reconstructed or dropped, and the operation count of the right-hand side (all decided
    /// exactly).
    Plan {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: ReportFormat,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
        /// Also measure the plan: integrate the scene on its compiled core and the full
        /// unreduced system (every coordinate, parameters not specialised) on its own compiled
        /// core with the same integrator, and report both times and the largest difference
        /// of the requested outputs.
        #[arg(long)]
        measure: bool,
        /// Set a parameter or input (repeatable), on top of the scene's `[parameters]`;
        /// derived parameters are evaluated again from it.
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
        set: Vec<(String, f64)>,
    },
    /// Measure the speed–accuracy trade on a scene: every integrator over a range of
    /// tolerances and fixed steps against a DOP853 reference at 1e-14; error on the requested
    /// outputs, time, RHS evaluations, drifts; the fastest setting that meets the target.
    Tradeoff {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: ReportFormat,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
        /// Also draw the work–precision diagram (FILE.svg or FILE.png).
        #[arg(long)]
        plot: Option<PathBuf>,
        /// Instead, write the planned system as Python with the reference solution and hamel's
        /// adaptive runs, for `bench/scipy_tradeoff.py` (JSON).
        #[arg(long, conflicts_with_all = ["plot", "format"])]
        export_python: Option<PathBuf>,
        /// What the timed runs evaluate: the scene's compiled core (as `hamel simulate` runs
        /// it; the interpreted evaluator, with a warning, when it cannot be built) or the
        /// interpreted evaluator.
        #[arg(long, value_enum, default_value = "compiled")]
        engine: EngineArg,
        /// Time each setting for this many seconds: a shorter run is repeated and the median
        /// taken (0: one run each, a quick table whose times are coarse).
        #[arg(long, value_name = "SECONDS", default_value = "0.05", value_parser = parse_timing)]
        min_time: hamel_run::tradeoff::Timing,
        /// Set a parameter or input (repeatable), on top of the scene's `[parameters]`;
        /// derived parameters are evaluated again from it.
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
        set: Vec<(String, f64)>,
    },
    /// Search for quasi-velocities that eliminate the given coordinates from the true
    /// equations: A-orthogonal choices, a finite ansatz, and unknown functions.
    Search(SearchArgs),
    /// The worker process of `hamel search` (internal: its output is a protocol).
    #[command(hide = true)]
    SearchWorker {
        model: PathBuf,
        #[arg(long, value_delimiter = ',', required = true)]
        eliminate: Vec<String>,
        #[arg(long)]
        budget: f64,
        #[arg(long)]
        max: usize,
    },
    /// The worker process that derives for the other commands (internal: the job on stdin,
    /// the result written to RESULT; its exit gives the computer algebra's thread back).
    #[command(hide = true)]
    DeriveWorker { result: PathBuf },
    /// The derivation store: list its entries, or clear it.
    Store {
        #[command(subcommand)]
        action: StoreAction,
    },
    /// Evaluate the derived equations at states given as JSON: η̇ (true and paper's), q̇, energy.
    Eval {
        /// The model file (TOML).
        model: PathBuf,
        /// The quasi-velocity choice (default: the first).
        #[arg(long)]
        eta: Option<String>,
        /// JSON file with one state object or a list of them (`-` for stdin):
        /// {"q": {"x": 0.1, …}, "eta": [1.0, 0.5], "params": {"m": 2.0}, "functions": {"z13": "…"}}.
        #[arg(long)]
        state: String,
        /// Write the result to this file instead of stdout.
        #[arg(long)]
        output: Option<PathBuf>,
        /// Set a parameter or input for every state (repeatable; a state's own `params` win);
        /// derived parameters are evaluated again from it.
        #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
        set: Vec<(String, f64)>,
    },
    /// Linearise the reduced equations about a steady motion (`[steady.NAME]` of the model):
    /// the linear equations (M q'' + C q' + K q = B u where the state allows it), the
    /// eigenvalues with the structural zeros apart; with --sweep, the eigenvalues along a
    /// parameter and the values where stability changes; with two, a stability map.
    Linearize(LinearizeArgs),
    /// Time the derivation of every model and choice; with --sympy, SymPy does the same
    /// derivation in the same run as the baseline (bench/sympy_derive.py).
    Bench(BenchArgs),
}

/// What `hamel store` does.
#[derive(Clone, Copy, Subcommand)]
pub enum StoreAction {
    /// List the stored derivations: the model, the choice, the purpose, the size, the age.
    Ls,
    /// Remove every stored derivation.
    Clear,
}

/// What evaluates the right-hand side (`hamel_run::Engine`).
#[derive(Clone, Copy, ValueEnum)]
pub enum EngineArg {
    /// The scene's generated core, compiled and cached.
    Compiled,
    /// The structured evaluator of the derivation (a tape interpreter).
    Interpreted,
}

impl From<EngineArg> for hamel_run::Engine {
    fn from(e: EngineArg) -> Self {
        match e {
            EngineArg::Compiled => hamel_run::Engine::Compiled,
            EngineArg::Interpreted => hamel_run::Engine::Interpreted,
        }
    }
}

/// The options of `hamel bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Model files (default: every models/*.toml).
    pub models: Vec<PathBuf>,
    /// Derivations per model and choice, at least (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub repeat: usize,
    /// Keep deriving each model and choice until this many seconds have been spent on it
    /// (derivations and printings), so that a fast one is timed many times (0: exactly
    /// --repeat times).
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0, value_parser = parse_min_time)]
    pub min_time: f64,
    /// Also run the SymPy baseline (needs python3 with sympy).
    #[arg(long)]
    pub sympy: bool,
    /// Time limit for each SymPy derivation, seconds.
    #[arg(long, default_value_t = 300.0)]
    pub timeout: f64,
    /// Output format.
    #[arg(long, value_enum, default_value = "markdown")]
    pub format: TableFormat,
    /// Write the result to this file instead of stdout.
    #[arg(long)]
    pub output: Option<PathBuf>,
}

/// The options of `hamel simulate`.
#[derive(Args)]
pub struct SimulateArgs {
    /// The scene file (TOML); its `model` path is relative to it.
    pub scene: PathBuf,
    /// Output format.
    #[arg(long, value_enum, default_value = "csv")]
    pub format: TrajectoryFormat,
    /// Write the trajectory to this file instead of stdout.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Also draw the coordinates and quasi-velocities against time (FILE.svg or FILE.png).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Also write the run as an animated 3D page (FILE.html, self-contained, opens offline):
    /// the bodies, wheels and blades posed at every output time, the contacts' tracks, the
    /// requested outputs plotted, requested contact forces as arrows. Every coordinate is
    /// integrated for it.
    #[arg(long, value_name = "FILE.html")]
    pub animate: Option<PathBuf>,
    /// `compiled`: the scene's generated core, specialised for its parameters, built with
    /// cargo on first use and cached (falls back to `interpreted`, with a warning, when it
    /// cannot be built); `interpreted`: the structured evaluator, nothing compiled.
    #[arg(long, value_enum, default_value = "compiled")]
    pub engine: EngineArg,
    /// Estimate the global error on the requested outputs with a check run (1/1000 of the
    /// tolerances, or half the step) and report it (stderr, and `stats.error_estimate`).
    /// Done without asking when a tolerance is loose (≥ 1e-3).
    #[arg(long)]
    pub estimate_error: bool,
    /// Set a parameter or input (repeatable), on top of the scene's `[parameters]`;
    /// derived parameters are evaluated again from it.
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    pub set: Vec<(String, f64)>,
    #[command(flatten)]
    pub ensemble: EnsembleArgs,
}

/// The options of `hamel linearize`.
#[derive(Args)]
pub struct LinearizeArgs {
    /// The model file (TOML).
    pub model: PathBuf,
    /// The steady motion (a `[steady.NAME]` of the model).
    #[arg(long)]
    pub steady: String,
    /// The quasi-velocity choice (default: the first).
    #[arg(long)]
    pub eta: Option<String>,
    /// Sweep a steady or model parameter: P=START:STOP:COUNT (twice for a map).
    #[arg(long = "sweep", value_name = "P=START:STOP:COUNT", value_parser = hamel_study::Range::parse)]
    pub sweep: Vec<hamel_study::Range>,
    /// Set a steady parameter, a model parameter or an input (repeatable); derived
    /// parameters are evaluated again from it.
    #[arg(long = "set", value_name = "NAME=VALUE", value_parser = parse_set)]
    pub set: Vec<(String, f64)>,
    /// Output format.
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
    /// Write the result to this file instead of stdout.
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Draw the sweep (real and imaginary parts against the parameter) or the map (heat
    /// map of the largest real part) as SVG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Threads for the points of a sweep or map (default: every core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also write the study after its symbolic pass to this file (JSON), for the
    /// `hamel-sweep` worker, which runs sweeps and maps without the computer algebra.
    #[arg(long)]
    pub export: Option<PathBuf>,
    /// Also the LQR gain K (u = u* − K(x − x*)) from the continuous algebraic Riccati
    /// equation for the reduced state and the inputs, weights from --weight (at a point only).
    #[arg(long)]
    pub lqr: bool,
    /// A weight of the LQR: a component of the reduced state (diagonal of Q, default 1) or
    /// an input (diagonal of R, default 1); repeatable.
    #[arg(long = "weight", value_name = "NAME=VALUE", value_parser = parse_set, requires = "lqr")]
    pub weight: Vec<(String, f64)>,
    /// An input the LQR drives (repeatable; default: every input of the model); the others
    /// keep their values.
    #[arg(long = "lqr-input", value_name = "NAME", requires = "lqr")]
    pub lqr_input: Vec<String>,
}

/// `hamel search`.
#[derive(Args)]
pub struct SearchArgs {
    /// The model file (TOML).
    pub model: PathBuf,
    /// Coordinates to eliminate, comma-separated.
    #[arg(long, value_delimiter = ',', required = true)]
    pub eliminate: Vec<String>,
    /// Time budget in seconds for the whole command: it returns within the budget plus
    /// about a second, with what it found and why it stopped (an exact check under way at
    /// the deadline is abandoned, and named).
    #[arg(long, default_value_t = 60.0)]
    pub budget: f64,
    /// Most reducing choices to collect from the finite ansatz.
    #[arg(long, default_value_t = 12)]
    pub max: usize,
    /// Progress on stderr.
    #[arg(long, value_enum, default_value = "auto")]
    pub progress: crate::search::ProgressMode,
    /// Output format.
    #[arg(long, value_enum, default_value = "text")]
    pub format: ReportFormat,
    /// Write the result to this file instead of stdout.
    #[arg(long)]
    pub output: Option<PathBuf>,
}

/// `NAME=VALUE` of `--set`: a name and a finite number.
/// How a scene with `[ensemble]` runs (docs/ensembles.md).
#[derive(clap::Args, Debug)]
pub struct EnsembleArgs {
    /// Ensembles: threads of the compiled core's pool (default: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Ensembles: run only the K-th of N contiguous blocks of the members (K from 0).
    #[arg(long, value_name = "K/N")]
    pub shard: Option<hamel_sim::Shard>,
    /// Ensembles: write the compiled core and its job to DIR for a scheduler (Slurm job
    /// arrays, Ray) instead of running them; the parts are gathered with `--merge`.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["shard", "merge"])]
    pub export_ensemble: Option<PathBuf>,
    /// Ensembles: gather the parts that the exported core wrote (`--output` of each task)
    /// into one result.
    #[arg(long, value_name = "PART", num_args = 1.., conflicts_with = "shard")]
    pub merge: Vec<PathBuf>,
    /// Ensembles: the members `--animate` shows, side by side or overlaid (default: the first
    /// four); they are run again, every output time kept.
    #[arg(
        long,
        value_name = "I,J,…",
        value_delimiter = ',',
        requires = "animate"
    )]
    pub animate_members: Vec<usize>,
}

/// `--min-time`: seconds, from 0 to 600 (a bound on how long one model and choice is timed).
fn parse_min_time(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(t) if (0.0..=600.0).contains(&t) => Ok(t),
        Ok(_) => Err(format!("`{s}` is not between 0 and 600 seconds")),
        Err(_) => Err(format!("`{s}` is not a number of seconds")),
    }
}

/// `hamel tradeoff --min-time`: seconds per setting ([`hamel_run::tradeoff::Timing::from_secs`]).
fn parse_timing(s: &str) -> Result<hamel_run::tradeoff::Timing, String> {
    use hamel_run::tradeoff::Timing;
    let seconds = s
        .parse::<f64>()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    Timing::from_secs(seconds)
        .ok_or_else(|| format!("`{s}` is not between 0 and {} seconds", Timing::MAX_SECONDS))
}

fn parse_set(s: &str) -> Result<(String, f64), String> {
    hamel_model::parse_assignment(s)
}
