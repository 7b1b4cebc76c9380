//! Ensembles: many integrations with one method, one time span and one set of output times,
//! each member its own system (parameters) and initial state, run on a rayon pool.
//!
//! What DifferentialEquations.jl's `EnsembleProblem` with `EnsembleThreads()` does, and a numba
//! `prange` loop around numbalsoda: members are independent, so they are spread over the
//! pool's threads by work stealing, and the outcomes come back in member order whatever the
//! schedule. A member that cannot be set up or whose integration fails is reported as that
//! member's error (with its partial solution); the others are kept.
//!
//! Only what the caller's `member` closure builds runs on the pool: in hamel that is a compiled
//! core, never the computer-algebra engine.

use std::sync::atomic::{AtomicUsize, Ordering};

use rayon::prelude::*;

use crate::driver::{Method, Options, integrate};
use crate::solution::{ErrorKind, IntegrationError, Solution};
use crate::system::OdeSystem;

/// What every member shares: the method, the start, the output times, the options, and the
/// pool's size.
#[derive(Clone, Copy, Debug)]
pub struct Ensemble<'a> {
    /// The integrator.
    pub method: Method,
    /// The initial time.
    pub t0: f64,
    /// The output times.
    pub times: &'a [f64],
    /// Tolerances and limits.
    pub options: Options,
    /// Worker threads; 0 for one per core (rayon's default).
    pub threads: usize,
}

/// The K-th of N contiguous blocks of an ensemble's members (K from 0): what one task of a job
/// array runs. Written `K/N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// K.
    pub index: usize,
    /// N.
    pub count: usize,
}

impl Shard {
    /// Every member: the one block of one.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// The members of this block of `total`, in order.
    pub fn range(self, total: usize) -> std::ops::Range<usize> {
        total * self.index / self.count..total * (self.index + 1) / self.count
    }
}

impl Default for Shard {
    fn default() -> Self {
        Shard::ALL
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N` with 0 ≤ K < N.
    fn from_str(s: &str) -> Result<Shard, String> {
        let bad = || format!("expected K/N with 0 <= K < N, got `{s}`");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = k.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// Why an ensemble could not run at all (a member's failure is in its outcome instead).
#[derive(Debug, thiserror::Error)]
#[error("cannot start {threads} worker threads: {source}")]
pub struct EnsembleError {
    /// The threads asked for.
    pub threads: usize,
    /// rayon's error.
    #[source]
    pub source: rayon::ThreadPoolBuildError,
}

/// Integrate members `0..n` on a pool of `ensemble.threads` threads: `member(i)` gives the
/// i-th system and initial state, or why it cannot be set up (reported as that member's
/// [`ErrorKind::InvalidInput`]); `output(i, outcome)` makes what is kept of member i (as
/// DifferentialEquations.jl's `output_func`), on the worker, as soon as it finishes — the last
/// state only, say, so that the solutions do not pile up in memory. The kept values are in
/// member order; `done` counts the members finished (for a progress bar drawn by another
/// thread).
///
/// ```
/// use std::sync::atomic::AtomicUsize;
/// use hamel_sim::{Ensemble, Method, OdeSystem, Options, SystemError, integrate_many};
///
/// /// `y' = −k y`.
/// struct Decay(f64);
/// impl OdeSystem for Decay {
///     fn dim(&self) -> usize { 1 }
///     fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
///         dy[0] = -self.0 * y[0];
///         Ok(())
///     }
/// }
///
/// let ensemble = Ensemble { method: Method::Dop853, t0: 0.0, times: &[1.0],
///                           options: Options::default(), threads: 2 };
/// let done = AtomicUsize::new(0);
/// let member = |i: usize| Ok((Decay(i as f64 / 100.0), vec![1.0]));
/// let last = |_i: usize, outcome: Result<hamel_sim::Solution, _>| outcome.map(|s| s.y[0][0]);
/// let out = integrate_many(&ensemble, 100, member, last, &done)?;
/// let y = *out[50].as_ref().unwrap();
/// assert!((y - (-0.5f64).exp()).abs() < 1e-9);
/// # Ok::<(), hamel_sim::EnsembleError>(())
/// ```
pub fn integrate_many<S, F, O, T>(
    ensemble: &Ensemble<'_>,
    n: usize,
    member: F,
    output: O,
    done: &AtomicUsize,
) -> Result<Vec<T>, EnsembleError>
where
    S: OdeSystem,
    F: Fn(usize) -> Result<(S, Vec<f64>), String> + Sync,
    O: Fn(usize, Result<Solution, IntegrationError>) -> T + Sync,
    T: Send,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(ensemble.threads)
        .thread_name(|i| format!("hamel-ensemble-{i}"))
        .build()
        .map_err(|source| EnsembleError {
            threads: ensemble.threads,
            source,
        })?;
    Ok(pool.install(|| {
        (0..n)
            .into_par_iter()
            .map(|i| {
                let kept = output(i, run_member(ensemble, &member, i));
                done.fetch_add(1, Ordering::Relaxed);
                kept
            })
            .collect()
    }))
}

/// One member, set up and integrated.
fn run_member<S: OdeSystem, F: Fn(usize) -> Result<(S, Vec<f64>), String>>(
    ensemble: &Ensemble<'_>,
    member: &F,
    i: usize,
) -> Result<Solution, IntegrationError> {
    let (system, y0) = member(i).map_err(|message| IntegrationError {
        kind: ErrorKind::InvalidInput,
        time: ensemble.t0,
        state: Vec::new(),
        message,
        partial: Box::default(),
    })?;
    integrate(
        &system,
        ensemble.method,
        ensemble.t0,
        &y0,
        ensemble.times,
        &ensemble.options,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::system::SystemError;

    /// `y' = k y` for member k's rate; member 3 cannot be set up and member 5 blows up.
    struct Growth(f64);

    impl OdeSystem for Growth {
        fn dim(&self) -> usize {
            1
        }
        fn rhs(&self, _t: f64, y: &[f64], dy: &mut [f64]) -> Result<(), SystemError> {
            dy[0] = self.0 * y[0] * if self.0 > 100.0 { y[0] } else { 1.0 };
            Ok(())
        }
    }

    fn member(i: usize) -> Result<(Growth, Vec<f64>), String> {
        match i {
            3 => Err("member 3 has no rate".into()),
            5 => Ok((Growth(1000.0), vec![1.0])),
            _ => Ok((Growth(-(i as f64) / 10.0), vec![2.0])),
        }
    }

    #[test]
    fn members_come_back_in_order_with_their_failures() {
        let times = [0.5, 1.0];
        for threads in [1, 2] {
            let ensemble = Ensemble {
                method: Method::Dop853,
                t0: 0.0,
                times: &times,
                options: Options {
                    rtol: 1e-11,
                    atol: 1e-12,
                    ..Options::default()
                },
                threads,
            };
            let done = AtomicUsize::new(0);
            let out = integrate_many(&ensemble, 40, member, |_, o| o, &done).unwrap();
            assert_eq!(done.load(Ordering::Relaxed), 40);
            assert_eq!(out.len(), 40);
            for (i, o) in out.iter().enumerate() {
                match i {
                    3 => {
                        let e = o.as_ref().unwrap_err();
                        assert_eq!(e.kind, ErrorKind::InvalidInput);
                        assert!(e.message.contains("member 3"));
                    }
                    // y' = 1000 y² from 1 blows up at t = 1e-3.
                    5 => assert!(!o.as_ref().unwrap_err().partial.complete),
                    _ => {
                        let s = o.as_ref().unwrap();
                        let exact = 2.0 * (-(i as f64) / 10.0).exp();
                        assert!((s.y[1][0] - exact).abs() < 1e-9 * exact.max(1.0), "{i}");
                    }
                }
            }
        }
    }

    #[test]
    fn shards_cover_every_member_once_in_order() {
        for total in [0, 1, 7, 100, 10_001] {
            for count in 1..=9 {
                let mut next = 0;
                for index in 0..count {
                    let r = Shard { index, count }.range(total);
                    assert_eq!(r.start, next);
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
        assert_eq!("2/5".parse::<Shard>(), Ok(Shard { index: 2, count: 5 }));
        for bad in ["5/5", "1", "a/2", "1/0", "-1/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    #[test]
    fn the_output_function_keeps_what_it_returns_in_member_order() {
        let ensemble = Ensemble {
            method: Method::Dop853,
            t0: 0.0,
            times: &[0.5, 1.0],
            options: Options::default(),
            threads: 2,
        };
        let last = |i: usize, o: Result<Solution, IntegrationError>| {
            (i, o.ok().and_then(|s| s.y.last().map(|y| y[0])))
        };
        let out = integrate_many(&ensemble, 20, member, last, &AtomicUsize::new(0)).unwrap();
        for (i, (j, y)) in out.iter().enumerate() {
            assert_eq!(i, *j);
            assert_eq!(y.is_none(), i == 3 || i == 5);
        }
    }

    #[test]
    fn the_same_members_give_the_same_bits_on_one_and_two_threads() {
        let run = |threads| {
            let ensemble = Ensemble {
                method: Method::Dopri5,
                t0: 0.0,
                times: &[0.3, 0.7],
                options: Options::default(),
                threads,
            };
            integrate_many(&ensemble, 64, member, |_, o| o, &AtomicUsize::new(0)).unwrap()
        };
        assert_eq!(run(1), run(2));
    }
}
