//! The job protocol of a compiled core's `scene` binary, in one place: what hamel sends
//! ([`Job`], [`Member`]), what the core answers ([`Answer`]; for an ensemble a [`PartHeader`]
//! line then one [`MemberAnswer`] line per member), and how each side fails, typed
//! ([`Stopped`], [`ForcesFailure`], [`JobError`]).
//!
//! This file is vendored into every generated crate with the rest of `hamel-sim`, so the core
//! and hamel read and write the same types; nothing here depends on a model.
//!
//! **Invariants**: the job's text is deterministic (parameters in name order), so that its
//! [`fingerprint`] names it; an ensemble part carries [`PART_FORMAT`], and a part of another
//! format or another job is refused by name, never merged.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::{ErrorKind, IntegrationError, Live, Method, Options, Solution};

/// The format of an ensemble part's header (`hamel_ensemble_part`): 2 since member failures
/// are typed ([`Stopped`]).
pub const PART_FORMAT: u32 = 2;

/// The prefix of the line on which a core that refuses its job writes the [`JobError`] as
/// JSON (on stderr, after the `error:` line a person reads).
pub const ERROR_LINE: &str = "hamel-core-error: ";

/// One integration job (or, with `members`, an ensemble).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Job {
    /// The initial time.
    pub t0: f64,
    /// The output times.
    pub times: Vec<f64>,
    /// The reduced state: the kept coordinates in model order, then η.
    pub y0: Vec<f64>,
    /// The integrator.
    pub method: Method,
    /// Its tolerances and limits.
    pub options: Options,
    /// The value at which the eliminated coordinates are held where a full configuration is
    /// needed (the equations are free of them).
    pub reference: f64,
    /// Monitor the energy.
    pub energy: bool,
    /// Monitor ‖α(q)q̇‖∞.
    pub residual: bool,
    /// Compute the constraint forces at the output times ([`Answer::constraint_forces`]).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub forces: bool,
    /// How many times to integrate, for timing.
    #[serde(default = "one")]
    pub repeat: usize,
    /// Parameter values other than those the core was generated with.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub params: BTreeMap<String, f64>,
    /// What sets each of the core's live parameters at every evaluation, in their order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub live: Vec<Live>,
    /// An ensemble's members (empty: one integration of `y0`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub members: Vec<Member>,
    /// What an ensemble keeps of each member.
    #[serde(default)]
    pub save: Save,
}

fn one() -> usize {
    1
}

impl Job {
    /// The job as the core reads it, and its [`fingerprint`].
    pub fn to_text(&self) -> (String, String) {
        let text = serde_json::to_string(self).expect("a job is serialisable");
        let print = fingerprint(&text);
        (text, print)
    }
}

/// A member of an ensemble: its reduced state, its parameters (on top of the core's and the
/// job's), and its reference value for the eliminated coordinates (else the job's).
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Member {
    /// The reduced state.
    pub y0: Vec<f64>,
    /// Parameter values of this member.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub params: BTreeMap<String, f64>,
    /// The eliminated coordinates' value (else the job's `reference`).
    #[serde(default)]
    pub reference: Option<f64>,
}

/// What an ensemble keeps of each member: the requested outputs at every output time, or at
/// the last one only (with the member's statistics either way).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Save {
    /// Every output time.
    Outputs,
    /// The last output time.
    #[default]
    Final,
}

/// Why an integration stopped early, as the core reports it: an [`IntegrationError`] without
/// its partial solution (which the answer carries).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[error("{kind} at t = {time}: {message}")]
pub struct Stopped {
    /// The cause.
    pub kind: ErrorKind,
    /// The time of the last valid state.
    pub time: f64,
    /// What happened, in words.
    pub message: String,
}

impl Stopped {
    /// The solution (partial on failure) and why it stopped, of an integration's result.
    pub fn split(r: Result<Solution, IntegrationError>) -> (Solution, Option<Stopped>) {
        match r {
            Ok(s) => (s, None),
            Err(e) => {
                let stopped = Stopped {
                    kind: e.kind,
                    time: e.time,
                    message: e.message,
                };
                (*e.partial, Some(stopped))
            }
        }
    }
}

/// Why the constraint forces could not be computed, at the first output time where they
/// could not.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[error("at t = {time}: {message}")]
pub struct ForcesFailure {
    /// The output time.
    pub time: f64,
    /// Why, in words (the evaluation's error).
    pub message: String,
}

/// What the core answers to one integration job.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Answer {
    /// The solution (up to the failure, if any).
    pub solution: Solution,
    /// Why it stopped early.
    pub stopped: Option<Stopped>,
    /// The median wall time of one integration.
    pub seconds: f64,
    /// With `forces` asked: every reported constraint force at each output time (None where
    /// they could not be computed).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub constraint_forces: Vec<Option<Vec<f64>>>,
    /// Why they could not be computed at the first output where they could not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forces_failure: Option<ForcesFailure>,
}

/// The first line of an ensemble part: which job, which members, how it ran.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PartHeader {
    /// [`PART_FORMAT`] of the core that wrote it.
    pub hamel_ensemble_part: u32,
    /// The job's [`fingerprint`].
    pub job: String,
    /// Members in the whole job, and the block `first..end` of them in this part.
    pub members: usize,
    /// The first member of this part.
    pub first: usize,
    /// One past the last member of this part.
    pub end: usize,
    /// The names of the reduced state's components.
    pub state: Vec<String>,
    /// What is kept of each member.
    pub save: Save,
    /// Threads of the core's pool.
    pub threads: usize,
    /// Wall time of the loop over the members.
    pub seconds: f64,
}

/// One member's line of an ensemble part.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MemberAnswer {
    /// The member's index in the whole job.
    pub member: usize,
    /// Its solution (the last output only with [`Save::Final`]).
    pub solution: Solution,
    /// Why it stopped early.
    pub stopped: Option<Stopped>,
}

/// Why a core refused or could not finish a job (it exits with status 2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, thiserror::Error)]
pub enum JobError {
    /// Its command line.
    #[error("{0}")]
    Arguments(String),
    /// The job could not be read (stdin or `--job FILE`).
    #[error("cannot read the job{}: {why}", path.as_ref().map(|p| format!(" {p}")).unwrap_or_default())]
    Read {
        /// The file, if not stdin.
        path: Option<String>,
        /// The system's error.
        why: String,
    },
    /// The job is not JSON of a [`Job`].
    #[error("bad job: {0}")]
    Unreadable(String),
    /// As many live values as the core has live parameters are needed.
    #[error("bad job: {got} live values, the core sets {expected} ({names:?}) at every evaluation")]
    Live {
        /// Sent.
        got: usize,
        /// The core's live parameters.
        expected: usize,
        /// Their names.
        names: Vec<String>,
    },
    /// A state of the wrong length (the job's `y0`, or a member's).
    #[error("bad job: {} has {got} values, the reduced state ({state:?}) has {}", member.map_or("y0".to_string(), |m| format!("member {m}'s y0")), state.len())]
    State {
        /// The member, or None for the job's `y0`.
        member: Option<usize>,
        /// Values sent.
        got: usize,
        /// The reduced state's names.
        state: Vec<String>,
    },
    /// A parameter the core does not have, or a value it refuses.
    #[error("bad job: {0}")]
    Parameter(String),
    /// The parameters could not be prepared (a derived value is not finite).
    #[error("{0}")]
    Prepare(String),
    /// The ensemble could not run (its thread pool).
    #[error("{0}")]
    Ensemble(String),
    /// The answer could not be written.
    #[error("cannot write {what}: {why}")]
    Write {
        /// The file, or "the answer" for stdout.
        what: String,
        /// The system's error.
        why: String,
    },
}

impl JobError {
    /// The lines a core writes on stderr when it fails: `error: …` for a person, then
    /// [`ERROR_LINE`] and the error as JSON for hamel.
    pub fn report(&self) -> String {
        let json = serde_json::to_string(self).expect("a job error is serialisable");
        format!("error: {self}\n{ERROR_LINE}{json}")
    }

    /// The typed error among a failed core's stderr lines, if it wrote one.
    pub fn from_report(stderr: &str) -> Option<JobError> {
        stderr
            .lines()
            .find_map(|l| l.strip_prefix(ERROR_LINE))
            .and_then(|json| serde_json::from_str(json).ok())
    }
}

/// FNV-1a, 64 bits, in hexadecimal: a job's fingerprint (and the code cache's entry names).
pub fn fingerprint(text: &str) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in text.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    format!("{h:016x}")
}

/// The progress line a core writes on stderr as an ensemble's members finish.
pub struct Progress {
    /// Members finished.
    pub done: usize,
    /// Members in the part.
    pub total: usize,
    /// Seconds since the loop started.
    pub seconds: f64,
}

impl Progress {
    /// A `progress DONE TOTAL SECONDS` line, if `line` is one.
    pub fn parse(line: &str) -> Option<Progress> {
        let mut words = line.strip_prefix("progress ")?.split(' ');
        Some(Progress {
            done: words.next()?.parse().ok()?,
            total: words.next()?.parse().ok()?,
            seconds: words.next().and_then(|s| s.parse().ok()).unwrap_or(0.0),
        })
    }
}

impl fmt::Display for Progress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "progress {} {} {:.3}",
            self.done, self.total, self.seconds
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_job_error_survives_the_report() {
        let e = JobError::State {
            member: Some(3),
            got: 2,
            state: vec!["x".into(), "eta1".into(), "eta2".into()],
        };
        let report = e.report();
        assert!(report.starts_with("error: bad job: member 3's y0 has 2 values"));
        assert_eq!(JobError::from_report(&report), Some(e));
        assert_eq!(JobError::from_report("error: something else"), None);
    }

    #[test]
    fn progress_lines_round_trip() {
        let p = Progress::parse(
            &Progress {
                done: 4,
                total: 9,
                seconds: 0.5,
            }
            .to_string(),
        )
        .unwrap();
        assert_eq!((p.done, p.total), (4, 9));
        assert!(Progress::parse("warning: x").is_none());
    }

    #[test]
    fn a_stopped_run_reads_as_the_integration_error() {
        let e = IntegrationError {
            kind: ErrorKind::StepSizeUnderflow,
            time: 1.5,
            state: vec![],
            message: "h = 1e-300".into(),
            partial: Box::default(),
        };
        let text = e.to_string();
        let (_, stopped) = Stopped::split(Err(e));
        assert_eq!(stopped.unwrap().to_string(), text);
    }
}
