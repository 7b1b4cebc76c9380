//! Sweeps over one parameter and maps over two: the points run in parallel on a rayon pool
//! (numeric code only: the computer algebra ran in [`Study::prepare`]), and the crossings
//! where stability changes are refined by root finding.

use indexmap::IndexMap;
use rayon::prelude::*;
use serde::Serialize;

use crate::eigen::ZERO_REAL_PART;
use crate::forms::Symbolic;
use crate::{Linearisation, Point, Stability, Study, StudyError};

/// The most values one sweep, or one map, may have.
pub const MAX_POINTS: usize = 10_000_000;

/// `P=START:STOP:COUNT`: COUNT values from START to STOP, ends included (START may be the
/// larger).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Range {
    /// The parameter (steady or of the model).
    pub parameter: String,
    /// First value.
    pub start: f64,
    /// Last value.
    pub stop: f64,
    /// Number of values (≥ 2).
    pub count: usize,
}

impl Range {
    /// Parse `P=START:STOP:COUNT`.
    pub fn parse(text: &str) -> Result<Range, String> {
        let shape = || format!("`{text}`: write P=START:STOP:COUNT, such as v=0:10:21");
        let (p, rest) = text.split_once('=').ok_or_else(shape)?;
        let parts: Vec<&str> = rest.split(':').collect();
        let [start, stop, count] = parts.as_slice() else {
            return Err(shape());
        };
        let number = |s: &str| s.trim().parse::<f64>().ok().filter(|x| x.is_finite());
        let (Some(start), Some(stop)) = (number(start), number(stop)) else {
            return Err(shape());
        };
        let count: usize = count.trim().parse().map_err(|_| shape())?;
        if count > MAX_POINTS {
            return Err(format!(
                "`{text}`: at most {MAX_POINTS} values in one sweep"
            ));
        }
        if count < 2 || start == stop {
            return Err(format!(
                "`{text}`: a sweep needs COUNT ≥ 2 and START ≠ STOP"
            ));
        }
        Ok(Range {
            parameter: p.trim().to_string(),
            start,
            stop,
            count,
        })
    }

    /// The values.
    pub fn values(&self) -> Vec<f64> {
        let step = (self.stop - self.start) / (self.count - 1) as f64;
        (0..self.count)
            .map(|i| {
                if i + 1 == self.count {
                    self.stop
                } else {
                    self.start + step * i as f64
                }
            })
            .collect()
    }
}

/// One point of a sweep.
#[derive(Clone, Debug, Serialize)]
pub struct SweepPoint {
    /// The parameter's value.
    pub value: f64,
    /// The eigenvalues that are not structural, (re, im).
    pub eigenvalues: Vec<[f64; 2]>,
    /// Stability there.
    pub stability: Stability,
}

/// How stability changes at a crossing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CrossingKind {
    /// A real eigenvalue passes through zero (det A = 0 on the non-structural part; this
    /// includes a real pair that meets at zero and turns imaginary).
    RealZero,
    /// A complex pair crosses the imaginary axis (Hopf).
    Hopf,
}

/// A parameter value where an eigenvalue crosses the imaginary axis.
#[derive(Clone, Debug, Serialize)]
pub struct Crossing {
    /// The parameter's value, refined to 1e-12.
    pub value: f64,
    /// How.
    pub kind: CrossingKind,
    /// The crossing eigenvalue there (0, or iω).
    pub eigenvalue: [f64; 2],
    /// How many eigenvalues (structural zeros apart) are zero there: 2 where a real pair
    /// meets at zero and turns imaginary.
    pub zeros: usize,
    /// Stability just below and just above (at the neighbouring sweep points).
    pub below: Stability,
    /// Stability above.
    pub above: Stability,
}

/// A sweep over one parameter.
#[derive(Clone, Debug, Serialize)]
pub struct Sweep {
    /// The swept parameter.
    pub parameter: String,
    /// The points.
    pub points: Vec<SweepPoint>,
    /// Where stability changes.
    pub crossings: Vec<Crossing>,
    /// How the steady motion is known to be one.
    pub steady_check: crate::SteadyCheck,
    /// Zero eigenvalues present at every point (reported apart).
    pub persistent_zeros: usize,
    /// The linear equations as polynomials in the parameter, when they are.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub matrices: Option<Symbolic>,
    /// Why they are not, when they are not.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub matrices_note: Option<String>,
}

/// A map over two parameters: the largest real part of the non-structural eigenvalues.
#[derive(Clone, Debug, Serialize)]
pub struct Map {
    /// The first parameter (columns).
    pub x: Range,
    /// The second (rows).
    pub y: Range,
    /// max Re λ at (x_i, y_k), as `values[k][i]`.
    pub values: Vec<Vec<f64>>,
    /// Stability at each point, the same way.
    pub stability: Vec<Vec<Stability>>,
    /// How the steady motion is known to be one.
    pub steady_check: crate::SteadyCheck,
    /// Zero eigenvalues present at every point.
    pub persistent_zeros: usize,
}

impl Study {
    /// Linearise at every point of `points` in parallel, on a pool of the study's own (numeric
    /// code only: no computer algebra runs there); `done` is called after each.
    fn all(
        &self,
        points: &[Point],
        done: &(dyn Fn() + Sync),
    ) -> Result<Vec<Linearisation>, StudyError> {
        self.all_kept(points, done, false)
    }

    /// [`Study::all`]; with `slim`, each point keeps only its eigenvalues and stability.
    fn all_kept(
        &self,
        points: &[Point],
        done: &(dyn Fn() + Sync),
        slim: bool,
    ) -> Result<Vec<Linearisation>, StudyError> {
        let keep = |l: Linearisation| if slim { l.slim() } else { l };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(self.threads)
            .build()
            .map_err(|e| StudyError::Numeric(format!("cannot start the thread pool: {e}")))?;
        pool.install(|| {
            if !self.steady_q_is_fixed() {
                return points
                    .par_iter()
                    .map(|p| {
                        let l = self.linearise_with(p, 0, false).map(keep);
                        done();
                        l
                    })
                    .collect::<Vec<_>>()
                    .into_iter()
                    .collect();
            }
            // Points with the same model parameters share their steady configuration and
            // everything that depends on it alone (the ingredients and their derivatives in q).
            // Errors in point order, whatever the threads' order.
            let values = points
                .par_iter()
                .map(|p| self.values(&p.0))
                .collect::<Vec<_>>()
                .into_iter()
                .collect::<Result<Vec<_>, _>>()?;
            let mut groups: IndexMap<Vec<u64>, usize> = IndexMap::new();
            let mut first: Vec<usize> = Vec::new();
            let group: Vec<usize> = (0..values.len())
                .map(|i| {
                    let key = values[i].0.values().map(|v| v.to_bits()).collect();
                    let next = groups.len();
                    let g = *groups.entry(key).or_insert(next);
                    if g == next {
                        first.push(i);
                    }
                    g
                })
                .collect();
            let shared = first
                .par_iter()
                .map(|&i| self.at_q(values[i].0.clone(), &values[i].1))
                .collect::<Vec<_>>()
                .into_iter()
                .collect::<Result<Vec<_>, _>>()?;
            (0..points.len())
                .into_par_iter()
                .map(|i| {
                    let l = self
                        .linearise_at(&points[i], 0, false, &shared[group[i]], &values[i].1)
                        .map(keep);
                    done();
                    l
                })
                .collect::<Vec<_>>()
                .into_iter()
                .collect()
        })
    }

    /// The zeros present at every one of `lin` (the fewest any of them has).
    fn persistent(lin: &[Linearisation]) -> usize {
        lin.iter()
            .map(Linearisation::zero_multiplicity)
            .min()
            .unwrap_or(0)
    }

    /// The zero eigenvalues present along the steady family near `base`: the fewest at `base`
    /// and at two other values of every steady parameter (+1 and +2.5); none without steady
    /// parameters.
    pub fn persistent_zeros(&self, base: &Point) -> Result<usize, StudyError> {
        if self.steady.parameters.is_empty() {
            return Ok(0);
        }
        let (_, s) = self.values(&base.0)?;
        let shifted = |by: f64| {
            let mut p = base.clone();
            for (name, v) in self.steady.parameters.keys().zip(&s) {
                p.0.insert(name.clone(), v + by);
            }
            p
        };
        // The base must linearise; a shifted point that does not (off the family's domain) is
        // left out.
        let mut lin = vec![self.linearise_with(base, 0, false)?];
        lin.extend(
            [shifted(1.0), shifted(2.5)]
                .iter()
                .filter_map(|p| self.linearise_with(p, 0, false).ok()),
        );
        Ok(Self::persistent(&lin))
    }

    /// Sweep `range` about `base`: the eigenvalues at each point, the crossings refined, and
    /// the matrices as polynomials in the parameter when they are.
    pub fn sweep(
        &self,
        base: &Point,
        range: &Range,
        done: &(dyn Fn() + Sync),
    ) -> Result<Sweep, StudyError> {
        self.check_parameter(&range.parameter)?;
        let at = |x: f64| {
            let mut p = base.clone();
            p.0.insert(range.parameter.clone(), x);
            p
        };
        let points: Vec<Point> = range.values().into_iter().map(at).collect();
        let lin = self.all(&points, done)?;
        let s = Self::persistent(&lin);
        let lin: Vec<Linearisation> = lin.into_iter().map(|l| l.with_persistent(s)).collect();
        let values = range.values();
        let crossings = self.crossings(&at, &values, &lin, s)?;
        let (matrices, matrices_note) = match self.symbolic(base, &range.parameter) {
            Ok(Ok(m)) => (Some(m), None),
            Ok(Err(why)) => (None, Some(why)),
            Err(e) => (
                None,
                Some(format!("not computed: at a node of the interpolation, {e}")),
            ),
        };
        Ok(Sweep {
            parameter: range.parameter.clone(),
            steady_check: self.steady_check.clone(),
            points: values
                .iter()
                .zip(&lin)
                .map(|(&value, l)| SweepPoint {
                    value,
                    eigenvalues: l.eigenvalues.clone(),
                    stability: l.stability,
                })
                .collect(),
            crossings,
            persistent_zeros: s,
            matrices,
            matrices_note,
        })
    }

    /// A map over `x` and `y` about `base`.
    pub fn map(
        &self,
        base: &Point,
        x: &Range,
        y: &Range,
        done: &(dyn Fn() + Sync),
    ) -> Result<Map, StudyError> {
        self.check_parameter(&x.parameter)?;
        self.check_parameter(&y.parameter)?;
        if x.parameter == y.parameter {
            return Err(StudyError::Range(format!(
                "a map needs two different parameters, not `{}` twice",
                x.parameter
            )));
        }
        if x.count.checked_mul(y.count).is_none_or(|n| n > MAX_POINTS) {
            return Err(StudyError::Range(format!(
                "a map of {} × {} points is more than {MAX_POINTS}",
                x.count, y.count
            )));
        }
        let (xs, ys) = (x.values(), y.values());
        let points: Vec<Point> = ys
            .iter()
            .flat_map(|&b| xs.iter().map(move |&a| (a, b)))
            .map(|(a, b)| {
                let mut p = base.clone();
                p.0.insert(x.parameter.clone(), a);
                p.0.insert(y.parameter.clone(), b);
                p
            })
            .collect();
        let lin = self.all_kept(&points, done, true)?;
        let s = Self::persistent(&lin);
        let lin: Vec<Linearisation> = lin.into_iter().map(|l| l.with_persistent(s)).collect();
        let top = |l: &Linearisation| {
            l.eigenvalues
                .iter()
                .map(|z| z[0])
                .fold(f64::NEG_INFINITY, f64::max)
        };
        Ok(Map {
            x: x.clone(),
            steady_check: self.steady_check.clone(),
            y: y.clone(),
            values: lin
                .chunks(xs.len())
                .map(|row| row.iter().map(top).collect())
                .collect(),
            stability: lin
                .chunks(xs.len())
                .map(|row| row.iter().map(|l| l.stability).collect())
                .collect(),
            persistent_zeros: s,
        })
    }

    /// A swept name must be a steady parameter or a model parameter that is not derived.
    fn check_parameter(&self, p: &str) -> Result<(), StudyError> {
        if self.steady.parameters.contains_key(p) {
            return Ok(());
        }
        if self.model.derived.contains_key(p) {
            return Err(StudyError::Range(format!(
                "`{p}` is a derived parameter: sweep the parameters it is computed from"
            )));
        }
        if self.model.parameters.contains_key(p) {
            return Ok(());
        }
        let steady: Vec<&str> = self.steady.parameters.keys().map(String::as_str).collect();
        Err(StudyError::Range(format!(
            "`{p}` is neither a parameter of the steady motion `{}` ({}) nor of the model",
            self.steady.name,
            if steady.is_empty() {
                "it has none".into()
            } else {
                steady.join(", ")
            }
        )))
    }

    /// The crossings along a sweep. A real crossing lies between neighbouring points whose
    /// zero functions have opposite signs; a point with more zeros than the persistent ones is
    /// a crossing itself and is bracketed by the points on either side. A Hopf crossing lies
    /// between neighbouring points where a complex pair's real part, clear of zero at both,
    /// changes sign (points with a pair on the axis are stepped over the same way).
    fn crossings(
        &self,
        at: &(dyn Fn(f64) -> Point + Sync),
        values: &[f64],
        lin: &[Linearisation],
        s: usize,
    ) -> Result<Vec<Crossing>, StudyError> {
        let one = |x: f64| self.linearise_with(&at(x), s, false);
        // Stability below and above, whichever way the range runs.
        let sides = |i: usize, k: usize| {
            let (a, b) = (lin[i].stability, lin[k].stability);
            if values[i] <= values[k] {
                (a, b)
            } else {
                (b, a)
            }
        };
        let mut out = Vec::new();
        let clear: Vec<usize> = (0..lin.len())
            .filter(|&i| lin[i].zero_multiplicity() == s)
            .collect();
        for w in clear.windows(2) {
            let (i, k) = (w[0], w[1]);
            let (fa, fb) = (lin[i].zero_function, lin[k].zero_function);
            if fa.signum() == fb.signum() {
                continue;
            }
            let x = root(
                &|x| Ok(one(x)?.zero_function),
                (values[i], fa),
                (values[k], fb),
            )?;
            let zeros = one(x)?.zero_multiplicity().saturating_sub(s).max(1);
            let (below, above) = sides(i, k);
            out.push(Crossing {
                value: x,
                kind: CrossingKind::RealZero,
                eigenvalue: [0.0, 0.0],
                zeros,
                below,
                above,
            });
        }
        // Neighbouring points, and the points on either side of one with a pair on the axis
        // (a crossing that falls on a sweep point).
        let brackets = (0..lin.len().saturating_sub(1)).map(|i| (i, i + 1)).chain(
            (1..lin.len().saturating_sub(1))
                .filter(|&i| !off_axis(&lin[i]))
                .map(|i| (i - 1, i + 1)),
        );
        for (i, k) in brackets {
            for (za, zb) in hopf_pairs(&lin[i], &lin[k]) {
                let (x, z) = hopf(&one, (values[i], za), (values[k], zb))?;
                let (below, above) = sides(i, k);
                out.push(Crossing {
                    value: x,
                    kind: CrossingKind::Hopf,
                    eigenvalue: [0.0, z[1]],
                    zeros: 0,
                    below,
                    above,
                });
            }
        }
        out.sort_by(|a, b| a.value.total_cmp(&b.value));
        // A crossing seen from two brackets (one of them over a point on the axis) once.
        out.dedup_by(|b, a| {
            a.kind == b.kind && (a.value - b.value).abs() <= 1e-9 * a.value.abs().max(1.0)
        });
        Ok(out)
    }
}

/// Whether every complex eigenvalue is clear of the imaginary axis.
fn off_axis(l: &Linearisation) -> bool {
    let tol = ZERO_REAL_PART * l.scale;
    l.eigenvalues
        .iter()
        .all(|z| z[1].abs() <= tol || z[0].abs() > tol)
}

/// The complex eigenvalues (upper half plane) at `la` whose nearest partner at `lb` has a real
/// part of the other sign, both clear of zero.
fn hopf_pairs(la: &Linearisation, lb: &Linearisation) -> Vec<([f64; 2], [f64; 2])> {
    let tol = |l: &Linearisation| ZERO_REAL_PART * l.scale;
    let upper = |l: &Linearisation| -> Vec<[f64; 2]> {
        l.eigenvalues
            .iter()
            .copied()
            .filter(|z| z[1] > tol(l))
            .collect()
    };
    let (ua, ub) = (upper(la), upper(lb));
    ua.into_iter()
        .filter_map(|za| {
            let zb = nearest(&ub, za)?;
            let clear = za[0].abs() > tol(la) && zb[0].abs() > tol(lb);
            (clear && za[0].signum() != zb[0].signum()).then_some((za, zb))
        })
        .collect()
}

fn nearest(set: &[[f64; 2]], z: [f64; 2]) -> Option<[f64; 2]> {
    set.iter()
        .copied()
        .min_by(|x, y| distance(*x, z).total_cmp(&distance(*y, z)))
}

fn distance(x: [f64; 2], y: [f64; 2]) -> f64 {
    (x[0] - y[0]).hypot(x[1] - y[1])
}

/// Whether a bracket is as small as a crossing needs: 1e-13 relative (the answer is good to
/// 1e-12).
fn small(a: f64, b: f64) -> bool {
    (b - a).abs() <= 1e-13 * a.abs().max(b.abs()).max(1.0)
}

/// A root of f in [a, b] where f changes sign: the Illinois variant of regula falsi (at most
/// 200 steps).
fn root(
    f: &dyn Fn(f64) -> Result<f64, StudyError>,
    (mut a, mut fa): (f64, f64),
    (mut b, mut fb): (f64, f64),
) -> Result<f64, StudyError> {
    let mut side = 0;
    for _ in 0..200 {
        if small(a, b) {
            break;
        }
        let x = (a * fb - b * fa) / (fb - fa);
        let x = if x > a.min(b) && x < a.max(b) {
            x
        } else {
            0.5 * (a + b)
        };
        let fx = f(x)?;
        if fx == 0.0 {
            return Ok(x);
        }
        if fx.signum() == fb.signum() {
            b = x;
            fb = fx;
            if side == -1 {
                fa *= 0.5;
            }
            side = -1;
        } else {
            a = x;
            fa = fx;
            if side == 1 {
                fb *= 0.5;
            }
            side = 1;
        }
    }
    Ok(if fa.abs() < fb.abs() { a } else { b })
}

/// A Hopf crossing in [a, b]: bisection on the real part of the pair, followed from the end
/// nearer the midpoint to the eigenvalue nearest it (at most 200 steps).
fn hopf(
    lin: &dyn Fn(f64) -> Result<Linearisation, StudyError>,
    (mut a, mut za): (f64, [f64; 2]),
    (mut b, mut zb): (f64, [f64; 2]),
) -> Result<(f64, [f64; 2]), StudyError> {
    for _ in 0..200 {
        if small(a, b) {
            break;
        }
        let m = 0.5 * (a + b);
        let l = lin(m)?;
        let guess = [0.5 * (za[0] + zb[0]), 0.5 * (za[1] + zb[1])];
        let upper: Vec<[f64; 2]> = l
            .eigenvalues
            .iter()
            .copied()
            .filter(|z| z[1] > 0.0)
            .collect();
        let Some(z) = nearest(&upper, guess) else {
            break;
        };
        if z[0].signum() == za[0].signum() {
            a = m;
            za = z;
        } else {
            b = m;
            zb = z;
        }
    }
    // The end whose real part is nearer zero.
    Ok(if za[0].abs() < zb[0].abs() {
        (a, za)
    } else {
        (b, zb)
    })
}
