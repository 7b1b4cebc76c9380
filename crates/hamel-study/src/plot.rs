//! `hamel linearize --plot`: a sweep drawn as the benchmark bicycle's Figure 3 (the real and the
//! imaginary parts of the eigenvalues against the parameter, the crossings marked), a map as a
//! heat map of the largest real part (blue stable, red unstable).

use std::path::Path;

use hamel_model::ModelError;
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::{Map, Sweep};

/// Check the plot path before any work: a figure needs a sweep, and a .svg or .png name.
pub fn check(path: Option<&Path>, sweeps: usize) -> Result<(), ModelError> {
    if let Some(p) = path
        && sweeps == 0
    {
        return Err(ModelError::new(
            &p.display().to_string(),
            Default::default(),
            None,
            None,
            "--plot draws a sweep or a map: give --sweep P=START:STOP:COUNT (twice for a map)",
        ));
    }
    hamel_run::plot::check(path)
}

/// Write the sweep's figure.
pub fn sweep(s: &Sweep, path: &Path) -> Result<(), ModelError> {
    hamel_run::plot::write_figure(path, (900, 700), |a| draw_sweep(a, s), |a| draw_sweep(a, s))
}

/// Write the map's figure.
pub fn map(m: &Map, path: &Path) -> Result<(), ModelError> {
    hamel_run::plot::write_figure(path, (800, 700), |a| draw_map(a, m), |a| draw_map(a, m))
}

fn draw_sweep<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, s: &Sweep) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let part = |k: usize| -> Vec<(f64, f64)> {
        s.points
            .iter()
            .flat_map(|p| p.eigenvalues.iter().map(move |z| (p.value, z[k])))
            .collect()
    };
    panel(
        &top,
        &format!("real parts of the eigenvalues against {}", s.parameter),
        &part(0),
        s,
    )?;
    let imaginary: Vec<(f64, f64)> = part(1).into_iter().map(|(x, y)| (x, y.abs())).collect();
    panel(&bottom, "imaginary parts (|Im λ|)", &imaginary, s)?;
    root.present().map_err(|e| e.to_string())
}

fn panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    pts: &[(f64, f64)],
    s: &Sweep,
) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (x0, x1) = bounds(pts.iter().map(|p| p.0));
    let (y0, y1) = bounds(pts.iter().map(|p| p.1).chain([0.0]));
    let pad = 0.05 * (y1 - y0);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(s.parameter.as_str())
        .draw()
        .map_err(e)?;
    chart
        .draw_series(LineSeries::new(
            [(x0, 0.0), (x1, 0.0)],
            BLACK.stroke_width(1),
        ))
        .map_err(e)?;
    for c in &s.crossings {
        let line = [(c.value, y0 - pad), (c.value, y1 + pad)];
        chart
            .draw_series(LineSeries::new(line, RED.mix(0.6).stroke_width(1)))
            .map_err(e)?;
    }
    let blue = BLUE.mix(0.8).filled();
    chart
        .draw_series(pts.iter().map(|&p| Circle::new(p, 2, blue)))
        .map_err(e)?;
    Ok(())
}

fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo >= hi {
        (lo - 1.0, lo + 1.0)
    } else {
        (lo, hi)
    }
}

fn draw_map<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, m: &Map) -> Result<(), String>
where
    DB::ErrorType: 'static,
{
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let (xs, ys) = (m.x.values(), m.y.values());
    let half = |v: &[f64]| 0.5 * (v[1] - v[0]).abs();
    let (hx, hy) = (half(&xs), half(&ys));
    let (x0, x1) = bounds(xs.iter().copied());
    let (y0, y1) = bounds(ys.iter().copied());
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "largest real part of the eigenvalues (blue stable, red unstable)",
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(55)
        .build_cartesian_2d((x0 - hx)..(x1 + hx), (y0 - hy)..(y1 + hy))
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(m.x.parameter.as_str())
        .y_desc(m.y.parameter.as_str())
        .disable_mesh()
        .draw()
        .map_err(e)?;
    // Separate scales for the stable (negative) and the unstable (positive) values, so that a
    // narrow stable region still shows.
    let finite = || m.values.iter().flatten().copied().filter(|v| v.is_finite());
    let top = (
        finite()
            .filter(|v| *v < 0.0)
            .fold(0.0, |a: f64, v| a.max(-v)),
        finite().filter(|v| *v > 0.0).fold(0.0, f64::max),
    );
    let cells = ys.iter().zip(&m.values).flat_map(|(&y, row)| {
        xs.iter().zip(row).map(move |(&x, &v)| {
            Rectangle::new(
                [(x - hx, y - hy), (x + hx, y + hy)],
                colour(v, top).filled(),
            )
        })
    });
    chart.draw_series(cells).map_err(e)?;
    root.present().map_err(|e| e.to_string())
}

/// Blue for negative, red for positive, white at zero; the strength by |v| over the largest
/// of its sign (`top`: negative, positive).
fn colour(v: f64, top: (f64, f64)) -> RGBColor {
    let scale = if v > 0.0 { top.1 } else { top.0 };
    let t = if scale > 0.0 {
        (v.abs() / scale).sqrt().min(1.0)
    } else {
        0.0
    };
    let fade = (255.0 * (1.0 - t)) as u8;
    if v > 0.0 {
        RGBColor(255, fade, fade)
    } else {
        RGBColor(fade, fade, 255)
    }
}
