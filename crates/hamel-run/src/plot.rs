//! `hamel simulate --plot FILE.svg|png`: the coordinates and the quasi-velocities against time;
//! `hamel tradeoff --plot`: the work–precision diagram.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use hamel_model::ModelError;
use hamel_sim::MethodName;

use crate::trajectory::Trajectory;

/// Fonts tried for the labels.
const FONTS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:\\Windows\\Fonts\\arial.ttf",
];

type Series<'a> = Vec<(String, Vec<(f64, f64)>)>;

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    series: &Series,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (mut t0, mut t1, mut lo, mut hi) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (_, pts) in series {
        for &(t, v) in pts {
            t0 = t0.min(t);
            t1 = t1.max(t);
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if t0 >= t1 {
        t1 = t0 + 1.0;
    }
    if lo >= hi {
        (lo, hi) = (lo - 1.0, hi + 1.0);
    }
    let pad = 0.05 * (hi - lo);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(55)
        .build_cartesian_2d(t0..t1, (lo - pad)..(hi + pad))
        .map_err(e)?;
    chart.configure_mesh().x_desc("t").draw().map_err(e)?;
    for (i, (name, pts)) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
            .map_err(e)?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(e)?;
    Ok(())
}

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, traj: &Trajectory) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let coords: Series = traj
        .q
        .iter()
        .map(|(n, v)| {
            (
                n.clone(),
                traj.t.iter().copied().zip(v.iter().copied()).collect(),
            )
        })
        .collect();
    let sigma = traj.eta.first().map_or(0, Vec::len);
    let etas: Series = (0..sigma)
        .map(|i| {
            (
                format!("eta{}", i + 1),
                traj.t
                    .iter()
                    .copied()
                    .zip(traj.eta.iter().map(|e| e[i]))
                    .collect(),
            )
        })
        .collect();
    let title = format!(
        "{} ({}): coordinates{}",
        traj.model,
        traj.eta_name,
        if traj.complete { "" } else { " (INCOMPLETE)" }
    );
    panel(&top, &title, &coords)?;
    panel(&bottom, "quasi-velocities", &etas)?;
    root.present().map_err(|e| e.to_string())
}

/// The work–precision diagram of `hamel tradeoff`: error over the span against wall time, both
/// logarithmic, one line per integrator (adaptive and fixed-step Gauss–Legendre apart).
fn draw_tradeoff<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    table: &crate::tradeoff::Table,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for r in table
        .rows
        .iter()
        .filter(|r| r.complete && r.error_span.is_finite())
    {
        let name = match (r.method, r.step) {
            (MethodName::GaussLegendre, Some(_)) => "gauss-legendre (fixed step)".to_string(),
            (MethodName::GaussLegendre, None) => "gauss-legendre (adaptive)".to_string(),
            (m, _) => m.to_string(),
        };
        let point = (r.error_span.max(1e-17), r.seconds.max(1e-7));
        match series.iter_mut().find(|(n, _)| *n == name) {
            Some((_, pts)) => pts.push(point),
            None => series.push((name, vec![point])),
        }
    }
    let all = series.iter().flat_map(|(_, p)| p.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (1e-16, 1.0, 1e-6, 1.0);
    }
    let mut chart = ChartBuilder::on(&root)
        .caption(
            format!("{}: work–precision", table.model),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(
            ((x0 / 2.0)..(x1 * 2.0)).log_scale(),
            ((y0 / 2.0)..(y1 * 2.0)).log_scale(),
        )
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("error over the span (relative)")
        .y_desc("wall time [s]")
        .x_label_formatter(&|x| format!("{x:.0e}"))
        .y_label_formatter(&|y| format!("{y:.0e}"))
        .draw()
        .map_err(e)?;
    for (i, (name, mut pts)) in series.into_iter().enumerate() {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))
            .map_err(e)?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color));
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
            .map_err(e)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(e)?;
    root.present().map_err(|e| e.to_string())
}

/// Register a TrueType font for the labels (plotters measures text with it, in SVG too).
fn register_font() -> Result<(), String> {
    static DONE: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    DONE.get_or_init(|| {
        let font = FONTS
            .iter()
            .find_map(|f| std::fs::read(f).ok())
            .ok_or_else(|| {
                format!(
                    "the plot needs a TrueType font for its labels and none was found (tried {})",
                    FONTS.join(", ")
                )
            })?;
        let font: &'static [u8] = Box::leak(font.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, font)
            .map_err(|_| "the font file could not be read".to_string())
    })
    .clone()
}

/// The figure formats, by file extension.
enum Format {
    Svg,
    Png,
}

fn format_of(path: &Path) -> Result<Format, String> {
    match path.extension().and_then(|e| e.to_str()) {
        Some("svg") => Ok(Format::Svg),
        Some("png") => Ok(Format::Png),
        _ => Err("the plot file must end in .svg or .png".into()),
    }
}

/// An error about the figure file.
fn error(path: &Path, message: String) -> ModelError {
    ModelError::new(
        &path.display().to_string(),
        Default::default(),
        None,
        None,
        message,
    )
}

/// Check the plot path before any work is done (so a bad name writes nothing).
pub fn check(path: Option<&Path>) -> Result<(), ModelError> {
    match path {
        Some(p) => format_of(p).map(|_| ()).map_err(|m| error(p, m)),
        None => Ok(()),
    }
}

/// Write a figure of `size` pixels drawn by `svg` or `png` as the extension says; on failure no
/// file is left behind and the error names the file.
pub fn write_figure(
    path: &Path,
    size: (u32, u32),
    svg: impl FnOnce(DrawingArea<SVGBackend, Shift>) -> Result<(), String>,
    png: impl FnOnce(DrawingArea<BitMapBackend, Shift>) -> Result<(), String>,
) -> Result<(), ModelError> {
    // Drawn into a temporary file renamed into place (hamel_model::files): an interrupted or
    // failed drawing leaves nothing behind.
    let tmp = hamel_model::files::Temporary::beside(path);
    let result = format_of(path).and_then(|format| {
        register_font()?;
        match format {
            Format::Svg => svg(SVGBackend::new(tmp.path(), size).into_drawing_area()),
            Format::Png => png(BitMapBackend::new(tmp.path(), size).into_drawing_area()),
        }
    });
    result
        .and_then(|()| tmp.commit(path).map_err(|e| e.to_string()))
        .map_err(|m| error(path, m))
}

/// Write the trajectory's figure (`hamel simulate --plot`).
pub fn write(path: &Path, traj: &Trajectory) -> Result<(), ModelError> {
    write_figure(path, (900, 700), |a| draw(a, traj), |a| draw(a, traj))
}

/// Write the work–precision diagram (`hamel tradeoff --plot`).
pub fn write_tradeoff(path: &Path, table: &crate::tradeoff::Table) -> Result<(), ModelError> {
    write_figure(
        path,
        (900, 600),
        |a| draw_tradeoff(a, table),
        |a| draw_tradeoff(a, table),
    )
}
