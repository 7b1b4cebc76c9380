//! One simulated motion as a page holds it: at each output time, the pose of every drawn frame
//! and the point of every contact; beside them the scene's requested outputs (plotted) and the
//! contacts' forces (drawn as arrows).

use hamel_bodies::{ContactForces, ContactKind, Mechanism, Point};
use indexmap::IndexMap;

use crate::drawing::{ContactPoint, Drawing};
use crate::poses::{Pose, PoseError, poses, rotate};

/// A motion at its output times.
#[derive(Clone, Debug, Default)]
pub struct Motion {
    /// What the page calls it (an ensemble member's label; empty for a single run).
    pub label: String,
    /// The output times, increasing.
    pub t: Vec<f64>,
    /// Per time, per frame of the drawing: the position (3) and the unit quaternion (w, x, y,
    /// z): 7 numbers.
    pub poses: Vec<f64>,
    /// Per time, per contact of the drawing: its point (3).
    pub tracks: Vec<f64>,
    /// The outputs plotted against time.
    pub series: Vec<Series>,
    /// The contacts' forces as vectors in the world's axes.
    pub arrows: Vec<Arrow>,
}

/// One output against time (None where it has no value).
#[derive(Clone, Debug)]
pub struct Series {
    /// Its name, as the scene requests it.
    pub name: String,
    /// Its values at the motion's times.
    pub values: Vec<Option<f64>>,
}

/// The force the ground pushes a contact with, at each output time.
#[derive(Clone, Debug)]
pub struct Arrow {
    /// The contact's name.
    pub name: String,
    /// The contact (index into [`Drawing::contacts`]).
    pub contact: usize,
    /// Per time, the force in the world's axes (3; NaN where it has no value).
    pub vectors: Vec<f64>,
}

impl Motion {
    /// The poses and contact points of `drawing` along the configurations `q` (every
    /// coordinate of `m`, one per time of `t`), at the parameters `params`.
    pub fn place(
        label: &str,
        m: &Mechanism,
        drawing: &Drawing,
        params: &IndexMap<String, f64>,
        t: &[f64],
        q: &[Vec<f64>],
    ) -> Result<Motion, PoseError> {
        let mut motion = Motion {
            label: label.to_string(),
            t: t.to_vec(),
            ..Motion::default()
        };
        for qi in q {
            let placed = poses(m, qi, params)?;
            for f in &drawing.frames {
                let p = placed[f];
                motion.poses.extend(p.position);
                motion.poses.extend(p.rotation);
            }
            for c in &drawing.contacts {
                motion.tracks.extend(c.position(&placed, drawing.up));
            }
        }
        Ok(motion)
    }

    /// Motion without a mechanism: times and outputs only.
    pub fn outputs_only(label: &str, t: &[f64]) -> Motion {
        Motion {
            label: label.to_string(),
            t: t.to_vec(),
            ..Motion::default()
        }
    }

    /// Arrows for the contacts whose forces `columns` hold (`force.NAME.longitudinal`,
    /// `.lateral`, `.normal`; a missing component counts 0), the rolling and lateral
    /// directions evaluated along `q` as the model's contact forces define them.
    pub fn add_arrows(
        &mut self,
        m: &Mechanism,
        drawing: &Drawing,
        contact_forces: &ContactForces,
        params: &IndexMap<String, f64>,
        q: &[Vec<f64>],
        columns: &IndexMap<String, Vec<Option<f64>>>,
    ) -> Result<(), PoseError> {
        for (k, c) in drawing.contacts.iter().enumerate() {
            let column = |axis: &str| columns.get(&format!("force.{}.{axis}", c.name));
            let parts = [column("longitudinal"), column("lateral"), column("normal")];
            if parts.iter().all(Option::is_none) {
                continue;
            }
            let Some(kind) = contact_forces.contacts.iter().find(|x| x.name == c.name) else {
                continue;
            };
            let mut vectors = Vec::with_capacity(3 * q.len());
            for (i, qi) in q.iter().enumerate() {
                let value = |p: Option<&Vec<Option<f64>>>| p.map_or(Some(0.0), |v| v[i]);
                let [long, lat, normal] = parts.map(value);
                let point = Point::at(&m.coordinates, qi, params);
                let placed = poses(m, qi, params)?;
                let directions = directions(&kind.kind, &c.at, drawing.up, &point, &placed)?;
                match (long, lat, normal) {
                    (Some(a), Some(b), Some(n)) => {
                        vectors.extend((0..3).map(|j| {
                            a * directions[0][j] + b * directions[1][j] + n * drawing.up[j]
                        }))
                    }
                    _ => vectors.extend([f64::NAN; 3]),
                }
            }
            self.arrows.push(Arrow {
                name: c.name.clone(),
                contact: k,
                vectors,
            });
        }
        Ok(())
    }
}

/// A contact's rolling (forwards) and lateral directions in the world's axes at `q`: a wheel's
/// as its force's definition evaluates them, a blade's lateral one up × its direction.
fn directions(
    kind: &ContactKind,
    at: &ContactPoint,
    up: [f64; 3],
    point: &Point,
    placed: &IndexMap<String, Pose>,
) -> Result<[[f64; 3]; 2], PoseError> {
    match (kind, at) {
        (ContactKind::Wheel(w), _) => {
            let horizontal = (0..3).filter(|&j| up[j] == 0.0);
            let mut out = [[0.0; 3]; 2];
            for (d, exprs) in [&w.rolling, &w.lateral].into_iter().enumerate() {
                for (j, e) in horizontal.clone().zip(exprs) {
                    out[d][j] = point.value(e).map_err(|p| PoseError::Evaluation {
                        frame: String::new(),
                        why: p.to_string(),
                    })?;
                }
            }
            Ok(out)
        }
        (
            ContactKind::Blade { .. },
            ContactPoint::Blade {
                frame, direction, ..
            },
        ) => {
            let lateral = cross(up, rotate(placed[frame].rotation, *direction));
            let n = lateral.iter().map(|x| x * x).sum::<f64>().sqrt();
            Ok([[0.0; 3], lateral.map(|x| x / n.max(f64::MIN_POSITIVE))])
        }
        _ => Ok([[0.0; 3]; 2]),
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
