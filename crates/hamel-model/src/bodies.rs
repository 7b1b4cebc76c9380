//! Reading a model given by bodies, frames and rolling wheels (`[world]`, `[frames.*]`,
//! `[bodies.*]`, `[wheels.*]`, `[rolling.*]`, `[blades.*]`, `[holonomic.*]`): every field parsed and resolved
//! with its place in the file, the mechanism expanded by `hamel-bodies` into A, U and the rows
//! of α, and any problem it finds located at the field it names.

use std::collections::HashMap;
use std::ops::Range;

use hamel_bodies::{
    Anchor, Axis, Blade, BodiesError, Body, Completion, Damper, Direction, Frame, Holonomic,
    HolonomicConstraint, Inertia, Load, LoadKind, Mechanism, Place, Roller, Rotation, Row, Section,
    Spring, Stretch, Surface, WORLD, Wheel, World,
};
use hamel_expr::Expr;
use toml::Spanned;

use crate::error::ModelError;
use crate::loader::{Dynamics, ErrorAt, FieldKind, Item, Kinetic, Loader, Origin};
use crate::schema::{RawAnchor, RawDirection, RawModel, RawScalar, RawVector};

/// The places of the description's fields: key path → span.
#[derive(Default)]
pub(crate) struct Sites(HashMap<String, Range<usize>>);

impl Sites {
    /// The span of `key`, or of its nearest enclosing entry.
    pub fn span(&self, key: &str) -> Range<usize> {
        let mut k = key;
        loop {
            if let Some(s) = self.0.get(k) {
                return s.clone();
            }
            match k.rfind('.') {
                Some(i) => k = &k[..i],
                None => return 0..0,
            }
        }
    }

    fn note(&mut self, key: &str, span: Range<usize>) {
        self.0.insert(key.to_string(), span);
    }
}

/// Whether the file describes bodies (then it gives no `[lagrangian]`).
pub(crate) fn describes_bodies(raw: &RawModel) -> bool {
    raw.world.is_some()
        || !raw.frames.is_empty()
        || !raw.bodies.is_empty()
        || !raw.wheels.is_empty()
        || !raw.rolling.is_empty()
        || !raw.blades.is_empty()
}

/// L and α from the file's bodies: A, U and the rows of α expanded by `hamel-bodies`, any
/// problem located at the field it names.
pub(crate) fn dynamics(
    raw: &RawModel,
    loader: &mut Loader,
    err: &ErrorAt,
) -> Result<Dynamics, ModelError> {
    if let Some(l) = &raw.lagrangian {
        return Err(err(
            l.span(),
            "lagrangian",
            "a model of bodies derives T and U from them: give [lagrangian] or bodies, not both"
                .into(),
        ));
    }
    let mut sites = Sites::default();
    let mechanism = mechanism(raw, loader, &mut sites, err)?;
    let samples = crate::sample_configurations(mechanism.coordinates.len(), 8, 23);
    let values = loader.parameters.clone();
    let e =
        hamel_bodies::expand(&mechanism, &values, &samples).map_err(|e| located(&sites, err, e))?;
    let span = |key: &str| sites.span(key);
    let ell = mechanism.coordinates.len();
    let kinetic = Kinetic::MassMatrix(
        (0..ell)
            .map(|i| {
                (0..ell)
                    .map(|j| {
                        let key = format!("bodies: A[{}][{}]", i + 1, j + 1);
                        Item::expanded(&key, e.mass_matrix[i][j].clone(), span("bodies"))
                    })
                    .collect()
            })
            .collect(),
    );
    let potential = Item::expanded("bodies: U", e.potential.clone(), span("bodies"));
    let rows = e
        .rows
        .iter()
        .map(|r| {
            (
                r.name.clone(),
                row_item(r, &mechanism.coordinates, span(&row_section(r, &mechanism))),
            )
        })
        .collect();
    Ok(Dynamics {
        kinetic,
        potential,
        rows,
        holonomic: e.holonomic,
        completion: e.completion,
        origin: Origin::Bodies,
        forces: e
            .forces
            .iter()
            .enumerate()
            .map(|(k, f)| Item::expanded(&format!("loads: F[{}]", k + 1), f.clone(), span("loads")))
            .collect(),
        notes: e.notes,
        symmetries: crate::symmetry::from_bodies(&e.symmetries, span("frames")),
        contact_forces: e.contact_forces,
        mechanism: Some(std::sync::Arc::new(mechanism)),
    })
}

/// The key of the entry a row comes from.
fn row_section(r: &Row, m: &Mechanism) -> String {
    let from = |names: Vec<&str>, section: &str| {
        names
            .into_iter()
            .find(|n| r.name.starts_with(&format!("{n}_")) || r.name == *n)
            .map(|n| format!("{section}.{n}"))
    };
    from(m.wheels.iter().map(|w| w.name.as_str()).collect(), "wheels")
        .or_else(|| {
            from(
                m.rollers.iter().map(|r| r.name.as_str()).collect(),
                "rolling",
            )
        })
        .or_else(|| from(m.blades.iter().map(|b| b.name.as_str()).collect(), "blades"))
        .unwrap_or_else(|| format!("holonomic.{}", r.name))
}

/// The constraint Σ_k coefficient_k der(q_k) = 0 of a row.
fn row_item(r: &Row, coordinates: &[String], span: Range<usize>) -> Item {
    let terms = r
        .coefficients
        .iter()
        .zip(coordinates)
        .map(|(c, q)| hamel_expr::build::mul(c.clone(), Expr::Der(q.clone())));
    Item::expanded(
        &format!("constraints.{}", r.name),
        hamel_expr::build::sum(terms),
        span,
    )
}

fn located(sites: &Sites, err: &ErrorAt, e: BodiesError) -> ModelError {
    let key = e.place.key();
    err(sites.span(&key), &key, e.problem.to_string())
}

/// The holonomic constraints of a model typed in by hand.
pub(crate) struct HolonomicRows {
    /// Their velocity rows, named as the constraints.
    pub rows: Vec<(String, Item)>,
    pub constraints: Vec<HolonomicConstraint>,
    pub completion: Completion,
}

/// The `[holonomic]` constraints of a model typed in by hand: their velocity rows and their
/// completion.
pub(crate) fn holonomic_of(
    raw: &RawModel,
    loader: &mut Loader,
    err: &ErrorAt,
) -> Result<HolonomicRows, ModelError> {
    let mut sites = Sites::default();
    let mut constraints = Vec::new();
    for (name, h) in &raw.holonomic {
        let c = holonomic(loader, &mut sites, name, h, err)?;
        constraints.push(HolonomicConstraint {
            name: c.name,
            h: c.h,
            dependent: c.dependent,
            rate: None,
        });
    }
    let place = |c: &HolonomicConstraint, field| Place::new(Section::Holonomic, &c.name, field);
    let holonomic = hamel_bodies::holonomic_rows(
        &loader.coordinates,
        &constraints,
        &loader.parameters,
        &place,
    )
    .map_err(|e| located(&sites, err, e))?;
    // An implied constraint is not solved for its coordinate; its row is dropped with the
    // other dependent rows of α.
    let constraints = holonomic.kept(constraints);
    let hamel_bodies::HolonomicRows {
        rows, completion, ..
    } = holonomic;
    let coordinates = loader.coordinates.clone();
    let items = rows
        .iter()
        .map(|r| {
            (
                r.name.clone(),
                row_item(
                    r,
                    &coordinates,
                    sites.span(&format!("holonomic.{}", r.name)),
                ),
            )
        })
        .collect();
    Ok(HolonomicRows {
        rows: items,
        constraints,
        completion,
    })
}

fn mechanism(
    raw: &RawModel,
    loader: &mut Loader,
    sites: &mut Sites,
    err: &ErrorAt,
) -> Result<Mechanism, ModelError> {
    let Some(world) = &raw.world else {
        return Err(err(
            0..0,
            "world",
            "a model of bodies needs [world] with `up` (and `gravity`)".into(),
        ));
    };
    sites.note("world", world.span());
    let w = world.get_ref();
    let up = Axis::parse(w.up.get_ref()).ok_or_else(|| {
        err(
            w.up.span(),
            "world.up",
            format!(
                "`{}` is not an axis: write x, y, z, -x, -y or -z",
                w.up.get_ref()
            ),
        )
    })?;
    let gravity = match &w.gravity {
        Some(g) => scalar(loader, g, "world.gravity")?,
        None => Expr::int(0),
    };
    let mut frames = Vec::new();
    for (name, f) in &raw.frames {
        frames.push(frame(loader, sites, name, f)?);
    }
    let mut m = Mechanism {
        coordinates: loader.coordinates.clone(),
        world: World { up, gravity },
        frames,
        bodies: Vec::new(),
        wheels: Vec::new(),
        rollers: Vec::new(),
        blades: Vec::new(),
        holonomic: Vec::new(),
        loads: Vec::new(),
        springs: Vec::new(),
        dampers: Vec::new(),
        shapes: Vec::new(),
    };
    for (name, b) in &raw.bodies {
        m.bodies.push(body(loader, sites, name, b)?);
    }
    for (name, w) in &raw.wheels {
        m.wheels.push(wheel(loader, sites, name, w, err)?);
    }
    for (name, r) in &raw.rolling {
        m.rollers.push(roller(loader, sites, name, r, err)?);
    }
    for (name, b) in &raw.blades {
        m.blades.push(blade(loader, sites, name, b)?);
    }
    for (name, h) in &raw.holonomic {
        m.holonomic.push(holonomic(loader, sites, name, h, err)?);
    }
    for (name, l) in &raw.loads {
        m.loads.push(load(loader, sites, name, l, err)?);
    }
    for (name, s) in &raw.springs {
        let key = format!("springs.{name}");
        sites.note(&key, s.span());
        let raw = s.get_ref();
        let ends = (raw.between.as_ref(), raw.coordinate.as_ref());
        let stretch = stretch(loader, sites, &key, ends, err)?;
        sites.note(&format!("{key}.stiffness"), raw.stiffness.span());
        m.springs.push(Spring {
            name: name.clone(),
            stretch,
            stiffness: scalar(loader, &raw.stiffness, &format!("{key}.stiffness"))?,
            rest: match &raw.rest {
                Some(r) => scalar(loader, r, &format!("{key}.rest"))?,
                None => Expr::int(0),
            },
        });
    }
    for (name, d) in &raw.dampers {
        let key = format!("dampers.{name}");
        sites.note(&key, d.span());
        let raw = d.get_ref();
        let ends = (raw.between.as_ref(), raw.coordinate.as_ref());
        let stretch = stretch(loader, sites, &key, ends, err)?;
        sites.note(&format!("{key}.damping"), raw.damping.span());
        m.dampers.push(Damper {
            name: name.clone(),
            stretch,
            damping: scalar(loader, &raw.damping, &format!("{key}.damping"))?,
        });
    }
    Ok(m)
}

/// What a spring or damper stretches: exactly one of `between` (two points) and
/// `coordinate`.
fn stretch(
    loader: &mut Loader,
    sites: &mut Sites,
    key: &str,
    (between, coordinate): (Option<&Spanned<Vec<RawAnchor>>>, Option<&Spanned<String>>),
    err: &ErrorAt,
) -> Result<Stretch, ModelError> {
    match (between, coordinate) {
        (Some(b), None) => {
            let bkey = format!("{key}.between");
            sites.note(&bkey, b.span());
            if b.get_ref().len() != 2 {
                let msg = format!(
                    "`between` takes two points, as [{{ frame = \"a\" }}, {{ frame = \"b\", point = [0, 0, 1] }}]; found {}",
                    b.get_ref().len()
                );
                return Err(err(b.span(), &bkey, msg));
            }
            let anchor = |i: usize, loader: &mut Loader| -> Result<Anchor, ModelError> {
                let a = &b.get_ref()[i];
                let pkey = format!("{bkey}[{}].point", i + 1);
                Ok(Anchor {
                    frame: a.frame.get_ref().clone(),
                    point: vector(loader, a.point.as_ref(), &pkey)?,
                })
            };
            let ends = [anchor(0, loader)?, anchor(1, loader)?];
            Ok(Stretch::Between(Box::new(ends)))
        }
        (None, Some(c)) => {
            let ckey = format!("{key}.coordinate");
            sites.note(&ckey, c.span());
            Ok(Stretch::Coordinate(coordinate_name(loader, c, &ckey, err)?))
        }
        _ => {
            let msg = "give exactly one of `between` (two points of two frames) and `coordinate`";
            Err(err(sites.span(key), key, msg.into()))
        }
    }
}

/// `[loads.NAME]`: exactly one of `force` (at `point`, default the frame's origin) and `torque`
/// (with an optional `reaction` frame); `axes` (default the load's frame) names the frame whose
/// axes the vector is written in, or `world`.
fn load(
    loader: &mut Loader,
    sites: &mut Sites,
    name: &str,
    l: &Spanned<crate::schema::RawLoad>,
    err: &ErrorAt,
) -> Result<Load, ModelError> {
    let key = format!("loads.{name}");
    sites.note(&key, l.span());
    let raw = l.get_ref();
    sites.note(&format!("{key}.frame"), raw.frame.span());
    for (field, v) in [("axes", &raw.axes), ("reaction", &raw.reaction)] {
        if let Some(v) = v {
            sites.note(&format!("{key}.{field}"), v.span());
        }
    }
    let kind = match (&raw.force, &raw.torque) {
        (Some(f), None) => {
            if let Some(r) = &raw.reaction {
                let msg = "a force takes no `reaction` (a force at a point; give the opposite force on the other body as a load of its own)";
                return Err(err(r.span(), &format!("{key}.reaction"), msg.into()));
            }
            LoadKind::Force {
                point: vector(loader, raw.point.as_ref(), &format!("{key}.point"))?,
                force: load_vector(loader, f, &format!("{key}.force"))?,
            }
        }
        (None, Some(t)) => {
            if let Some(p) = &raw.point {
                let msg = "a torque acts on the whole frame: it has no `point`";
                return Err(err(p.span(), &format!("{key}.point"), msg.into()));
            }
            LoadKind::Torque {
                torque: load_vector(loader, t, &format!("{key}.torque"))?,
                reaction: raw.reaction.as_ref().map(|r| r.get_ref().clone()),
            }
        }
        _ => {
            let msg = "give exactly one of `force` (at `point`) and `torque`";
            return Err(err(l.span(), &key, msg.into()));
        }
    };
    Ok(Load {
        name: name.to_string(),
        frame: raw.frame.get_ref().clone(),
        axes: raw
            .axes
            .as_ref()
            .map_or_else(|| raw.frame.get_ref().clone(), |a| a.get_ref().clone()),
        kind,
    })
}

/// One scalar expression of the configuration.
fn scalar(loader: &mut Loader, v: &Spanned<RawScalar>, key: &str) -> Result<Expr, ModelError> {
    loader.scalar(v, key, FieldKind::Positional)
}

/// Three scalars of the configuration (zero when absent).
fn vector(loader: &mut Loader, v: Option<&RawVector>, key: &str) -> Result<[Expr; 3], ModelError> {
    loader.vector(v, key, FieldKind::Positional)
}

/// A load's force or torque: three scalars that may also depend on the velocities der(q)
/// (drag, viscous friction).
fn load_vector(loader: &mut Loader, v: &RawVector, key: &str) -> Result<[Expr; 3], ModelError> {
    loader.vector(Some(v), key, FieldKind::Force)
}

fn direction(
    loader: &mut Loader,
    d: &Spanned<RawDirection>,
    key: &str,
) -> Result<Direction, ModelError> {
    match d.get_ref() {
        RawDirection::Axis(name) => Axis::parse(name).map(Direction::Axis).ok_or_else(|| {
            loader.err(
                d.span(),
                key,
                format!("`{name}` is not an axis: write x, y, z, -x, -y, -z or a vector [a, b, c]"),
            )
        }),
        RawDirection::Vector(v) => {
            let items = v
                .iter()
                .map(|x| Spanned::new(d.span(), x.clone()))
                .collect();
            let spanned = Spanned::new(d.span(), items);
            Ok(Direction::Vector(vector(loader, Some(&spanned), key)?))
        }
    }
}

fn frame(
    loader: &mut Loader,
    sites: &mut Sites,
    name: &str,
    f: &Spanned<crate::schema::RawFrame>,
) -> Result<Frame, ModelError> {
    let key = format!("frames.{name}");
    sites.note(&key, f.span());
    let raw = f.get_ref();
    let parent = match &raw.parent {
        Some(p) => {
            sites.note(&format!("{key}.parent"), p.span());
            p.get_ref().clone()
        }
        None => WORLD.to_string(),
    };
    if let Some(o) = &raw.origin {
        sites.note(&format!("{key}.origin"), o.span());
    }
    let origin = vector(loader, raw.origin.as_ref(), &format!("{key}.origin"))?;
    let mut rotations = Vec::new();
    for (i, r) in raw.rotations.iter().enumerate() {
        let rkey = format!("{key}.rotations[{}]", i + 1);
        sites.note(&format!("{key}.rotations"), r.span());
        rotations.push(Rotation {
            axis: direction(loader, &r.get_ref().axis, &format!("{rkey}.axis"))?,
            angle: scalar(loader, &r.get_ref().angle, &format!("{rkey}.angle"))?,
        });
    }
    Ok(Frame {
        name: name.to_string(),
        parent,
        origin,
        rotations,
    })
}

fn body(
    loader: &mut Loader,
    sites: &mut Sites,
    name: &str,
    b: &Spanned<crate::schema::RawBody>,
) -> Result<Body, ModelError> {
    let key = format!("bodies.{name}");
    sites.note(&key, b.span());
    let raw = b.get_ref();
    sites.note(&format!("{key}.frame"), raw.frame.span());
    sites.note(&format!("{key}.mass"), raw.mass.span());
    let inertia = match &raw.inertia {
        Some(i) => Some(inertia(loader, sites, &key, i)?),
        None => None,
    };
    Ok(Body {
        name: name.to_string(),
        frame: raw.frame.get_ref().clone(),
        mass: scalar(loader, &raw.mass, &format!("{key}.mass"))?,
        centre_of_mass: vector(
            loader,
            raw.centre_of_mass.as_ref(),
            &format!("{key}.centre_of_mass"),
        )?,
        inertia,
    })
}

fn inertia(
    loader: &mut Loader,
    sites: &mut Sites,
    key: &str,
    i: &Spanned<crate::schema::RawInertia>,
) -> Result<Inertia, ModelError> {
    let ikey = format!("{key}.inertia");
    sites.note(&ikey, i.span());
    let i = i.get_ref();
    let entry = |v: &Option<Spanned<RawScalar>>, field: &str, loader: &mut Loader| match v {
        Some(v) => scalar(loader, v, &format!("{ikey}.{field}")),
        None => Ok(Expr::int(0)),
    };
    let entries = [
        scalar(loader, &i.xx, &format!("{ikey}.xx"))?,
        scalar(loader, &i.yy, &format!("{ikey}.yy"))?,
        scalar(loader, &i.zz, &format!("{ikey}.zz"))?,
        entry(&i.xy, "xy", loader)?,
        entry(&i.xz, "xz", loader)?,
        entry(&i.yz, "yz", loader)?,
    ];
    Ok(Inertia { entries })
}

fn coordinate_name(
    loader: &Loader,
    c: &Spanned<String>,
    key: &str,
    err: &ErrorAt,
) -> Result<String, ModelError> {
    let name = c.get_ref();
    if loader.coordinates.contains(name) {
        Ok(name.clone())
    } else {
        Err(err(c.span(), key, format!("`{name}` is not a coordinate")))
    }
}

fn wheel(
    loader: &mut Loader,
    sites: &mut Sites,
    name: &str,
    w: &Spanned<crate::schema::RawWheel>,
    err: &ErrorAt,
) -> Result<Wheel, ModelError> {
    let key = format!("wheels.{name}");
    sites.note(&key, w.span());
    let raw = w.get_ref();
    sites.note(&format!("{key}.frame"), raw.frame.span());
    sites.note(&format!("{key}.axis"), raw.axis.span());
    sites.note(&format!("{key}.radius"), raw.radius.span());
    let crown = match &raw.crown {
        Some(c) => {
            sites.note(&format!("{key}.crown"), c.span());
            Some(scalar(loader, c, &format!("{key}.crown"))?)
        }
        None => None,
    };
    let dependent = dependent_of(loader, sites, &key, raw.dependent.as_ref(), err)?;
    Ok(Wheel {
        name: name.to_string(),
        frame: raw.frame.get_ref().clone(),
        axis: direction(loader, &raw.axis, &format!("{key}.axis"))?,
        radius: scalar(loader, &raw.radius, &format!("{key}.radius"))?,
        crown,
        dependent,
    })
}

/// A wheel's or rolling body's `dependent` coordinate, if it names one (`key`: the entry).
fn dependent_of(
    loader: &mut Loader,
    sites: &mut Sites,
    key: &str,
    dependent: Option<&Spanned<String>>,
    err: &ErrorAt,
) -> Result<Option<String>, ModelError> {
    let Some(d) = dependent else {
        return Ok(None);
    };
    let field = format!("{key}.dependent");
    sites.note(&field, d.span());
    coordinate_name(loader, d, &field, err).map(Some)
}

fn roller(
    loader: &mut Loader,
    sites: &mut Sites,
    name: &str,
    r: &Spanned<crate::schema::RawRoller>,
    err: &ErrorAt,
) -> Result<Roller, ModelError> {
    let key = format!("rolling.{name}");
    sites.note(&key, r.span());
    let raw = r.get_ref();
    sites.note(&format!("{key}.frame"), raw.frame.span());
    let surface = match (&raw.sphere, &raw.ellipsoid) {
        (Some(a), None) => {
            sites.note(&format!("{key}.sphere"), a.span());
            Surface::Sphere {
                radius: scalar(loader, a, &format!("{key}.sphere"))?,
            }
        }
        (None, Some(axes)) => {
            sites.note(&format!("{key}.ellipsoid"), axes.span());
            let semi_axes = vector(loader, Some(axes), &format!("{key}.ellipsoid"))?;
            Surface::Ellipsoid { semi_axes }
        }
        _ => {
            let msg = "give exactly one of `sphere = RADIUS` and `ellipsoid = [a, b, c]` (semi-axes along the frame's axes)";
            return Err(err(r.span(), &key, msg.into()));
        }
    };
    let dependent = dependent_of(loader, sites, &key, raw.dependent.as_ref(), err)?;
    Ok(Roller {
        name: name.to_string(),
        frame: raw.frame.get_ref().clone(),
        centre: vector(loader, raw.centre.as_ref(), &format!("{key}.centre"))?,
        surface,
        dependent,
    })
}

fn blade(
    loader: &mut Loader,
    sites: &mut Sites,
    name: &str,
    b: &Spanned<crate::schema::RawBlade>,
) -> Result<Blade, ModelError> {
    let key = format!("blades.{name}");
    sites.note(&key, b.span());
    let raw = b.get_ref();
    sites.note(&format!("{key}.frame"), raw.frame.span());
    sites.note(&format!("{key}.direction"), raw.direction.span());
    Ok(Blade {
        name: name.to_string(),
        frame: raw.frame.get_ref().clone(),
        point: vector(loader, raw.point.as_ref(), &format!("{key}.point"))?,
        direction: direction(loader, &raw.direction, &format!("{key}.direction"))?,
    })
}

fn holonomic(
    loader: &mut Loader,
    sites: &mut Sites,
    name: &str,
    h: &Spanned<crate::schema::RawHolonomic>,
    err: &ErrorAt,
) -> Result<Holonomic, ModelError> {
    let key = format!("holonomic.{name}");
    sites.note(&key, h.span());
    let raw = h.get_ref();
    sites.note(&format!("{key}.h"), raw.h.span());
    sites.note(&format!("{key}.dependent"), raw.dependent.span());
    Ok(Holonomic {
        name: name.to_string(),
        h: loader
            .item(&raw.h, &format!("{key}.h"), FieldKind::Positional)?
            .expr,
        dependent: coordinate_name(loader, &raw.dependent, &format!("{key}.dependent"), err)?,
    })
}

#[cfg(test)]
mod tests {
    use crate::{Model, ModelError, Origin};
    use indexmap::IndexMap;

    /// A disk rolling on the plane, from its body; the variants below break one thing each.
    const DISK: &str = r#"
name = "disk"
title = "test"
coordinates = ["x", "y", "phi", "psi", "theta"]
[parameters]
R = 0.5
m = 2.0
g = 9.81
[world]
up = "z"
gravity = "g"
[frames.heading]
origin = ["x", "y", 0]
rotations = [{ axis = "z", angle = "phi" }]
[frames.lean]
parent = "heading"
rotations = [{ axis = "-x", angle = "theta" }]
[frames.disk]
parent = "lean"
origin = [0, 0, "R"]
rotations = [{ axis = "y", angle = "psi" }]
[bodies.disk]
frame = "disk"
mass = "m"
inertia = { xx = "m*R^2/4", yy = "m*R^2/2", zz = "m*R^2/4" }
[wheels.disk]
frame = "disk"
axis = "y"
radius = "R"
"#;

    fn bad(text: &str) -> ModelError {
        Model::from_source("bad.toml", text).unwrap_err()
    }

    /// The message, and the line of the file it points at.
    fn at(e: &ModelError) -> (String, usize) {
        (e.to_string(), e.line_col().map_or(0, |(l, _)| l))
    }

    #[test]
    fn a_disk_from_its_body() {
        let m = Model::from_source("disk.toml", DISK).unwrap();
        assert_eq!(m.origin, Origin::Bodies);
        assert_eq!((m.ell(), m.mu()), (5, 2));
        assert!(
            m.notes.iter().any(|n| n.contains("cos(theta)")),
            "{:?}",
            m.notes
        );
    }

    /// A pushing force at the disk's centre along the heading, a torque about the vertical on
    /// the heading frame, and a spin torque between the disk and the lean frame, with two
    /// inputs: the generalised forces are the virtual powers (checked at a point), and
    /// `hamel expand` writes them and the inputs back.
    #[test]
    fn loads_give_generalised_forces() {
        let text = format!(
            "{}[inputs]\npush = 0.5\nspin = 0.0\n\
             [loads.push]\nframe = \"lean\"\npoint = [0, 0, \"R\"]\nforce = [\"push\", 0, 0]\naxes = \"heading\"\n\
             [loads.turn]\nframe = \"heading\"\ntorque = [0, 0, \"m\"]\naxes = \"world\"\n\
             [loads.motor]\nframe = \"disk\"\ntorque = [0, \"spin\", 0]\nreaction = \"lean\"\n",
            DISK
        );
        let m = Model::from_source("disk.toml", &text).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.inputs, ["push", "spin"]);
        assert!(m.has_forces());
        let nm =
            crate::NumericModel::new(&m, &IndexMap::from([("spin".to_string(), 0.3)])).unwrap();
        let (phi, theta) = (0.4_f64, 0.25_f64);
        let f = nm
            .forces::<f64>(&[0.1, -0.2, phi, 0.9, theta], &[0.0; 5])
            .unwrap();
        // The centre C + R(lean's z): pushed along the heading's x by `push`.
        let push = 0.5;
        let want = [
            push * phi.cos(),
            push * phi.sin(),
            // the torque m about the vertical on the heading (φ̇ along z), and the push: the
            // centre, R sin θ to the side of the heading, moves back by R sin θ per unit φ
            2.0 - push * 0.5 * theta.sin(),
            0.3, // the motor's spin, relative to the lean frame
            0.0, // the push along the heading's x does no work when θ changes (the centre moves across it)
        ];
        for (k, (got, want)) in f.iter().zip(want).enumerate() {
            assert!((got - want).abs() < 1e-14, "F[{k}] = {got}, want {want}");
        }
        let expanded = m.to_lagrangian_toml();
        assert!(
            expanded.contains("[inputs]\npush = 0.5\nspin = 0.0"),
            "{expanded}"
        );
        assert!(expanded.contains("[forces]\n"), "{expanded}");
        let again =
            Model::from_source("expanded.toml", &expanded).unwrap_or_else(|e| panic!("{e}"));
        let g = crate::NumericModel::new(&again, &IndexMap::from([("spin".to_string(), 0.3)]))
            .unwrap()
            .forces::<f64>(&[0.1, -0.2, phi, 0.9, theta], &[0.0; 5])
            .unwrap();
        assert_eq!(f, g);
    }

    #[test]
    fn loads_are_located() {
        let with = |load: &str| format!("{DISK}[loads.bad]\n{load}");
        let (msg, _) = at(&bad(&with("frame = \"hub\"\ntorque = [0, 0, 1]\n")));
        assert!(
            msg.contains("loads.bad.frame: unknown frame `hub`"),
            "{msg}"
        );
        let (msg, _) = at(&bad(&with(
            "frame = \"disk\"\ntorque = [0, 0, 1]\nreaction = \"lea\"\n",
        )));
        assert!(
            msg.contains("loads.bad.reaction: unknown frame `lea`"),
            "{msg}"
        );
        let (msg, _) = at(&bad(&with(
            "frame = \"disk\"\nforce = [0, 0, 1]\naxes = \"nowhere\"\n",
        )));
        assert!(
            msg.contains("loads.bad.axes: unknown frame `nowhere`"),
            "{msg}"
        );
        let (msg, _) = at(&bad(&with(
            "frame = \"disk\"\nforce = [0, 0, 1]\ntorque = [0, 0, 1]\n",
        )));
        assert!(msg.contains("give exactly one of `force`"), "{msg}");
        let (msg, _) = at(&bad(&with(
            "frame = \"disk\"\ntorque = [0, 0, 1]\npoint = [1, 0, 0]\n",
        )));
        assert!(msg.contains("a torque acts on the whole frame"), "{msg}");
        let (msg, _) = at(&bad(&with(
            "frame = \"disk\"\npoint = [\"der(x)\", 0, 0]\nforce = [1, 0, 0]\n",
        )));
        assert!(msg.contains("der(x)"), "{msg}");
        let (msg, _) = at(&bad(&with(
            "frame = \"disk\"\nforce = [\"-der(der(x))\", 0, 0]\n",
        )));
        assert!(msg.contains("acceleration"), "{msg}");
    }

    /// A spring and a damper from a point of the world to the disk's centre, and a torsional
    /// damper on the spin: U and F against the centre's position written out by hand,
    /// P = (x − R sin θ sin φ, y + R sin θ cos φ, R cos θ), the damper's F_k = −c ḋ ∂d/∂q_k by
    /// central differences.
    #[test]
    fn springs_and_dampers_give_u_and_f() {
        let text = DISK.replacen(
            "[parameters]\n",
            "[parameters]\nk = 3.0\nc = 0.7\nd0 = 0.4\ncs = 0.2\n",
            1,
        );
        let ends = "between = [{ frame = \"world\", point = [1, 2, 0] }, { frame = \"lean\", point = [0, 0, \"R\"] }]";
        let text = format!(
            "{text}[springs.tether]\n{ends}\nstiffness = \"k\"\nrest = \"d0\"\n\
             [dampers.tether]\n{ends}\ndamping = \"c\"\n\
             [dampers.bearing]\ncoordinate = \"psi\"\ndamping = \"cs\"\n"
        );
        let m = Model::from_source("disk.toml", &text).unwrap_or_else(|e| panic!("{e}"));
        assert!(m.has_velocity_forces());
        let nm = crate::NumericModel::new(&m, &IndexMap::new()).unwrap();
        let (r, mass, g, k, c, d0, cs) = (0.5, 2.0, 9.81, 3.0, 0.7, 0.4, 0.2);
        let d = |q: &[f64]| {
            let (x, y, phi, theta) = (q[0], q[1], q[2], q[4]);
            let p = [
                x - r * theta.sin() * phi.sin() - 1.0,
                y + r * theta.sin() * phi.cos() - 2.0,
                r * theta.cos(),
            ];
            p.iter().map(|v| v * v).sum::<f64>().sqrt()
        };
        let q = [0.1, -0.2, 0.4, 0.9, 0.25];
        let qd = [0.3, -0.5, 0.2, 1.1, -0.4];
        let u = nm.potential::<f64>(&q).unwrap();
        let want = -mass * g * r * q[4].cos() - 0.5 * k * (d(&q) - d0).powi(2);
        assert!((u - want).abs() < 1e-12, "U = {u}, want {want}");
        let h = 1e-6;
        let shifted = |dir: &[f64], s: f64| -> Vec<f64> {
            q.iter().zip(dir).map(|(a, b)| a + s * b).collect()
        };
        let d_dot = (d(&shifted(&qd, h)) - d(&shifted(&qd, -h))) / (2.0 * h);
        let f = nm.forces::<f64>(&q, &qd).unwrap();
        for (j, got) in f.iter().enumerate() {
            let mut e = [0.0; 5];
            e[j] = 1.0;
            let dd = (d(&shifted(&e, h)) - d(&shifted(&e, -h))) / (2.0 * h);
            let bearing = if j == 3 { -cs * qd[3] } else { 0.0 };
            let want = -c * d_dot * dd + bearing;
            assert!((got - want).abs() < 1e-8, "F[{j}] = {got}, want {want}");
        }
        // `hamel expand` writes the springs into U and the dampers into [forces] with der(q),
        // and the file it writes reads back to the same U and F.
        let expanded = m.to_lagrangian_toml();
        let again = Model::from_source("expanded.toml", &expanded)
            .unwrap_or_else(|e| panic!("{e}\n{expanded}"));
        let back = crate::NumericModel::new(&again, &IndexMap::new()).unwrap();
        assert_eq!(back.forces::<f64>(&q, &qd).unwrap(), f);
        assert_eq!(back.potential::<f64>(&q).unwrap(), u);
    }

    #[test]
    fn springs_and_dampers_are_located() {
        let with = |entry: &str| format!("{DISK}{entry}");
        let (msg, _) = at(&bad(&with(
            "[springs.s]\nbetween = [{ frame = \"world\" }, { frame = \"hub\" }]\nstiffness = 1\n",
        )));
        assert!(
            msg.contains("springs.s.between: unknown frame `hub`"),
            "{msg}"
        );
        let (msg, _) = at(&bad(&with(
            "[dampers.d]\ncoordinate = \"psi\"\ndamping = \"-m\"\n",
        )));
        assert!(
            msg.contains(
                "dampers.d.damping: the damping is not positive at the default parameters (-2)"
            ),
            "{msg}"
        );
        let (msg, _) = at(&bad(&with(
            "[springs.s]\ncoordinate = \"psy\"\nstiffness = 1\n",
        )));
        assert!(msg.contains("`psy` is not a coordinate"), "{msg}");
        let (msg, _) = at(&bad(&with("[springs.s]\nstiffness = 1\n")));
        assert!(msg.contains("give exactly one of `between`"), "{msg}");
        let (msg, _) = at(&bad(&with(
            "[springs.s]\nbetween = [{ frame = \"world\" }]\nstiffness = 1\n",
        )));
        assert!(msg.contains("`between` takes two points"), "{msg}");
    }

    #[test]
    fn an_unknown_parent_frame_is_located() {
        let (msg, line) = at(&bad(
            &DISK.replace("parent = \"heading\"", "parent = \"headng\"")
        ));
        assert!(
            msg.contains("frames.lean.parent: unknown frame `headng`"),
            "{msg}"
        );
        assert_eq!(line, 16, "{msg}");
    }

    #[test]
    fn a_cycle_among_frames_is_located() {
        let text = DISK.replace(
            "[frames.heading]\n",
            "[frames.heading]\nparent = \"disk\"\n",
        );
        let (msg, _) = at(&bad(&text));
        assert!(msg.contains("the frames form a cycle"), "{msg}");
    }

    #[test]
    fn an_inertia_that_is_not_positive_definite_is_located() {
        let text = DISK.replace("zz = \"m*R^2/4\"", "zz = \"-m*R^2/4\"");
        let (msg, line) = at(&bad(&text));
        assert!(
            msg.contains("bodies.disk.inertia: the inertia is not positive definite"),
            "{msg}"
        );
        assert_eq!(line, 25, "{msg}");
    }

    #[test]
    fn a_zero_wheel_axis_is_located() {
        let text = DISK.replace("axis = \"y\"\nradius", "axis = [0, 0, 0]\nradius");
        let (msg, line) = at(&bad(&text));
        assert!(
            msg.contains("wheels.disk.axis: the direction is zero"),
            "{msg}"
        );
        assert_eq!(line, 28, "{msg}");
    }

    #[test]
    fn a_wheel_off_the_ground_needs_a_dependent_coordinate() {
        let text = DISK.replace("origin = [0, 0, \"R\"]", "origin = [0, 0, \"2*R\"]");
        let (msg, _) = at(&bad(&text));
        assert!(
            msg.contains("wheels.disk.dependent: the wheel's contact leaves the ground"),
            "{msg}"
        );
    }

    #[test]
    fn a_holonomic_constraint_must_determine_its_coordinate() {
        let text = format!("{DISK}[holonomic.stuck]\nh = \"x^2 + 1\"\ndependent = \"x\"\n");
        let (msg, line) = at(&bad(&text));
        assert!(
            msg.contains("holonomic.stuck.dependent: the constraint does not determine `x`"),
            "{msg}"
        );
        assert_eq!(line, 32, "{msg}");
    }

    #[test]
    fn derived_parameters_are_evaluated_in_order() {
        let text = DISK.replace("R = 0.5\n", "R = \"D/2\"\nD = \"cos(pi/3)*2\"\n");
        let m = Model::from_source("disk.toml", &text).unwrap();
        assert!((m.parameters["R"] - 0.5).abs() < 1e-15);
        assert_eq!(m.derived["R"].text, "D/2");
        let e = bad(&DISK.replace("R = 0.5\n", "R = \"D/2\"\nD = \"2*R\"\n"));
        assert!(e.to_string().contains("cycle"), "{e}");
    }
}
