//! What a page draws of a mechanism, fixed in time: the solids on their frames, the contacts
//! whose tracks it draws, the bodies it reports. Numbers only: every size is evaluated once at
//! the scene's parameters (and at its initial configuration, for a direction that a model
//! writes as an expression).
//!
//! * A wheel is a disk of its radius about its axis (`Form::Wheel`, a tenth of the radius
//!   thick, with a spoke so that its spin shows).
//! * A blade is a thin plate along its direction, standing on its contact point (its height
//!   along the frame's direction nearest to up at the start).
//! * A `[shapes.NAME]` is drawn as given, on its frame.
//! * A body on a frame that carries no wheel and no shape is the ellipsoid of its mass and
//!   principal moments ([`crate::shapes`]); a point mass, or moments no solid has, a small
//!   sphere.

use hamel_bodies::{Axis, Direction, Geometry, Mechanism, Point, Surface};
use hamel_expr::Expr;
use indexmap::IndexMap;
use nalgebra::{UnitQuaternion, Vector3};
use serde::Serialize;

use crate::poses::{Pose, PoseError, poses, rotate};
use crate::shapes::{Solid, equivalent};

/// A palette that reads on a light background (Tableau 10).
pub const PALETTE: [[u8; 3]; 6] = [
    [78, 121, 167],
    [242, 142, 43],
    [89, 161, 79],
    [225, 87, 89],
    [176, 122, 161],
    [237, 201, 72],
];

/// What a page draws of a mechanism.
#[derive(Clone, Debug, Serialize)]
pub struct Drawing {
    /// The world's up, a unit vector.
    pub up: [f64; 3],
    /// The frames whose poses the page holds (those that carry something), by name.
    pub frames: Vec<String>,
    /// The solids.
    pub drawn: Vec<Drawn>,
    /// Each body's frame (index into `frames`), by body name: the poses the page reports.
    pub bodies: IndexMap<String, usize>,
    /// The contacts whose tracks the page draws, wheels then blades.
    pub contacts: Vec<Contact>,
    /// A length for the page's sizes (arrows, axes, the camera's distance): the largest
    /// solid's half-extent or the spread of the frames at the start, at least 0.1.
    pub scale: f64,
}

/// A solid on a frame.
#[derive(Clone, Debug, Serialize)]
pub struct Drawn {
    /// The wheel's, blade's, shape's or body's name.
    pub name: String,
    /// Its frame (index into [`Drawing::frames`]).
    pub frame: usize,
    /// Its centre in the frame's axes.
    pub centre: [f64; 3],
    /// The rotation (w, x, y, z) from the frame's axes to the solid's own.
    pub rotation: [f64; 4],
    /// Red, green, blue.
    pub colour: [u8; 3],
    /// What it is.
    pub form: Form,
}

/// A solid in its own axes (as three.js builds them: a cylinder and a disk about y).
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Form {
    /// A box of these half-sides.
    Box { half: [f64; 3] },
    /// An ellipsoid of these semi-axes.
    Ellipsoid { half: [f64; 3] },
    /// A cylinder about y.
    Cylinder { radius: f64, length: f64 },
    /// A sphere.
    Sphere { radius: f64 },
    /// A wheel: a disk about y with a spoke.
    Wheel { radius: f64, width: f64 },
}

/// A point of contact with the ground, tracked over time.
#[derive(Clone, Debug, Serialize)]
pub struct Contact {
    /// The wheel's or blade's name.
    pub name: String,
    /// Where the point is.
    #[serde(skip)]
    pub at: ContactPoint,
}

/// How a contact point follows its frame.
#[derive(Clone, Debug)]
pub enum ContactPoint {
    /// A wheel's lowest point: its centre (the frame's origin) minus the radius along the
    /// downward direction in the wheel's plane.
    Wheel {
        /// The frame's name.
        frame: String,
        /// The radius (a tyre's major radius).
        radius: f64,
        /// A tyre's crown radius (0: a thin disk): the contact lies that much further down.
        crown: f64,
        /// The spin axis in the frame's axes.
        axis: [f64; 3],
    },
    /// A rolling body's lowest point: the surface's support point at the downward direction
    /// (an ellipsoid centre − (a²u₁, b²u₂, c²u₃)/s, u = up in the frame's axes; a sphere has
    /// equal semi-axes).
    Roller {
        /// The frame's name.
        frame: String,
        /// The surface's centre in the frame's axes.
        centre: [f64; 3],
        /// Its semi-axes along the frame's axes.
        semi_axes: [f64; 3],
    },
    /// A blade's point, fixed in its frame.
    Blade {
        /// The frame's name.
        frame: String,
        /// The point in the frame's axes.
        point: [f64; 3],
        /// The blade's direction in the frame's axes (unit).
        direction: [f64; 3],
    },
}

/// Why a mechanism cannot be drawn.
#[derive(Clone, Debug, thiserror::Error)]
pub enum DrawError {
    /// A frame's pose at the start.
    #[error(transparent)]
    Pose(#[from] PoseError),
    /// A size or direction does not evaluate to a finite number.
    #[error("{what} `{name}`: {why}")]
    Evaluation {
        /// wheel, blade, shape or body.
        what: &'static str,
        /// Its name.
        name: String,
        /// Why.
        why: String,
    },
}

impl Drawing {
    /// What `m` draws, its sizes evaluated at `params` and the configuration `q0`.
    pub fn of(
        m: &Mechanism,
        q0: &[f64],
        params: &IndexMap<String, f64>,
    ) -> Result<Drawing, DrawError> {
        let start = poses(m, q0, params)?;
        let up = axis_vector(m.world.up);
        let mut d = Builder {
            point: Point::at(&m.coordinates, q0, params),
            up,
            start: &start,
            drawing: Drawing {
                up,
                frames: Vec::new(),
                drawn: Vec::new(),
                bodies: IndexMap::new(),
                contacts: Vec::new(),
                scale: 0.0,
            },
        };
        d.wheels(m)?;
        d.rollers(m)?;
        d.blades(m)?;
        d.shapes(m)?;
        d.bodies(m)?;
        d.drawing.scale = d.scale();
        Ok(d.drawing)
    }
}

/// A signed coordinate axis as a unit vector.
fn axis_vector(a: Axis) -> [f64; 3] {
    let mut v = [0.0; 3];
    v[a.index] = a.sign as f64;
    v
}

struct Builder<'a> {
    point: Point<'a>,
    up: [f64; 3],
    start: &'a IndexMap<String, Pose>,
    drawing: Drawing,
}

impl Builder<'_> {
    /// The index of `frame` in the drawing's frames, added on first use.
    fn frame(&mut self, frame: &str) -> usize {
        let frames = &mut self.drawing.frames;
        frames.iter().position(|f| f == frame).unwrap_or_else(|| {
            frames.push(frame.to_string());
            frames.len() - 1
        })
    }

    fn value(&self, what: &'static str, name: &str, e: &Expr) -> Result<f64, DrawError> {
        self.point.value(e).map_err(|p| DrawError::Evaluation {
            what,
            name: name.to_string(),
            why: p.to_string(),
        })
    }

    fn direction(
        &self,
        what: &'static str,
        name: &str,
        d: &Direction,
    ) -> Result<[f64; 3], DrawError> {
        let v = d.vector();
        let v = [
            self.value(what, name, &v[0])?,
            self.value(what, name, &v[1])?,
            self.value(what, name, &v[2])?,
        ];
        let n = norm(v);
        if n.is_nan() || n <= 0.0 {
            return Err(DrawError::Evaluation {
                what,
                name: name.to_string(),
                why: "a direction of zero length".into(),
            });
        }
        Ok(v.map(|c| c / n))
    }

    fn push(
        &mut self,
        name: &str,
        frame: &str,
        centre: [f64; 3],
        rotation: [f64; 4],
        form: Form,
        colour: Option<[u8; 3]>,
    ) {
        let frame = self.frame(frame);
        let colour = colour.unwrap_or(PALETTE[self.drawing.drawn.len() % PALETTE.len()]);
        self.drawing.drawn.push(Drawn {
            name: name.to_string(),
            frame,
            centre,
            rotation,
            colour,
            form,
        });
    }

    fn wheels(&mut self, m: &Mechanism) -> Result<(), DrawError> {
        for w in &m.wheels {
            let radius = self.value("wheel", &w.name, &w.radius)?;
            let crown = match &w.crown {
                Some(c) => self.value("wheel", &w.name, c)?,
                None => 0.0,
            };
            let axis = self.direction("wheel", &w.name, &w.axis)?;
            // A tyre is drawn as the disk through its crown's outer edge, as wide as the crown.
            let form = Form::Wheel {
                radius: radius + crown,
                width: (2.0 * crown).max(0.1 * radius),
            };
            self.push(
                &w.name,
                &w.frame,
                [0.0; 3],
                from_y(axis),
                form,
                Some([60, 60, 66]),
            );
            self.drawing.contacts.push(Contact {
                name: w.name.clone(),
                at: ContactPoint::Wheel {
                    frame: w.frame.clone(),
                    radius,
                    crown,
                    axis,
                },
            });
        }
        Ok(())
    }

    /// A rolling body: its sphere or ellipsoid about its centre.
    fn rollers(&mut self, m: &Mechanism) -> Result<(), DrawError> {
        for r in &m.rollers {
            let v = |e: &Expr| self.value("rolling body", &r.name, e);
            let centre = [v(&r.centre[0])?, v(&r.centre[1])?, v(&r.centre[2])?];
            let (form, semi_axes) = match &r.surface {
                Surface::Sphere { radius } => {
                    let radius = v(radius)?;
                    (Form::Sphere { radius }, [radius; 3])
                }
                Surface::Ellipsoid { semi_axes } => {
                    let half = [v(&semi_axes[0])?, v(&semi_axes[1])?, v(&semi_axes[2])?];
                    (Form::Ellipsoid { half }, half)
                }
            };
            self.push(&r.name, &r.frame, centre, IDENTITY, form, None);
            self.drawing.contacts.push(Contact {
                name: r.name.clone(),
                at: ContactPoint::Roller {
                    frame: r.frame.clone(),
                    centre,
                    semi_axes,
                },
            });
        }
        Ok(())
    }

    /// A blade: a plate standing on its point, along its direction, its height along the
    /// frame's direction nearest to up at the start (perpendicular to the blade).
    fn blades(&mut self, m: &Mechanism) -> Result<(), DrawError> {
        for b in &m.blades {
            let along = self.direction("blade", &b.name, &b.direction)?;
            let point = [
                self.value("blade", &b.name, &b.point[0])?,
                self.value("blade", &b.name, &b.point[1])?,
                self.value("blade", &b.name, &b.point[2])?,
            ];
            let pose = self.start[&b.frame];
            // up in the frame's axes, made perpendicular to the blade.
            let inverse = [
                pose.rotation[0],
                -pose.rotation[1],
                -pose.rotation[2],
                -pose.rotation[3],
            ];
            let up = rotate(inverse, self.up);
            let a = Vector3::from(along);
            let h = Vector3::from(up) - a * a.dot(&Vector3::from(up));
            let h = if h.norm() > 1e-9 {
                h.normalize()
            } else {
                a.cross(&Vector3::z()).normalize()
            };
            let side = h.cross(&a);
            let frame = nalgebra::Matrix3::from_columns(&[a, side, h]);
            let rotation = UnitQuaternion::from_matrix(&frame);
            let (length, height) = (0.3, 0.06);
            let centre = [0, 1, 2].map(|i| point[i] + h[i] * height / 2.0);
            let form = Form::Box {
                half: [length / 2.0, 0.004, height / 2.0],
            };
            self.push(
                &b.name,
                &b.frame,
                centre,
                quaternion(rotation),
                form,
                Some([90, 90, 100]),
            );
            self.drawing.contacts.push(Contact {
                name: b.name.clone(),
                at: ContactPoint::Blade {
                    frame: b.frame.clone(),
                    point,
                    direction: along,
                },
            });
        }
        Ok(())
    }

    fn shapes(&mut self, m: &Mechanism) -> Result<(), DrawError> {
        for s in &m.shapes {
            let v = |e: &Expr| self.value("shape", &s.name, e);
            let centre = [v(&s.centre[0])?, v(&s.centre[1])?, v(&s.centre[2])?];
            let (form, rotation) = match &s.geometry {
                Geometry::Box { size } => {
                    let half = [v(&size[0])? / 2.0, v(&size[1])? / 2.0, v(&size[2])? / 2.0];
                    (Form::Box { half }, IDENTITY)
                }
                Geometry::Cylinder {
                    radius,
                    length,
                    axis,
                } => {
                    let form = Form::Cylinder {
                        radius: v(radius)?,
                        length: v(length)?,
                    };
                    (form, from_y(axis_vector(*axis)))
                }
                Geometry::Sphere { radius } => (Form::Sphere { radius: v(radius)? }, IDENTITY),
            };
            self.push(&s.name, &s.frame, centre, rotation, form, s.colour);
        }
        Ok(())
    }

    /// Bodies on frames without a wheel or a shape, as their inertia's ellipsoid; every body's
    /// frame reported.
    fn bodies(&mut self, m: &Mechanism) -> Result<(), DrawError> {
        let covered = |frame: &str| {
            m.wheels.iter().any(|w| w.frame == frame)
                || m.rollers.iter().any(|r| r.frame == frame)
                || m.shapes.iter().any(|s| s.frame == frame)
        };
        for b in &m.bodies {
            let frame = self.frame(&b.frame);
            self.drawing.bodies.insert(b.name.clone(), frame);
            if covered(&b.frame) {
                continue;
            }
            let v = |e: &Expr| self.value("body", &b.name, e);
            let centre = [
                v(&b.centre_of_mass[0])?,
                v(&b.centre_of_mass[1])?,
                v(&b.centre_of_mass[2])?,
            ];
            let mass = v(&b.mass)?;
            let solid = match &b.inertia {
                Some(i) => {
                    let m = i.matrix();
                    let mut n = [[0.0; 3]; 3];
                    for r in 0..3 {
                        for c in 0..3 {
                            n[r][c] = v(&m[r][c])?;
                        }
                    }
                    equivalent(Solid::Ellipsoid, mass, n)
                        .filter(|e| e.half.iter().all(|h| *h > 1e-6))
                }
                None => None,
            };
            let (form, rotation) = match solid {
                Some(e) => (Form::Ellipsoid { half: e.half }, e.rotation),
                None => (Form::Sphere { radius: 0.0 }, IDENTITY),
            };
            self.push(&b.name, &b.frame, centre, rotation, form, None);
        }
        Ok(())
    }

    /// The largest half-extent of a solid, or the spread of the frames at the start.
    fn scale(&mut self) -> f64 {
        let mut scale: f64 = 0.1;
        for d in &self.drawing.drawn {
            scale = scale.max(match &d.form {
                Form::Box { half } | Form::Ellipsoid { half } => {
                    half.iter().copied().fold(0.0, f64::max)
                }
                Form::Cylinder { radius, length } => radius.max(length / 2.0),
                Form::Sphere { radius } | Form::Wheel { radius, .. } => *radius,
            });
        }
        let at: Vec<[f64; 3]> = self
            .drawing
            .frames
            .iter()
            .map(|f| self.start[f].position)
            .collect();
        for a in &at {
            for b in &at {
                scale = scale.max(0.5 * norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]]));
            }
        }
        // A point mass (or moments no solid has) is a sphere of a tenth of the scale.
        for d in &mut self.drawing.drawn {
            if let Form::Sphere { radius } = &mut d.form
                && *radius == 0.0
            {
                *radius = 0.1 * scale;
            }
        }
        scale
    }
}

impl Contact {
    /// The contact point in world coordinates, the frames placed at `placed`, up `up`.
    pub fn position(&self, placed: &IndexMap<String, Pose>, up: [f64; 3]) -> [f64; 3] {
        match &self.at {
            ContactPoint::Blade { frame, point, .. } => placed[frame].apply(*point),
            ContactPoint::Roller {
                frame,
                centre,
                semi_axes,
            } => {
                let pose = placed[frame];
                let inverse = [
                    pose.rotation[0],
                    -pose.rotation[1],
                    -pose.rotation[2],
                    -pose.rotation[3],
                ];
                let u = rotate(inverse, up);
                let w = [0, 1, 2].map(|i| semi_axes[i] * semi_axes[i] * u[i]);
                let s = (0..3).map(|i| u[i] * w[i]).sum::<f64>().sqrt();
                pose.apply([0, 1, 2].map(|i| centre[i] - w[i] / s))
            }
            ContactPoint::Wheel {
                frame,
                radius,
                crown,
                axis,
            } => {
                let pose = placed[frame];
                let a = rotate(pose.rotation, *axis);
                let along: f64 = (0..3).map(|i| up[i] * a[i]).sum();
                let down = [0, 1, 2].map(|i| along * a[i] - up[i]);
                let n = norm(down);
                let c = pose.position;
                if n < 1e-12 {
                    // The wheel lies flat: its lowest points form a circle; its centre's foot.
                    return [0, 1, 2].map(|i| c[i] - up[i] * (radius + crown));
                }
                [0, 1, 2].map(|i| c[i] + radius * down[i] / n - crown * up[i])
            }
        }
    }
}

const IDENTITY: [f64; 4] = [1.0, 0.0, 0.0, 0.0];

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn quaternion(q: UnitQuaternion<f64>) -> [f64; 4] {
    [q.w, q.i, q.j, q.k]
}

/// The rotation taking y to the unit vector `a` (three.js builds cylinders about y).
fn from_y(a: [f64; 3]) -> [f64; 4] {
    let r =
        UnitQuaternion::rotation_between(&Vector3::y(), &Vector3::from(a)).unwrap_or_else(|| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
    quaternion(r)
}
