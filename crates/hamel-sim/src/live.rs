//! Values a system reads at every evaluation: the time itself, or an input tabulated in time
//! ([`Table`]: samples with linear or cubic interpolation, and what happens outside them).
//!
//! A table is checked whole when it is made ([`Table::new`]: at least two samples, finite,
//! times strictly increasing), so that [`Table::at`] has no failure but a time outside it.

use serde::{Deserialize, Serialize};

use crate::SystemError;

/// How a table is read between its samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Interpolation {
    /// Straight lines between samples (continuous, kinks at the samples).
    #[default]
    Linear,
    /// The natural cubic spline through the samples (C², zero second derivative at both ends).
    Cubic,
}

/// What a table gives outside its first and last sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Outside {
    /// An error: the run stops there.
    #[default]
    Error,
    /// The first (before) or last (after) sample's value.
    Hold,
}

/// Why samples do not make a table.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TableError {
    /// Fewer than two samples.
    #[error("a table needs at least two samples, this one has {0}")]
    TooShort(usize),
    /// Times and values of different lengths.
    #[error("{times} times but {values} values")]
    Lengths {
        /// Number of times.
        times: usize,
        /// Number of values.
        values: usize,
    },
    /// A time or value that is NaN or infinite (sample index from 0).
    #[error("sample {0} is not finite")]
    NotFinite(usize),
    /// Times not strictly increasing: sample `index` (from 0) is not after the one before.
    #[error(
        "the times are not increasing: t = {time} at sample {index} does not come after t = {before}"
    )]
    NotIncreasing {
        /// The sample (from 0).
        index: usize,
        /// Its time.
        time: f64,
        /// The time of the sample before.
        before: f64,
    },
}

/// An input tabulated in time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Samples", into = "Samples")]
pub struct Table {
    samples: Samples,
    /// For a cubic table, the spline's second derivatives at the samples.
    second: Vec<f64>,
}

/// A table as written: its samples and how it is read.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Samples {
    /// The times, strictly increasing.
    pub times: Vec<f64>,
    /// The values at those times.
    pub values: Vec<f64>,
    /// Between samples.
    #[serde(default)]
    pub interpolation: Interpolation,
    /// Outside them.
    #[serde(default)]
    pub outside: Outside,
}

impl TryFrom<Samples> for Table {
    type Error = TableError;
    fn try_from(s: Samples) -> Result<Table, TableError> {
        Table::new(s)
    }
}

impl From<Table> for Samples {
    fn from(t: Table) -> Samples {
        t.samples
    }
}

impl Table {
    /// The table of `samples`, checked (see the module doc).
    pub fn new(samples: Samples) -> Result<Table, TableError> {
        let (t, v) = (&samples.times, &samples.values);
        if t.len() != v.len() {
            return Err(TableError::Lengths {
                times: t.len(),
                values: v.len(),
            });
        }
        if t.len() < 2 {
            return Err(TableError::TooShort(t.len()));
        }
        if let Some(i) = (0..t.len()).find(|&i| !t[i].is_finite() || !v[i].is_finite()) {
            return Err(TableError::NotFinite(i));
        }
        if let Some(i) = (1..t.len()).find(|&i| t[i] <= t[i - 1]) {
            return Err(TableError::NotIncreasing {
                index: i,
                time: t[i],
                before: t[i - 1],
            });
        }
        let second = match samples.interpolation {
            Interpolation::Linear => Vec::new(),
            Interpolation::Cubic => natural_spline(t, v),
        };
        Ok(Table { samples, second })
    }

    /// The samples.
    pub fn samples(&self) -> &Samples {
        &self.samples
    }

    /// The first and last time.
    pub fn span(&self) -> (f64, f64) {
        let t = &self.samples.times;
        (t[0], t[t.len() - 1])
    }

    /// The value at time `t`; None outside the table when it says [`Outside::Error`].
    pub fn at(&self, t: f64) -> Option<f64> {
        let (times, values) = (&self.samples.times, &self.samples.values);
        let (first, last) = self.span();
        if !(first..=last).contains(&t) {
            return match self.samples.outside {
                Outside::Error => None,
                Outside::Hold if t < first => Some(values[0]),
                Outside::Hold => Some(values[values.len() - 1]),
            };
        }
        // The interval [t_i, t_{i+1}] holding t.
        let i = times.partition_point(|&s| s <= t).clamp(1, times.len() - 1) - 1;
        let h = times[i + 1] - times[i];
        let b = (t - times[i]) / h;
        let a = 1.0 - b;
        let linear = a * values[i] + b * values[i + 1];
        if self.second.is_empty() {
            return Some(linear);
        }
        let m = &self.second;
        Some(linear + ((a * a * a - a) * m[i] + (b * b * b - b) * m[i + 1]) * h * h / 6.0)
    }
}

/// The second derivatives of the natural cubic spline through (t, v): the tridiagonal system
/// solved by the Thomas algorithm (diagonally dominant, so stable without pivoting).
fn natural_spline(t: &[f64], v: &[f64]) -> Vec<f64> {
    let n = t.len();
    let mut m = vec![0.0; n];
    if n < 3 {
        return m;
    }
    // Rows 1..n-1: h_{i-1} m_{i-1} + 2(h_{i-1} + h_i) m_i + h_i m_{i+1} = 6 (slope_i − slope_{i-1}).
    let h: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    let slope: Vec<f64> = (0..n - 1).map(|i| (v[i + 1] - v[i]) / h[i]).collect();
    let mut diag = vec![0.0; n];
    let mut rhs = vec![0.0; n];
    for i in 1..n - 1 {
        diag[i] = 2.0 * (h[i - 1] + h[i]);
        rhs[i] = 6.0 * (slope[i] - slope[i - 1]);
    }
    for i in 2..n - 1 {
        let w = h[i - 1] / diag[i - 1];
        diag[i] -= w * h[i - 1];
        rhs[i] -= w * rhs[i - 1];
    }
    for i in (1..n - 1).rev() {
        m[i] = (rhs[i] - h[i] * m[i + 1]) / diag[i];
    }
    m
}

/// What sets one live parameter at every evaluation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
pub enum Live {
    /// The time t.
    Time,
    /// An input read from a table: its name (for messages) and the table.
    Table {
        /// The input's name.
        name: String,
        /// Its table.
        table: Table,
    },
}

impl Live {
    /// The value at time `t`; an error outside a table that says [`Outside::Error`].
    #[inline]
    pub fn at(&self, t: f64) -> Result<f64, SystemError> {
        match self {
            Live::Time => Ok(t),
            Live::Table { name, table } => table.at(t).ok_or_else(|| {
                let (a, b) = table.span();
                SystemError::new(format!(
                    "t = {t} is outside the table of the input {name}, which covers [{a}, {b}] (a scene may say outside = \"hold\")"
                ))
            }),
        }
    }
}

/// The values of `live` at time `t` into `out` (one each, in order).
pub fn live_values(live: &[Live], t: f64, out: &mut [f64]) -> Result<(), SystemError> {
    for (o, l) in out.iter_mut().zip(live) {
        *o = l.at(t)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(times: &[f64], values: &[f64], i: Interpolation, o: Outside) -> Table {
        Table::new(Samples {
            times: times.to_vec(),
            values: values.to_vec(),
            interpolation: i,
            outside: o,
        })
        .unwrap()
    }

    #[test]
    fn linear_tables_interpolate_and_hold_or_refuse_outside() {
        let t = table(
            &[0.0, 1.0, 3.0],
            &[0.0, 2.0, 0.0],
            Interpolation::Linear,
            Outside::Error,
        );
        assert_eq!(t.at(0.5), Some(1.0));
        assert_eq!(t.at(2.0), Some(1.0));
        assert_eq!(t.at(3.0), Some(0.0));
        assert_eq!(t.at(3.0 + 1e-12), None);
        let h = table(
            &[0.0, 1.0],
            &[1.0, 2.0],
            Interpolation::Linear,
            Outside::Hold,
        );
        assert_eq!((h.at(-5.0), h.at(7.0)), (Some(1.0), Some(2.0)));
        let live = Live::Table {
            name: "T".into(),
            table: t,
        };
        let e = live.at(-1.0).unwrap_err().message;
        assert!(e.contains("input T") && e.contains("[0, 3]"), "{e}");
    }

    #[test]
    fn cubic_tables_reproduce_a_cubic_free_at_the_ends_and_pass_the_samples() {
        // A natural spline is exact for a line; through samples of sin it is close inside.
        let times: Vec<f64> = (0..=40).map(|i| f64::from(i) * 0.1).collect();
        let line: Vec<f64> = times.iter().map(|t| 3.0 * t - 1.0).collect();
        let c = table(&times, &line, Interpolation::Cubic, Outside::Error);
        for k in 0..400 {
            let t = f64::from(k) * 0.01;
            assert!((c.at(t).unwrap() - (3.0 * t - 1.0)).abs() < 1e-12);
        }
        let sines: Vec<f64> = times.iter().map(|t| t.sin()).collect();
        let s = table(&times, &sines, Interpolation::Cubic, Outside::Error);
        for (t, v) in times.iter().zip(&sines) {
            assert!((s.at(*t).unwrap() - v).abs() < 1e-14);
        }
        let err = (100..300)
            .map(|k| f64::from(k) * 0.01 + 0.005)
            .map(|t| (s.at(t).unwrap() - t.sin()).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-6, "{err}");
    }

    #[test]
    fn bad_samples_are_refused_with_the_reason() {
        let make = |t: &[f64], v: &[f64]| {
            Table::new(Samples {
                times: t.to_vec(),
                values: v.to_vec(),
                interpolation: Interpolation::Linear,
                outside: Outside::Error,
            })
        };
        assert_eq!(make(&[0.0], &[1.0]), Err(TableError::TooShort(1)));
        assert!(matches!(
            make(&[0.0, 1.0, 1.0], &[1.0, 2.0, 3.0]),
            Err(TableError::NotIncreasing { index: 2, .. })
        ));
        assert_eq!(
            make(&[0.0, f64::NAN], &[1.0, 2.0]),
            Err(TableError::NotFinite(1))
        );
        let json = r#"{"times": [1, 0], "values": [0, 0]}"#;
        assert!(serde_json::from_str::<Table>(json).is_err());
    }
}
