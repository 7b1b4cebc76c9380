//! Ensembles: a scene run for each of many members (`[ensemble]`) on its compiled core.
//!
//! **Job**: turn each member ([`crate::members`]: values of coordinates, η and parameters on
//! top of the scene's) into an initial state as [`crate::load`] does for the scene (the
//! holonomic constraints completed, q̇ projected, the reference value of the dropped
//! coordinates), run them all on the scene's core — one process, a rayon pool of
//! [`hamel_sim::integrate_many`] inside it — and gather per member the requested outputs at
//! every output time or at the last one, with its statistics, or its failure.
//!
//! **Inputs**: a [`Loaded`] scene with `[ensemble]`, its [`Members`], the threads and the shard.
//! **Outputs**: an [`EnsembleRun`]: a [`Header`] and one [`MemberResult`] per member, written as
//! JSON lines or CSV.
//!
//! **Invariants**: only the compiled core runs on the pool, never the computer algebra; the
//! core is specialised for the parameters no member changes, and takes the others as inputs;
//! a member that cannot start or whose integration fails is reported with its index and reason
//! and the others are kept; the singular set is watched at each member's saved output states
//! as for a single run; results are in member order whatever the threads.

use std::path::Path;

use hamel_model::ModelError;
use hamel_sim::{MethodName, Shard};
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};

use crate::cache;
use crate::expressions::OutputExpression;
use crate::file::Save;
use crate::initial::initial_eta;
use crate::load::Loaded;
use crate::members::{Members, Source, Target};
use hamel_sim::job::{MemberAnswer, PART_FORMAT, PartHeader};

/// How an ensemble runs: the core's threads (0: one per core) and the shard of the members.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// Threads of the core's pool.
    pub threads: usize,
    /// The block of the members to run ([`Shard::ALL`] for every one).
    pub shard: Shard,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            threads: 0,
            shard: Shard::ALL,
        }
    }
}

/// The first line of a result file: what was run, and how much of it failed.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Header {
    /// The scene file.
    pub scene: String,
    /// The model and the quasi-velocity choice.
    pub model: String,
    pub eta: String,
    /// The integrator and its tolerances.
    pub method: MethodName,
    pub rtol: f64,
    pub atol: f64,
    /// Members in the whole ensemble, and the range of them in this file.
    pub members: usize,
    pub first: usize,
    pub end: usize,
    /// Members of this file that failed.
    pub failed: usize,
    /// What is kept of each member.
    pub save: Save,
    /// The names the members set (coordinates, `eta1`…, parameters).
    pub given: Vec<String>,
    /// The output names, in the order of each member's values.
    pub outputs: Vec<String>,
    /// Where the members come from.
    pub source: Source,
    /// The parameters the members vary (inputs of the core; the others are specialised).
    pub varying: Vec<String>,
    /// Threads of the core's pool, and the wall time of its loop over the members.
    pub threads: usize,
    pub seconds: f64,
}

/// One member's outcome.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MemberResult {
    /// Its index in the ensemble (from 0: the row of the members file, or the draw).
    pub member: usize,
    /// The member's own values (coordinates, `eta1`…, parameters), as given or drawn.
    pub given: IndexMap<String, f64>,
    /// Whether every output time was reached.
    pub complete: bool,
    /// The saved output times (the last one only with `save = "final"`).
    pub t: Vec<f64>,
    /// The requested outputs at those times, by name (null where a value cannot be computed).
    pub values: IndexMap<String, Vec<Option<f64>>>,
    /// Accepted and rejected steps, right-hand-side evaluations, drifts.
    pub steps: usize,
    pub rejected: usize,
    pub rhs_evals: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub energy_drift: Option<f64>,
    /// Why it stopped early or could not start.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Every coordinate at each saved time, when the state holds them all (a scene loaded
    /// with [`crate::LoadOptions::every_coordinate`]); not written.
    #[serde(skip)]
    pub configurations: Option<Vec<Vec<f64>>>,
}

/// An ensemble's results: the header and the members in order.
pub struct EnsembleRun {
    pub header: Header,
    pub members: Vec<MemberResult>,
}

/// A member made ready to run: its initial state (the plan's order, then η), parameter values,
/// reference value of the dropped coordinates, and δ there.
struct Start {
    y0: Vec<f64>,
    params: IndexMap<String, f64>,
    reference: f64,
    delta0: f64,
}

/// The members of a shard made ready for the core.
struct PreparedEnsemble {
    range: std::ops::Range<usize>,
    starts: Vec<Result<Start, String>>,
    /// The members (of the shard) that can start: those sent to the core, in order.
    ok: Vec<usize>,
    varying: Vec<String>,
    exe: std::path::PathBuf,
    job: cache::Job,
}

impl Loaded {
    /// The scene's members: read from `[ensemble] file` or drawn from `[ensemble.vary]`; None
    /// for a scene without `[ensemble]`.
    pub fn members(&self) -> Result<Option<Members>, ModelError> {
        let Some(spec) = &self.scene.ensemble else {
            return Ok(None);
        };
        let Some(file) = &spec.file else {
            return crate::members::draw(spec, &self.model)
                .map(Some)
                .map_err(|m| self.error("ensemble.vary", m));
        };
        let dir = std::path::Path::new(&self.file.name)
            .parent()
            .unwrap_or(std::path::Path::new("."));
        let path = dir.join(file);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            self.error(
                "ensemble.file",
                format!("cannot read the members file {}: {e}", path.display()),
            )
        })?;
        crate::members::read(&path.display().to_string(), &text, &self.model, spec.save).map(Some)
    }

    /// Run the members of `settings.shard` on the scene's compiled core with the scene's
    /// integrator (for an `[accuracy]` target, DOP853 at its tolerances, so that the job is the
    /// same whenever it is made again); `progress(done, total)` as members finish.
    pub fn run_ensemble(
        &self,
        members: &Members,
        settings: Settings,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<EnsembleRun, ModelError> {
        let prepared = self.prepare_ensemble(members, settings.shard)?;
        let (core, answers) = if prepared.job.members.is_empty() {
            (empty_part(&prepared.job), Vec::new())
        } else {
            let text =
                cache::run_ensemble(&prepared.exe, &prepared.job, settings.threads, progress)
                    .map_err(|e| self.core_error(e, "the ensemble's compiled core"))?;
            parse_core(&text).map_err(|why| self.core_answer(&prepared, why))?
        };
        self.gather(members, prepared, core, answers)
    }

    /// Write what a scheduler needs to run the ensemble without hamel: `dir/core` (the scene's
    /// compiled core, CAS-free) and `dir/job.json` (every member that can start). Each task
    /// runs `dir/core --job dir/job.json --shard K/N --output part-K.jsonl`, and
    /// [`Self::merge_ensemble`] gathers the parts. Returns the number of members in the job.
    pub fn export_ensemble(&self, members: &Members, dir: &Path) -> Result<usize, ModelError> {
        let prepared = self.prepare_ensemble(members, Shard::ALL)?;
        let io = |what: &str, e: std::io::Error| {
            ModelError::environment(format!("{}: cannot write {what}: {e}", dir.display()))
        };
        std::fs::create_dir_all(dir).map_err(|e| io("the directory", e))?;
        // Both files appear whole, or neither does.
        let tmp = |name: &str| dir.join(format!("{name}.tmp{}", std::process::id()));
        let (job, _) = prepared.job.to_text();
        let written = std::fs::write(tmp("job.json"), job)
            .and_then(|()| std::fs::copy(&prepared.exe, tmp("core")).map(|_| ()))
            .and_then(|()| std::fs::rename(tmp("core"), dir.join("core")))
            .and_then(|()| std::fs::rename(tmp("job.json"), dir.join("job.json")));
        if let Err(e) = written {
            let _ = std::fs::remove_file(tmp("job.json"));
            let _ = std::fs::remove_file(tmp("core"));
            return Err(io("the core and its job", e));
        }
        Ok(prepared.job.members.len())
    }

    /// The ensemble's result from the parts that the core wrote for
    /// [`Self::export_ensemble`]'s job (`parts`: (file name, text)), which must together hold
    /// every member once.
    pub fn merge_ensemble(
        &self,
        members: &Members,
        parts: &[(String, String)],
    ) -> Result<EnsembleRun, ModelError> {
        let prepared = self.prepare_ensemble(members, Shard::ALL)?;
        let (_, fingerprint) = prepared.job.to_text();
        let (core, answers) = merge_parts(parts, prepared.job.members.len(), &fingerprint)?;
        self.gather(members, prepared, core, answers)
    }

    /// The members of `shard` made ready: their starts, the parameters they vary, the core and
    /// its job (the members that can start).
    fn prepare_ensemble(
        &self,
        members: &Members,
        shard: Shard,
    ) -> Result<PreparedEnsemble, ModelError> {
        let range = shard.range(members.rows.len());
        let starts: Vec<Result<Start, String>> = members.rows[range.clone()]
            .iter()
            .map(|row| self.start_of(&members.columns, row))
            .collect();
        let varying = varying(&self.params, &starts);
        // The scene's integrator, or DOP853 at its [accuracy] tolerances: not the setting that
        // `hamel tradeoff` times fastest, which a merge on another day might not find again.
        let crate::check::Integration { method, options } = self.integrator;
        let fixed: IndexMap<String, f64> = (self.fixed().into_iter())
            .filter(|(k, _)| !varying.contains(k))
            .collect();
        let fail = |e: cache::CacheError| self.core_error(e, "the ensemble's compiled core");
        let trace = crate::traced::for_core(self.trace_start(&fixed));
        let entry =
            cache::prepare(&self.model, &self.d, &self.plan, &fixed, trace).map_err(fail)?;
        let exe = cache::binary(&entry).map_err(fail)?.path;
        let ok: Vec<usize> = (0..starts.len()).filter(|&i| starts[i].is_ok()).collect();
        let job = cache::Job {
            t0: self.scene.t0,
            times: self.times.clone(),
            y0: self.to_core(&self.y0),
            method,
            options,
            reference: self.reference,
            energy: self.request.energy,
            residual: self.request.constraint_residual,
            forces: false,
            repeat: 1,
            params: Default::default(),
            live: self.live.clone(),
            members: ok
                .iter()
                .map(|&i| self.core_member(starts[i].as_ref().expect("ok"), &varying))
                .collect(),
            save: members.save,
        };
        Ok(PreparedEnsemble {
            range,
            starts,
            ok,
            varying,
            exe,
            job,
        })
    }

    /// An unreadable answer of the core as an error.
    fn core_answer(&self, prepared: &PreparedEnsemble, why: String) -> ModelError {
        let e = cache::CacheError::Core {
            binary: prepared.exe.clone(),
            why,
        };
        self.core_error(e, "the ensemble's compiled core")
    }

    /// The results of the prepared members from the core's answers (in the job's order).
    fn gather(
        &self,
        members: &Members,
        prepared: PreparedEnsemble,
        core: PartHeader,
        answers: Vec<MemberAnswer>,
    ) -> Result<EnsembleRun, ModelError> {
        if answers.len() != prepared.ok.len()
            || answers.iter().enumerate().any(|(i, a)| a.member != i)
        {
            let why = format!(
                "{} answers for the {} members sent, or not in order",
                answers.len(),
                prepared.ok.len()
            );
            return Err(self.core_answer(&prepared, why));
        }
        let expressions = self
            .ensemble_expressions(&prepared.varying)
            .map_err(|(k, m)| self.error(&k, m))?;
        let mut answers = answers.into_iter();
        let results: Vec<MemberResult> = (prepared.starts.iter().enumerate())
            .map(|(i, start)| {
                let member = prepared.range.start + i;
                let mut result = match start {
                    Err(why) => failed_to_start(member, why),
                    Ok(start) => {
                        let a = answers.next().expect("one answer per member sent");
                        let v = &prepared.varying;
                        self.member_result(member, start, a, v, &expressions, members.save)
                    }
                };
                result.given = members.given(member);
                result
            })
            .collect();
        let header = Header {
            scene: self.file.name.clone(),
            model: self.d.model.clone(),
            eta: self.d.eta_name.clone(),
            method: prepared.job.method.name(),
            rtol: prepared.job.options.rtol,
            atol: prepared.job.options.atol,
            members: members.rows.len(),
            first: prepared.range.start,
            end: prepared.range.end,
            failed: results.iter().filter(|r| r.error.is_some()).count(),
            save: members.save,
            given: members.columns.iter().map(|(n, _)| n.clone()).collect(),
            outputs: self.output_names(),
            source: members.source.clone(),
            varying: prepared.varying,
            threads: core.threads,
            seconds: core.seconds,
        };
        Ok(EnsembleRun {
            header,
            members: results,
        })
    }

    /// A member's start: the scene's initial configuration, velocities and parameters with the
    /// member's values on top. Error: why it cannot start.
    fn start_of(&self, columns: &[(String, Target)], row: &[Option<f64>]) -> Result<Start, String> {
        let mut given = self.scene.initial.q.clone();
        let mut set = self.scene.parameters.clone();
        let mut eta_set = Vec::new();
        for ((name, target), v) in columns.iter().zip(row) {
            let Some(v) = *v else { continue };
            match target {
                Target::Coordinate(_) => {
                    given.insert(name.clone(), v);
                }
                Target::Eta(i) => eta_set.push((*i, v)),
                Target::Parameter(p) => {
                    set.insert(p.clone(), v);
                }
            }
        }
        let params = self
            .model
            .parameter_values(&set)
            .map_err(|e| e.to_string())?;
        let (q, _) = crate::check::configuration(&given, &self.model, &params)?;
        let numeric =
            hamel_model::NumericModel::new(&self.model, &params).map_err(|e| e.to_string())?;
        let (mut eta, _) =
            initial_eta(&self.scene.initial, &self.d, &numeric, &q).map_err(|(_, m)| m)?;
        for (i, v) in eta_set {
            eta[i] = v;
        }
        let (reference, delta0) =
            crate::load::start(&self.compiled, &self.plan, &q, &eta, &params)?;
        let y0 = self.state.iter().map(|&k| q[k]).chain(eta).collect();
        Ok(Start {
            y0,
            params,
            reference,
            delta0,
        })
    }

    /// The member as the core takes it.
    fn core_member(&self, start: &Start, varying: &[String]) -> cache::Member {
        cache::Member {
            y0: self.to_core(&start.y0),
            params: varying
                .iter()
                .map(|k| (k.clone(), start.params[k]))
                .collect(),
            reference: Some(start.reference),
        }
    }

    /// The names of the requested outputs, in the order of [`MemberResult::values`].
    fn output_names(&self) -> Vec<String> {
        let mut names: Vec<String> = (self.request.coordinates.iter())
            .map(|&k| self.d.coordinates[k.index()].clone())
            .collect();
        if self.request.eta {
            names.extend((1..=self.d.sigma).map(|i| format!("eta{i}")));
        }
        if self.request.energy {
            names.push("energy".into());
        }
        if self.request.constraint_residual {
            names.push("constraint_residual".into());
        }
        names.extend(self.expressions.iter().map(|e| e.name.clone()));
        names
    }

    /// The requested expressions with the varying parameters as inputs after (q, η).
    fn ensemble_expressions(
        &self,
        varying: &[String],
    ) -> Result<Vec<OutputExpression>, (String, String)> {
        (self.request.expressions.iter())
            .map(|&i| {
                self.parsed[i].specialised_over(
                    &self.params,
                    varying,
                    &crate::load::state_names(&self.d),
                )
            })
            .collect()
    }

    /// A member's result from the core's answer: the state back in the plan's order, the
    /// singular set watched, the requested outputs.
    fn member_result(
        &self,
        member: usize,
        start: &Start,
        mut a: MemberAnswer,
        varying: &[String],
        expressions: &[OutputExpression],
        save: Save,
    ) -> MemberResult {
        self.back_from_core(&mut a.solution);
        let (crossing, _) = self.watch_singular(&mut a.solution, &start.params, start.delta0);
        let s = &a.solution;
        let n = self.state.len();
        let mut values: IndexMap<String, Vec<Option<f64>>> = IndexMap::new();
        for &k in &self.request.coordinates {
            let i = self
                .state
                .iter()
                .position(|&s| s == k.index())
                .expect("requested ⊆ state");
            values.insert(
                self.d.coordinates[k.index()].clone(),
                s.y.component(i).map(Some).collect(),
            );
        }
        if self.request.eta {
            for i in 0..self.d.sigma {
                values.insert(
                    format!("eta{}", i + 1),
                    s.y.component(n + i).map(Some).collect(),
                );
            }
        }
        if self.request.energy {
            values.insert("energy".into(), s.energy.clone());
        }
        if self.request.constraint_residual {
            values.insert("constraint_residual".into(), s.constraint.clone());
        }
        let extra: Vec<f64> = varying.iter().map(|k| start.params[k]).collect();
        for e in expressions {
            let v = s.y.iter().map(|y| {
                let mut inputs = self.full_q(y);
                inputs.extend_from_slice(&y[n..]);
                inputs.extend_from_slice(&extra);
                e.tape
                    .eval::<f64>(&inputs)
                    .ok()
                    .map(|v| v[0])
                    .filter(|v| v.is_finite())
            });
            values.insert(e.name.clone(), v.collect());
        }
        let error = crossing.or(a.stopped.map(|s| s.to_string()));
        MemberResult {
            member,
            given: IndexMap::new(),
            complete: error.is_none() && s.complete,
            t: match save {
                Save::Final => s.t.last().copied().into_iter().collect(),
                Save::Outputs => s.t.clone(),
            },
            values,
            steps: s.stats.steps,
            rejected: s.stats.rejected,
            rhs_evals: s.stats.rhs_evals,
            energy_drift: s.stats.energy_drift,
            error,
            configurations: (n == self.d.ell).then(|| match save {
                Save::Final => {
                    s.y.iter()
                        .last()
                        .map(|y| self.full_q(y))
                        .into_iter()
                        .collect()
                }
                Save::Outputs => s.y.iter().map(|y| self.full_q(y)).collect(),
            }),
        }
    }
}

/// The parameters whose value differs between members that can start (in model order).
fn varying(params: &IndexMap<String, f64>, starts: &[Result<Start, String>]) -> Vec<String> {
    let mut ok = starts.iter().filter_map(|s| s.as_ref().ok());
    let Some(first) = ok.next() else {
        return Vec::new();
    };
    let mut differ: Vec<bool> = params
        .keys()
        .map(|k| first.params[k].to_bits() != params[k].to_bits())
        .collect();
    for s in ok {
        for (d, k) in differ.iter_mut().zip(params.keys()) {
            *d |= s.params[k].to_bits() != first.params[k].to_bits();
        }
    }
    params
        .keys()
        .zip(differ)
        .filter(|(_, d)| *d)
        .map(|(k, _)| k.clone())
        .collect()
}

/// A member that could not start.
fn failed_to_start(member: usize, why: &str) -> MemberResult {
    MemberResult {
        member,
        given: IndexMap::new(),
        complete: false,
        t: Vec::new(),
        values: IndexMap::new(),
        steps: 0,
        rejected: 0,
        rhs_evals: 0,
        energy_drift: None,
        error: Some(format!("cannot start: {why}")),
        configurations: None,
    }
}

/// The header of a part of no member (every member failed to start).
fn empty_part(job: &cache::Job) -> PartHeader {
    PartHeader {
        hamel_ensemble_part: PART_FORMAT,
        job: job.to_text().1,
        members: 0,
        first: 0,
        end: 0,
        state: Vec::new(),
        save: job.save,
        threads: 0,
        seconds: 0.0,
    }
}

/// The core's JSON lines: its header, then one answer per member sent.
fn parse_core(text: &str) -> Result<(PartHeader, Vec<MemberAnswer>), String> {
    let mut lines = text.lines();
    let first = lines.next().unwrap_or("");
    let format = serde_json::from_str::<serde_json::Value>(first)
        .ok()
        .and_then(|v| v.get("hamel_ensemble_part")?.as_u64());
    if format.is_some_and(|f| f != u64::from(PART_FORMAT)) {
        return Err(format!(
            "written in format {} of ensemble parts, this hamel reads format {PART_FORMAT}: run the part again with this hamel's core (export the ensemble again)",
            format.unwrap_or_default()
        ));
    }
    let header: PartHeader =
        serde_json::from_str(first).map_err(|e| format!("unreadable answer: {e}"))?;
    let answers = lines
        .filter(|l| !l.is_empty())
        .map(|l| serde_json::from_str(l).map_err(|e| format!("unreadable answer: {e}")))
        .collect::<Result<Vec<MemberAnswer>, String>>()?;
    Ok((header, answers))
}

/// The parts of an exported ensemble of `total` members put together (each computed for the
/// job with fingerprint `job`): each a core's JSON
/// lines for its block; together every member once. The threads are the largest part's and
/// the seconds the sum over the parts (the work, not the wall time of the whole).
fn merge_parts(
    parts: &[(String, String)],
    total: usize,
    job: &str,
) -> Result<(PartHeader, Vec<MemberAnswer>), ModelError> {
    let bad = |name: &str, why: String| ModelError::new(name, Default::default(), None, None, why);
    let mut blocks = Vec::new();
    for (name, text) in parts {
        let (h, answers) = parse_core(text).map_err(|why| bad(name, why))?;
        if h.job != job {
            return Err(bad(
                name,
                format!(
                    "computed for another job (fingerprint {}, this scene's job {job}): export the ensemble again (--export-ensemble) and run its parts",
                    if h.job.is_empty() { "none" } else { &h.job }
                ),
            ));
        }
        if h.members != total || answers.len() != h.end - h.first {
            return Err(bad(
                name,
                format!(
                    "not a part of this ensemble's job: it holds members {}..{} of {}, the job has {total}",
                    h.first, h.end, h.members
                ),
            ));
        }
        blocks.push((name, h, answers));
    }
    blocks.sort_by_key(|(_, h, _)| h.first);
    let mut next = 0;
    // Every part of one job has the job's state and save; the threads and seconds add up.
    let (state, save) = (blocks.first()).map_or((Vec::new(), Save::default()), |(_, h, _)| {
        (h.state.clone(), h.save)
    });
    let mut merged = PartHeader {
        hamel_ensemble_part: PART_FORMAT,
        threads: 0,
        seconds: 0.0,
        members: total,
        job: job.to_string(),
        first: 0,
        end: total,
        state,
        save,
    };
    let mut answers = Vec::with_capacity(total);
    for (name, h, a) in blocks {
        if h.first != next {
            let why = if h.first < next {
                "overlaps another part"
            } else {
                "leaves a gap before it"
            };
            return Err(bad(
                name,
                format!(
                    "members {}..{} {why} (expected {next} next)",
                    h.first, h.end
                ),
            ));
        }
        next = h.end;
        merged.threads = merged.threads.max(h.threads);
        merged.seconds += h.seconds;
        answers.extend(a);
    }
    if next != total {
        return Err(bad(
            &parts.last().map_or(String::new(), |p| p.0.clone()),
            format!("the parts hold members 0..{next} of {total}: the rest are missing"),
        ));
    }
    Ok((merged, answers))
}

impl EnsembleRun {
    /// JSON lines: the header, then one line per member.
    pub fn to_json_lines(&self) -> String {
        let mut o = serde_json::to_string(&self.header).expect("serialisable");
        for m in &self.members {
            o.push('\n');
            o.push_str(&serde_json::to_string(m).expect("serialisable"));
        }
        o.push('\n');
        o
    }

    /// CSV: one row per member and saved output time — `member, t`, the outputs, `complete,
    /// steps, rhs_evals, error` — and a member that could not start as one row without values.
    pub fn to_csv(&self) -> String {
        let mut o = String::from("member");
        let given = &self.header.given;
        for name in given {
            o.push_str(",given.");
            o.push_str(name);
        }
        o.push_str(",t");
        for name in &self.header.outputs {
            o.push(',');
            o.push_str(name);
        }
        o.push_str(",complete,steps,rhs_evals,error\n");
        let cell = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:e}"));
        for m in &self.members {
            let tail = format!(
                ",{},{},{},{}\n",
                m.complete,
                m.steps,
                m.rhs_evals,
                m.error.as_deref().map_or(String::new(), csv_quote)
            );
            let mut head = m.member.to_string();
            for name in given {
                head.push(',');
                head.push_str(&cell(m.given.get(name).copied()));
            }
            for (j, t) in m.t.iter().enumerate() {
                o.push_str(&format!("{head},{t:e}"));
                for name in &self.header.outputs {
                    o.push(',');
                    o.push_str(&cell(
                        m.values.get(name).and_then(|v| v.get(j).copied().flatten()),
                    ));
                }
                o.push_str(&tail);
            }
            if m.t.is_empty() {
                o.push_str(&format!("{head},"));
                o.push_str(&",".repeat(self.header.outputs.len()));
                o.push_str(&tail);
            }
        }
        o
    }

    /// One line for stderr.
    pub fn summary(&self) -> String {
        let h = &self.header;
        let first = self.members.iter().find_map(|m| {
            m.error
                .as_ref()
                .map(|e| format!("; first: member {}: {e}", m.member))
        });
        format!(
            "{} ({}), {}: {} members ({}..{} of {}) in {:.3} s on {} thread{} ({:.0} members/s), {} failed{}",
            h.model,
            h.eta,
            h.method,
            h.end - h.first,
            h.first,
            h.end,
            h.members,
            h.seconds,
            h.threads,
            if h.threads == 1 { "" } else { "s" },
            (h.end - h.first) as f64 / h.seconds.max(1e-9),
            h.failed,
            first.unwrap_or_default()
        )
    }
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
pub(crate) fn csv_quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
