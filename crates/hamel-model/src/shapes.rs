//! `[shapes.NAME]` of a model of bodies (issue 60): the solids an animated page draws on a
//! frame in place of its bodies' inertia solids. Each is checked here, at its field: one of
//! `box`, `cylinder` and `sphere`; a frame that exists; sizes that are expressions of the
//! parameters only, positive at their values; a colour written `#rrggbb`. Shapes have no mass
//! and no effect on the dynamics.

use hamel_bodies::{Axis, Geometry, Point, Shape, WORLD};
use hamel_expr::Expr;
use toml::Spanned;

use crate::error::ModelError;
use crate::loader::{Dynamics, ErrorAt, FieldKind, Loader};
use crate::schema::{RawScalar, RawShape};

/// Every `[shapes.NAME]` of the file checked and put on the mechanism of `dynamics` (a model
/// of bodies).
pub(crate) fn attach(
    raw: &indexmap::IndexMap<String, Spanned<RawShape>>,
    dynamics: &mut Dynamics,
    loader: &mut Loader,
    err: &ErrorAt,
) -> Result<(), ModelError> {
    let Some(m) = dynamics.mechanism.as_mut() else {
        return Ok(());
    };
    let m = std::sync::Arc::make_mut(m);
    let frames: Vec<String> = m.frames.iter().map(|f| f.name.clone()).collect();
    m.shapes = shapes(raw, &frames, loader, err)?;
    Ok(())
}

/// Every `[shapes.NAME]` of the file, checked against the frames named in `frames`.
fn shapes(
    raw: &indexmap::IndexMap<String, Spanned<RawShape>>,
    frames: &[String],
    loader: &mut Loader,
    err: &ErrorAt,
) -> Result<Vec<Shape>, ModelError> {
    raw.iter()
        .map(|(name, s)| shape(loader, name, s, frames, err))
        .collect()
}

fn shape(
    loader: &mut Loader,
    name: &str,
    s: &Spanned<RawShape>,
    frames: &[String],
    err: &ErrorAt,
) -> Result<Shape, ModelError> {
    let key = format!("shapes.{name}");
    let raw = s.get_ref();
    let frame = raw.frame.get_ref();
    if frame != WORLD && !frames.contains(frame) {
        let msg = format!("`{frame}` is not a frame: name one of [frames] or `world`");
        return Err(err(raw.frame.span(), &format!("{key}.frame"), msg));
    }
    let geometry = geometry(loader, &key, s, err)?;
    let centre = loader.vector(
        raw.centre.as_ref(),
        &format!("{key}.centre"),
        FieldKind::Positional,
    )?;
    let colour = match &raw.colour {
        Some(c) => Some(colour(c.get_ref()).ok_or_else(|| {
            let msg = format!("`{}` is not a colour: write `#rrggbb`", c.get_ref());
            err(c.span(), &format!("{key}.colour"), msg)
        })?),
        None => None,
    };
    Ok(Shape {
        name: name.to_string(),
        frame: frame.clone(),
        centre,
        geometry,
        colour,
    })
}

/// The shape's one solid, its sizes checked ([`size`]).
fn geometry(
    loader: &mut Loader,
    key: &str,
    s: &Spanned<RawShape>,
    err: &ErrorAt,
) -> Result<Geometry, ModelError> {
    let raw = s.get_ref();
    match (&raw.cuboid, &raw.cylinder, &raw.sphere) {
        (Some(b), None, None) => {
            let bkey = format!("{key}.box");
            let size = loader.vector(Some(b), &bkey, FieldKind::Positional)?;
            for (e, v) in size.iter().zip(b.get_ref()) {
                check_size(loader, e, v.span(), &bkey, err)?;
            }
            Ok(Geometry::Box { size })
        }
        (None, Some(c), None) => {
            let ckey = format!("{key}.cylinder");
            let c = c.get_ref();
            let axis = match &c.axis {
                None => Axis { index: 2, sign: 1 },
                Some(a) => Axis::parse(a.get_ref()).ok_or_else(|| {
                    let msg = format!("`{}` is not an axis: write x, y or z", a.get_ref());
                    err(a.span(), &format!("{ckey}.axis"), msg)
                })?,
            };
            Ok(Geometry::Cylinder {
                radius: size(loader, &c.radius, &format!("{ckey}.radius"), err)?,
                length: size(loader, &c.length, &format!("{ckey}.length"), err)?,
                axis,
            })
        }
        (None, None, Some(r)) => Ok(Geometry::Sphere {
            radius: size(loader, r, &format!("{key}.sphere"), err)?,
        }),
        _ => Err(err(
            s.span(),
            key,
            "give exactly one of `box = [lx, ly, lz]`, `cylinder = { radius = …, length = …, axis = \"z\" }` and `sphere = RADIUS`".into(),
        )),
    }
}

/// A size: an expression of the parameters, positive at their values.
fn size(
    loader: &mut Loader,
    v: &Spanned<RawScalar>,
    key: &str,
    err: &ErrorAt,
) -> Result<Expr, ModelError> {
    let e = loader.scalar(v, key, FieldKind::Positional)?;
    check_size(loader, &e, v.span(), key, err)?;
    Ok(e)
}

fn check_size(
    loader: &Loader,
    e: &Expr,
    span: std::ops::Range<usize>,
    key: &str,
    err: &ErrorAt,
) -> Result<(), ModelError> {
    if let Some(c) = loader.coordinates.iter().find(|c| e.mentions(c)) {
        let msg = format!("a size is fixed: it may use the parameters, not the coordinate `{c}`");
        return Err(err(span, key, msg));
    }
    let zeros = vec![0.0; loader.coordinates.len()];
    let value = Point::at(&loader.coordinates, &zeros, &loader.parameters).value(e);
    match value {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(()),
        Ok(v) => Err(err(
            span,
            key,
            format!("a size must be positive; it is {v}"),
        )),
        Err(p) => Err(err(span, key, format!("the size cannot be evaluated: {p}"))),
    }
}

/// `#rrggbb` as red, green, blue.
fn colour(text: &str) -> Option<[u8; 3]> {
    let hex = text.strip_prefix('#')?;
    if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).ok();
    Some([byte(0)?, byte(2)?, byte(4)?])
}
