//! `scene`: the integration jobs of `hamel simulate`, run on this compiled core.
//!
//! `scene [--job FILE] [--threads N] [--shard K/N] [--output FILE] [--progress]`
//!
//! Reads one [`Job`] (JSON, from FILE or stdin; the protocol's types are
//! `vendor/hamel-sim/src/job.rs`, shared with hamel): `y0` is the reduced state (the kept
//! coordinates in model order, then η), `reference` the value at which the eliminated
//! coordinates are held when the energy needs a full configuration (the equations are free of
//! them), and `repeat` how many times to integrate for timing. Writes an [`Answer`]: the
//! solution of the last run (the part computed before a failure, if any), why it stopped, and
//! the median wall time of one integration; with `"forces": true`, also every
//! [`CONSTRAINT_FORCES`](hamel_generated::CONSTRAINT_FORCES) component at each output time (null where they cannot be computed,
//! and why at the first such time). The parameters are those the core was generated with (a
//! scene's core is specialised for them) with `params` set on top. `live` says what sets each
//! of the core's [`LIVE`] parameters at every evaluation, in their order.
//!
//! A job with `members` is an **ensemble**: every member (or, with `--shard K/N`, the K-th of
//! N contiguous blocks of them, K from 0) is integrated on a pool of `--threads` threads
//! (default: one per core), and one [`MemberAnswer`] line is written per member in member
//! order (with `"save": "final"`, the solution holds the last output only), after a
//! [`PartHeader`] line that describes the part (`job`: the fingerprint of the job's text).
//! `--progress` prints `progress DONE TOTAL SECONDS` on stderr as members finish. The result
//! is written whole (to a temporary file renamed to `--output`), or not at all.
//!
//! A job refused or not finished exits with status 2 and writes the [`JobError`] on stderr,
//! for a person and (on its `hamel-core-error:` line) as JSON for hamel.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use hamel_generated::{
    fast, forces, runtime, reduced_with, DIMS, constraint_forces, ELIMINATED, HAS_FORCES, HOLONOMIC, HOLONOMIC_USES, KEPT, LIVE, Parameters, Prepared, REDUCED_DIM, SERIES_DIM,
    REDUCED_STATE, energy, energy_many, power, project, reduced_into_live, reduced_jacobian_live,
    reduced_series, residual_max, residual_max_many,
};
use hamel_sim::job::{Answer, ForcesFailure, Job, JobError, Member, MemberAnswer, PART_FORMAT, PartHeader, Progress, Save, Stopped};
use hamel_generated::runtime::{Scalar, Traced};
use hamel_sim::{Ensemble, Live, OdeSystem, Shard, Solution, States, SystemError, integrate_many, live_values};

struct Reduced {
    prep: Prepared,
    /// What sets the [`LIVE`] parameters (as many).
    live: Vec<Live>,
    reference: f64,
    energy: bool,
    residual: bool,
    /// Series traced at run time, not compiled ([`hamel_sim::Stats::series_traced`]).
    series_traced: AtomicUsize,
}

impl Reduced {
    /// The parameters at time `t`: the prepared ones with the [`LIVE`] ones set.
    #[inline(always)]
    fn at(&self, t: f64) -> Result<Parameters, SystemError> {
        let mut p = self.prep.p;
        if !LIVE.is_empty() {
            let mut values = [0.0; LIVE.len()];
            live_values(&self.live, t, &mut values)?;
            p.set_live(&values);
        }
        Ok(p)
    }

    /// The full configuration: the kept coordinates from the state, the eliminated ones at
    /// the reference value.
    fn full_q<S: Scalar>(&self, y: &[S]) -> [S; DIMS.ell] {
        let mut q = [S::constant(self.reference); DIMS.ell];
        for (i, &k) in KEPT.iter().enumerate() {
            q[k] = y[i];
        }
        q
    }

    /// The full states (q, η) of states of this system, one after another: `rows` itself
    /// when the state is (q, η), every coordinate kept in its order.
    fn full_rows<'a>(&self, rows: &'a [f64]) -> std::borrow::Cow<'a, [f64]> {
        if KEPT.len() == DIMS.ell && KEPT.iter().enumerate().all(|(i, &k)| i == k) {
            return rows.into();
        }
        let mut full = Vec::with_capacity(rows.len() / REDUCED_DIM * (DIMS.ell + DIMS.sigma));
        for y in rows.chunks_exact(REDUCED_DIM) {
            full.extend(self.full_q(y));
            full.extend(&y[KEPT.len()..]);
        }
        full.into()
    }
}

impl OdeSystem for Reduced {
    fn dim(&self) -> usize {
        REDUCED_DIM
    }
    fn rhs(&self, t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
        reduced_into_live(y, dy, &self.at(t)?, &self.prep).map_err(|e| SystemError::new(e.to_string()))
    }
    fn energy(&self, _t: f64, y: &[f64]) -> Option<f64> {
        if !self.energy {
            return None;
        }
        energy(&self.full_q(y), &y[KEPT.len()..], &self.prep.p).ok()
    }
    /// With the energy requested, forces that do work are integrated beside the state.
    fn does_work(&self) -> bool {
        self.energy && HAS_FORCES
    }
    fn power(&self, t: f64, y: &[f64]) -> Result<f64, SystemError> {
        power(&self.full_q(y), &y[KEPT.len()..], &self.at(t)?).map_err(|e| SystemError::new(e.to_string()))
    }
    /// ‖α(q)q̇‖∞; requested, every coordinate is in the state (nothing eliminated).
    fn constraint_residual(&self, _t: f64, y: &[f64]) -> Option<f64> {
        if !self.residual || !ELIMINATED.is_empty() {
            return None;
        }
        residual_max(&self.full_q(y), &y[KEPT.len()..], &self.prep.p).ok()
    }
    /// Four outputs at a time (`energy_many`); the default of None when not requested.
    fn energies(&self, _t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        if self.energy {
            energy_many(&self.full_rows(rows), &self.prep.p, out);
        }
    }
    /// Four outputs at a time (`residual_max_many`), as [`Self::constraint_residual`].
    fn constraint_residuals(&self, _t: &[f64], rows: &[f64], out: &mut [Option<f64>]) {
        if self.residual && ELIMINATED.is_empty() {
            residual_max_many(&self.full_rows(rows), &self.prep.p, out);
        }
    }
    /// Back onto the holonomic constraints, when the state holds every coordinate they
    /// mention (their dependent coordinates among them).
    fn project(&self, _t: f64, y: &mut [f64]) -> Option<Result<f64, SystemError>> {
        if HOLONOMIC == 0 || !HOLONOMIC_USES.iter().all(|k| KEPT.contains(k)) {
            return None;
        }
        let mut q = self.full_q(y);
        Some(
            project(&mut q, &self.prep.p)
                .map(|before| {
                    for (i, &k) in KEPT.iter().enumerate() {
                        y[i] = q[k];
                    }
                    before
                })
                .map_err(|e| SystemError::new(format!("projection onto the holonomic constraints: {e}"))),
        )
    }
    /// The solution's series for the Taylor method: by the recurrences compiled from the
    /// closed form or the scene's trace ([`reduced_series`], which checks the closed form's
    /// tests or the trace's guards at the state); else
    /// the reduced right-hand side traced once and the recurrences run over it
    /// ([`runtime::taylor_by_trace`]), as for a state that carries the forces' work.
    /// Parameters that change with time give none.
    fn taylor_coefficients(&self, t: f64, y: &[f64], order: usize, out: &mut Vec<f64>) -> Option<Result<(), SystemError>> {
        if !LIVE.is_empty() {
            return Some(Err(SystemError::new("the Taylor method needs parameters constant in time; this scene sets some at every step")));
        }
        if y.len() == SERIES_DIM {
            // the closed form's definiteness tests at coefficient 0; whether the series is
            // finite, the driver checks
            if let Some(series) = reduced_series(y, &self.prep, order, out) {
                return Some(series.map_err(|e| SystemError::new(format!("at t = {t}: {e}"))));
            }
        }
        self.series_traced.fetch_add(1, Ordering::Relaxed);
        // with the forces' work W appended (does_work), its rate the power q̇ᵀF
        let series = runtime::taylor_by_trace(y, order, out, |x, dx| {
            dx[..REDUCED_DIM].copy_from_slice(&reduced_with::<Traced>(&x[..REDUCED_DIM], &self.prep)?);
            if x.len() > REDUCED_DIM {
                let q = self.full_q(x);
                let (_, qd) = fast(&q, &x[KEPT.len()..REDUCED_DIM], &self.prep.p)?;
                let mut f = [Traced::constant(0.0); DIMS.ell];
                forces(&q, &qd, &self.prep.p, &mut f);
                dx[REDUCED_DIM] = f.iter().zip(&qd).fold(Traced::constant(0.0), |w, (f, v)| w + *f * *v);
            }
            Ok::<(), runtime::EvalError>(())
        });
        Some(series.map_err(|e| match e {
            runtime::SeriesFailure::NonFinite => SystemError::new(format!("at t = {t}: the Taylor series is not finite")),
            runtime::SeriesFailure::System(e) => SystemError::new(format!("at t = {t}: {e}")),
        }))
    }
    fn jacobian(&self, t: f64, y: &[f64], jac: &mut [f64]) -> Option<Result<(), SystemError>> {
        let p = match self.at(t) {
            Ok(p) => p,
            Err(e) => return Some(Err(e)),
        };
        Some(
            reduced_jacobian_live(y, &p, &self.prep)
                .map(|j| {
                    for (i, row) in j.iter().enumerate() {
                        jac[i * REDUCED_DIM..(i + 1) * REDUCED_DIM].copy_from_slice(row);
                    }
                })
                .map_err(|e| SystemError::new(e.to_string())),
        )
    }
}

/// The command line: where the job comes from and how an ensemble runs.
#[derive(Default)]
struct Args {
    job: Option<PathBuf>,
    threads: usize,
    shard: Shard,
    output: Option<PathBuf>,
    progress: bool,
}

fn args() -> Result<Args, JobError> {
    let mut a = Args {
        shard: Shard::ALL,
        ..Args::default()
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or(JobError::Arguments(format!("{flag} needs a value")));
        match flag.as_str() {
            "--job" => a.job = Some(value()?.into()),
            "--output" => a.output = Some(value()?.into()),
            "--threads" => {
                a.threads = value()?
                    .parse()
                    .map_err(|e| JobError::Arguments(format!("--threads: {e}")))?
            }
            "--shard" => a.shard = value()?.parse().map_err(|e| JobError::Arguments(format!("--shard: {e}")))?,
            "--progress" => a.progress = true,
            _ => return Err(JobError::Arguments(format!("unknown option {flag} (see the module doc of src/bin/scene.rs)"))),
        }
    }
    Ok(a)
}

/// The job and its fingerprint ([`hamel_sim::job::fingerprint`] of its text: a part of an
/// ensemble names the job it was computed for, so that parts of another job cannot be merged
/// with it).
fn read_job(a: &Args) -> Result<(Job, String), JobError> {
    let mut text = String::new();
    let read = match &a.job {
        Some(path) => std::fs::read_to_string(path).map(|t| text = t),
        None => std::io::stdin().read_to_string(&mut text).map(|_| ()),
    };
    read.map_err(|e| JobError::Read {
        path: a.job.as_ref().map(|p| p.display().to_string()),
        why: e.to_string(),
    })?;
    let job: Job = serde_json::from_str(&text).map_err(|e| JobError::Unreadable(e.to_string()))?;
    if job.live.len() != LIVE.len() {
        return Err(JobError::Live {
            got: job.live.len(),
            expected: LIVE.len(),
            names: LIVE.iter().map(|s| s.to_string()).collect(),
        });
    }
    check_state(None, &job.y0)?;
    Ok((job, hamel_sim::job::fingerprint(&text)))
}

/// A state must be a reduced state.
fn check_state(member: Option<usize>, y0: &[f64]) -> Result<(), JobError> {
    if y0.len() == REDUCED_DIM {
        return Ok(());
    }
    Err(JobError::State {
        member,
        got: y0.len(),
        state: REDUCED_STATE.iter().map(|s| s.to_string()).collect(),
    })
}

/// The core's parameters with `values` set on top, prepared.
fn prepared(values: &BTreeMap<String, f64>) -> Result<Prepared, JobError> {
    let mut p = Parameters::default();
    for (k, &v) in values {
        p.set(k, v).map_err(|e| JobError::Parameter(e.to_string()))?;
    }
    Prepared::new(&p).map_err(|e| JobError::Prepare(e.to_string()))
}

/// One integration, repeated `job.repeat` times for timing.
fn single(job: &Job) -> Result<String, JobError> {
    let system = Reduced {
        prep: prepared(&job.params)?,
        live: job.live.clone(),
        reference: job.reference,
        energy: job.energy,
        residual: job.residual,
        series_traced: AtomicUsize::new(0),
    };
    let mut seconds = Vec::new();
    let mut last = None;
    for _ in 0..job.repeat.max(1) {
        system.series_traced.store(0, Ordering::Relaxed);
        let start = Instant::now();
        let result =
            hamel_sim::integrate(&system, job.method, job.t0, &job.y0, &job.times, &job.options);
        seconds.push(start.elapsed().as_secs_f64());
        last = Some(result);
    }
    seconds.sort_by(f64::total_cmp);
    let (mut solution, stopped) = Stopped::split(last.expect("at least one run"));
    solution.stats.series_traced = system.series_traced.load(Ordering::Relaxed);
    let (constraint_forces, forces_failure) = if job.forces { constraint_forces_at(&system, &solution) } else { (Vec::new(), None) };
    let answer = Answer { solution, stopped, seconds: seconds[seconds.len() / 2], constraint_forces, forces_failure };
    Ok(serde_json::to_string(&answer).expect("an answer is serialisable"))
}

/// Every constraint force ([`CONSTRAINT_FORCES`](hamel_generated::CONSTRAINT_FORCES)) at the output states, at the parameters of
/// their times; None where they cannot be computed, and why at the first such time.
fn constraint_forces_at(system: &Reduced, solution: &Solution) -> (Vec<Option<Vec<f64>>>, Option<ForcesFailure>) {
    let mut first = None;
    let at = |t: f64, y: &[f64]| -> Result<Vec<f64>, String> {
        let p = system.at(t).map_err(|e| e.to_string())?;
        constraint_forces(&system.full_q(y), &y[KEPT.len()..], &p).map_err(|e| e.to_string())
    };
    let forces = (solution.t.iter().zip(solution.y.iter()))
        .map(|(&t, y)| match at(t, y) {
            Ok(v) => Some(v),
            Err(e) => {
                first.get_or_insert(ForcesFailure { time: t, message: e });
                None
            }
        })
        .collect();
    (forces, first)
}

/// A member's system (the core with its parameters) and initial state.
fn member_system(job: &Job, m: &Member) -> Result<(Reduced, Vec<f64>), JobError> {
    let system = Reduced {
        prep: prepared(&m.params)?,
        live: job.live.clone(),
        reference: m.reference.unwrap_or(job.reference),
        energy: job.energy,
        residual: job.residual,
        series_traced: AtomicUsize::new(0),
    };
    Ok((system, m.y0.clone()))
}

/// The ensemble's part of this shard: its header line, then one line per member.
fn ensemble(job: &Job, fingerprint: &str, members: &[Member], a: &Args) -> Result<String, JobError> {
    let range = a.shard.range(members.len());
    let mine = &members[range.clone()];
    for (i, m) in mine.iter().enumerate() {
        check_state(Some(range.start + i), &m.y0)?;
    }
    let setup = |i: usize| member_system(job, &mine[i]).map_err(|e| e.to_string());
    let settings = Ensemble {
        method: job.method,
        t0: job.t0,
        times: &job.times,
        options: job.options,
        threads: a.threads,
    };
    let done = AtomicUsize::new(0);
    let start = Instant::now();
    let (outcomes, seconds) = std::thread::scope(|scope| {
        let reporter = a.progress.then(|| scope.spawn(|| report(&done, mine.len(), &start)));
        // What is kept of a member is made on the worker, so the solutions do not pile up.
        let keep = |_: usize, r: Result<Solution, hamel_sim::IntegrationError>| {
            let (mut solution, stopped) = Stopped::split(r);
            if job.save == Save::Final {
                keep_last(&mut solution);
            }
            (solution, stopped)
        };
        let outcomes = integrate_many(&settings, mine.len(), setup, keep, &done);
        // The loop's time, not the reporter's wait.
        let seconds = start.elapsed().as_secs_f64();
        done.store(usize::MAX, Ordering::Relaxed);
        if let Some(r) = reporter {
            r.thread().unpark();
            let _ = r.join();
        }
        (outcomes, seconds)
    });
    let outcomes = outcomes.map_err(|e| JobError::Ensemble(e.to_string()))?;
    let threads = if a.threads == 0 { std::thread::available_parallelism().map_or(1, |n| n.get()) } else { a.threads };
    let header = PartHeader {
        hamel_ensemble_part: PART_FORMAT,
        job: fingerprint.to_string(),
        members: members.len(),
        first: range.start,
        end: range.end,
        state: REDUCED_STATE.iter().map(|s| s.to_string()).collect(),
        save: job.save,
        threads,
        seconds,
    };
    let mut text = serde_json::to_string(&header).expect("a header is serialisable");
    for (i, (solution, stopped)) in outcomes.into_iter().enumerate() {
        let line = MemberAnswer { member: range.start + i, solution, stopped };
        text.push('\n');
        text.push_str(&serde_json::to_string(&line).expect("an answer is serialisable"));
    }
    text.push('\n');
    Ok(text)
}

/// `progress DONE TOTAL SECONDS` on stderr every 100 ms until `done` is set to `usize::MAX`
/// (and the thread unparked).
fn report(done: &AtomicUsize, total: usize, start: &Instant) {
    let mut last = usize::MAX - 1;
    loop {
        let now = done.load(Ordering::Relaxed);
        let finished = now == usize::MAX;
        let now = if finished { total } else { now };
        if now != last {
            eprintln!("{}", Progress { done: now, total, seconds: start.elapsed().as_secs_f64() });
            last = now;
        }
        if finished {
            return;
        }
        // Woken early when the members are done.
        std::thread::park_timeout(std::time::Duration::from_millis(100));
    }
}

/// Only the last output of a solution (its statistics kept), in buffers of that size: the
/// run's own are freed, to be reused by the next member.
fn keep_last(s: &mut Solution) {
    let Some(j) = s.t.len().checked_sub(1) else {
        return;
    };
    let mut y = States::with_capacity(s.y.dim(), 1);
    y.push(&s.y[j]);
    s.y = y;
    s.t = vec![s.t[j]];
    s.energy = vec![s.energy[j]];
    s.constraint = vec![s.constraint[j]];
    if let Some(&w) = s.work.get(j) {
        s.work = vec![w];
    }
}

/// Write `text` to `path` whole: a temporary file beside it, renamed.
fn write_whole(path: &std::path::Path, text: &str) -> Result<(), JobError> {
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, path))
        .map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            JobError::Write { what: path.display().to_string(), why: e.to_string() }
        })
}

fn run() -> Result<(), JobError> {
    let a = args()?;
    let (job, fingerprint) = read_job(&a)?;
    let text = match job.members.as_slice() {
        [] => single(&job)? + "\n",
        members => ensemble(&job, &fingerprint, members, &a)?,
    };
    match &a.output {
        Some(path) => write_whole(path, &text),
        None => std::io::stdout()
            .write_all(text.as_bytes())
            .map_err(|e| JobError::Write { what: "the answer".into(), why: e.to_string() }),
    }
}

fn main() {
    if let Err(e) = run() {
        eprintln!("{}", e.report());
        std::process::exit(2);
    }
}
