//! `hamel simulate --plot FILE.svg|png`: the coordinates and the quasi-velocities against time.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::simulate::Trajectory;

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

/// Check the plot path before any work is done (so a bad name writes nothing).
pub fn check(path: &Path) -> Result<(), String> {
    format_of(path).map(|_| ())
}

/// Write the figure; the format follows the extension (`.svg` or `.png`). On failure no file
/// is left behind.
pub fn write(path: &Path, traj: &Trajectory) -> Result<(), String> {
    let format = format_of(path)?;
    register_font()?;
    let size = (900, 700);
    let result = match format {
        Format::Svg => draw(SVGBackend::new(path, size).into_drawing_area(), traj),
        Format::Png => draw(BitMapBackend::new(path, size).into_drawing_area(), traj),
    };
    if result.is_err() {
        let _ = std::fs::remove_file(path);
    }
    result
}
