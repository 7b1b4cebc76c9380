//! Shared by the test binaries that need it.
#![allow(dead_code)] // each test binary uses part of it

pub mod oracle;

/// The coordinates each seed example eliminates in the paper (Remark 3.1 for the vertical knife:
/// y is removed, θ is not; Remark 2.2: q1 is not), and those the robots' equations are free of
/// (the position, the heading and the wheel angles).
pub const ELIMINATE: &[(&str, &str)] = &[
    ("bar_blade", "x,y,theta"),
    ("bar_wheels", "x,y,theta,psi1"),
    ("chaplygin_ball", "x,y,psi"),
    ("chaplygin_sleigh", "x,y,theta"),
    ("diff_drive", "x,y,psi,phiL,phiR,phiC"),
    ("knife", "x,y,theta"),
    ("remark22", "q1"),
    ("rolling_disk", "xC,yC,phi"),
    ("rolling_disc_sympy", "q4,q5,q1"),
    ("rolling_tyre", "xC,yC,phi"),
    ("rattleback", "x,y,psi"),
    ("routh_sphere", "x,y,psi,phi"),
    ("segway", "x,y,psi,phiL,phiR"),
    ("snakeboard", "x,y,theta"),
    ("sprung_sleigh", "x,y,psi"),
    ("unicycle_rider", "xC,yC,phi,psi"),
    ("vertical_knife", "x,y,theta"),
    ("whipple_bicycle", "x,y,yaw,rear_wheel,front_wheel"),
    ("whipple_bicycle_tyres", "x,y,yaw,rear_wheel,front_wheel"),
];

/// The bundled models, sorted by file name.
pub fn models() -> Vec<hamel_model::Model> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/models");
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    paths
        .iter()
        .map(|p| hamel_model::Model::load(p).unwrap())
        .collect()
}

/// The closed loops whose generated cores are checked in beside the models' own: the scene
/// (relative to the repository), its choice of η and the core's directory under `generated/`.
pub const CLOSED_LOOPS: &[(&str, &str, &str)] =
    &[("scenes/segway_lqr.toml", "body", "segway_lqr__body")];

/// The model of `scene` with the loop closed by its `[inputs]` laws (`Model::controlled`).
pub fn closed_loop(scene: &str) -> hamel_model::Model {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(scene);
    let text = std::fs::read_to_string(&path).unwrap();
    let dir = path.parent().unwrap().to_path_buf();
    let load = |m: &str| hamel_model::Model::load(dir.join(m));
    hamel_run::check(scene, &text, &indexmap::IndexMap::new(), &load)
        .unwrap_or_else(|e| panic!("{e}"))
        .model
}

/// The model a generated core was made from: the model file's, or a scene's closed loop.
pub fn model_of_core<'m>(
    models: &'m [hamel_model::Model],
    model: &str,
    scene: &str,
) -> std::borrow::Cow<'m, hamel_model::Model> {
    if scene.is_empty() {
        std::borrow::Cow::Borrowed(models.iter().find(|m| m.name == model).unwrap())
    } else {
        std::borrow::Cow::Owned(closed_loop(scene))
    }
}

/// The elimination asked for `model` in the paper.
pub fn eliminate(model: &hamel_model::Model) -> Vec<String> {
    let (_, p) = ELIMINATE
        .iter()
        .find(|(m, _)| *m == model.name)
        .unwrap_or_else(|| panic!("add the model `{}` to ELIMINATE", model.name));
    p.split(',').map(str::to_string).collect()
}

/// max |a − b| / max(max |b|, 1), over any scalar (the value part of dual numbers).
pub fn rel_error<S: hamel_expr::Scalar + Copy>(a: &[S], b: &[S]) -> f64 {
    let scale = b.iter().fold(1.0_f64, |m, x| m.max(x.value().abs()));
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).value().abs())
        .fold(0.0, f64::max)
        / scale
}

/// The reduction of `asked` under `eta` and the derivation it analysed (with the ingredients
/// code uses), from one pass made here ([`hamel_reduce::pass::make`]; the store untouched).
#[allow(dead_code)]
pub fn reduce_with_derivation(
    model: &hamel_model::Model,
    eta: Option<&str>,
    asked: &[String],
) -> Result<(hamel_reduce::Reduction, hamel_derive::Derivation), hamel_model::ModelError> {
    use hamel_reduce::pass::{Analysis, Job, make};
    let pass = || {
        let p = hamel_reduce::coordinate_indices(model, asked)?;
        let mut artefact = make(&Job::new(model, eta, Analysis::Eliminate(p))?.for_code())?;
        let reduction = artefact.reduction.take().expect("analysed");
        Ok((reduction, artefact.into_derivation()?))
    };
    pass().map_err(|e: hamel_reduce::ReduceError| e.locate(model))
}
