//! The requested outputs of a solution, and their errors against a reference: what
//! [`crate::tradeoff`] measures and [`crate::simulate`]'s error estimate reports.

use hamel_sim::Solution;

use crate::load::Loaded;

/// The requested outputs of a solution, per output time: the requested state components, the
/// energy when requested (and `energy`), then the requested expressions.
pub fn outputs(loaded: &Loaded, s: &Solution, energy: bool) -> Vec<Vec<f64>> {
    let ix = loaded.requested_components();
    let expressions = loaded.evaluate_expressions(s);
    s.y.iter()
        .zip(&s.energy)
        .enumerate()
        .map(|(j, (y, e))| {
            ix.iter()
                .map(|&i| y[i])
                .chain((energy && loaded.request.energy).then(|| e.unwrap_or(f64::NAN)))
                .chain(expressions.values().map(|v| v[j].unwrap_or(f64::NAN)))
                .collect()
        })
        .collect()
}

/// The errors of one solution's outputs against a reference's, each relative to
/// max(1, |reference|); infinite where a value is not a number or the run stopped early.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    /// At the end time.
    pub end: f64,
    /// The largest over the output times.
    pub span: f64,
    /// The largest |y − y_ref| / (atol + rtol·|y_ref|): at most 1 meets the target.
    pub ratio: f64,
}

/// The [`Errors`] of `got` against `reference`, for the target (rtol, atol).
pub fn errors(got: &[Vec<f64>], reference: &[Vec<f64>], target: (f64, f64)) -> Errors {
    let (mut end, mut span, mut ratio) = (0.0_f64, 0.0_f64, 0.0_f64);
    for (j, (g, r)) in got.iter().zip(reference).enumerate() {
        for (a, b) in g.iter().zip(r) {
            let d = (a - b).abs();
            let e = if d.is_nan() {
                f64::INFINITY
            } else {
                d / b.abs().max(1.0)
            };
            span = span.max(e);
            ratio = ratio.max(if d.is_nan() {
                f64::INFINITY
            } else {
                d / (target.1 + target.0 * b.abs())
            });
            if j + 1 == reference.len() {
                end = end.max(e);
            }
        }
    }
    if got.len() < reference.len() {
        // An incomplete run has no error to compare at the missing times.
        return Errors {
            end: f64::INFINITY,
            span: f64::INFINITY,
            ratio: f64::INFINITY,
        };
    }
    Errors { end, span, ratio }
}
