//! A picture of a plan as SVG (plotters' SVG backend): the input image underneath in
//! workspace millimetres, the traced contour, the fitted curve the job carries, the
//! start point, and optional extra curves (a test's known shape).
//!
//! The image is drawn as grey cells of at most [`MAX_CELLS`] per side (averaged, 16
//! grey levels, runs of one level merged) and lightened so that the curves stand out;
//! text goes out as SVG `<text>` (no font files needed).

use crate::output::OutputFile;
use crate::plan::Plan;
use image::GrayImage;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Most image cells along the image's longer side.
pub const MAX_CELLS: u32 = 120;
/// Picture size, px (the plotting area is square).
const SIZE: (u32, u32) = (820, 860);

/// A curve to draw over the image.
#[derive(Copy, Clone, Debug)]
pub struct Overlay<'a> {
    /// Legend text.
    pub label: &'a str,
    /// Points, mm.
    pub points_mm: &'a [[f64; 2]],
    /// Whether to draw the closing segment.
    pub closed: bool,
    /// Colour.
    pub color: RGBColor,
}

/// Why a picture was not drawn or written.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct PlotError(String);

impl PlotError {
    /// A picture not drawn, for the reason `words`.
    pub(crate) fn from_words(words: &str) -> Self {
        PlotError(format!("cannot draw the picture: {words}"))
    }
}

pub(crate) fn err<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError(format!("cannot draw the picture: {e}"))
}

impl From<crate::output::OutputError> for PlotError {
    fn from(e: crate::output::OutputError) -> Self {
        PlotError(e.to_string())
    }
}

/// A chart with both axes in f64 (every picture of this crate).
pub(crate) type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws `points` as a line of `width` px with a legend entry (none for an empty
/// label).
pub(crate) fn line<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    points: impl IntoIterator<Item = (f64, f64)>,
    label: &str,
    color: RGBColor,
    width: u32,
) -> Result<(), PlotError> {
    let series = chart
        .draw_series(LineSeries::new(points, color.stroke_width(width)))
        .map_err(err)?;
    legend_entry(series, label, color);
    Ok(())
}

/// `series`' legend entry, a short line in `color`; none for an empty label (the parts
/// after the first of a picture).
fn legend_entry<DB: DrawingBackend>(
    series: &mut plotters::chart::SeriesAnno<'_, DB>,
    label: &str,
    color: RGBColor,
) {
    if !label.is_empty() {
        series
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
    }
}

/// [`line`] dashed: a travel with the tool off (8 px dashes, 6 px apart).
pub(crate) fn dashed<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    points: impl Iterator<Item = (f64, f64)> + Clone,
    label: &str,
    color: RGBColor,
    width: u32,
) -> Result<(), PlotError> {
    let series = chart
        .draw_series(DashedLineSeries::new(
            points,
            8,
            6,
            color.stroke_width(width),
        ))
        .map_err(err)?;
    legend_entry(series, label, color);
    Ok(())
}

/// A white picture (titled `title`, if any) with a chart in workspace millimetres at
/// one scale on both axes, labelled `axes`, around the box `lo`–`hi` (mm; a box that
/// is not finite, of no points, is taken as ±0.1 mm), widened by `margin` (1.02: 2 %).
pub(crate) fn workspace_chart<'a, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    title: Option<&str>,
    axes: [&str; 2],
    lo: [f64; 2],
    hi: [f64; 2],
    margin: f64,
) -> Result<Chart<'a, DB>, PlotError> {
    let (lo, hi) = match lo.iter().chain(&hi).all(|v| v.is_finite()) {
        true => (lo, hi),
        false => ([-0.1; 2], [0.1; 2]),
    };
    let half = ((hi[0] - lo[0]).max(hi[1] - lo[1]) / 2.0 * margin).max(1e-3);
    let mid = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let build = |half_x: f64, half_y: f64| {
        root.fill(&WHITE).map_err(err)?;
        let mut builder = ChartBuilder::on(root);
        if let Some(title) = title {
            builder.caption(title, ("sans-serif", 20));
        }
        builder
            .margin(10)
            .x_label_area_size(45)
            .y_label_area_size(45)
            .build_cartesian_2d(
                mid[0] - half_x..mid[0] + half_x,
                mid[1] - half_y..mid[1] + half_y,
            )
            .map_err(err)
    };
    // A millimetre as long across as up: the longer side of the plotting area gets the
    // wider range (the layout does not depend on the ranges).
    let (w, h) = build(half, half)?.plotting_area().dim_in_pixel();
    let aspect = f64::from(w.max(1)) / f64::from(h.max(1));
    let mut chart = match aspect >= 1.0 {
        true => build(half * aspect, half)?,
        false => build(half, half / aspect)?,
    };
    chart
        .configure_mesh()
        .x_desc(axes[0])
        .y_desc(axes[1])
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(err)?;
    Ok(chart)
}

/// The legend, top right, over a light background.
pub(crate) fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(err)
}

/// Writes the picture of `plan` (module docs) with `extra` curves drawn first, whole
/// or not at all ([`crate::output`]).
pub fn write_svg(
    path: &Path,
    title: &str,
    gray: &GrayImage,
    plan: &Plan,
    extra: &[Overlay<'_>],
) -> Result<(), PlotError> {
    let text = svg(title, gray, plan, extra)?;
    OutputFile::prepare(path, "picture")
        .and_then(|f| f.write_bytes(text.as_bytes()))
        .map_err(PlotError::from)
}

/// The picture of `plan` (module docs) with `extra` curves drawn first, as SVG text.
pub fn svg(
    title: &str,
    gray: &GrayImage,
    plan: &Plan,
    extra: &[Overlay<'_>],
) -> Result<String, PlotError> {
    let mut text = String::new();
    draw(
        SVGBackend::with_string(&mut text, SIZE).into_drawing_area(),
        title,
        gray,
        plan,
        extra,
    )?;
    Ok(text)
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    gray: &GrayImage,
    plan: &Plan,
    extra: &[Overlay<'_>],
) -> Result<(), PlotError> {
    let (w, h) = gray.dimensions();
    // Workspace window: the image and every curve, squared.
    let corners = [
        plan.to_mm([-0.5, -0.5]),
        plan.to_mm([f64::from(w) - 0.5, f64::from(h) - 0.5]),
    ];
    let fit = plan.fit.samples_mm(1024);
    let all = corners
        .iter()
        .chain(plan.contour_mm.iter())
        .chain(fit.iter())
        .chain(extra.iter().flat_map(|o| o.points_mm.iter()));
    let (lo, hi) = crate::plan::bounds(all);
    let mut chart = workspace_chart(&root, Some(title), ["x, mm", "y, mm"], lo, hi, 1.02)?;

    // The image, lightened: cells of f × f pixels.
    let f = w.max(h).div_ceil(MAX_CELLS).max(1);
    let cells = (0..h.div_ceil(f)).flat_map(|cy| {
        let mut runs: Vec<(u32, u32, u8)> = Vec::new();
        for cx in 0..w.div_ceil(f) {
            let (mut sum, mut n) = (0u32, 0u32);
            for y in cy * f..((cy + 1) * f).min(h) {
                for x in cx * f..((cx + 1) * f).min(w) {
                    sum += u32::from(gray.get_pixel(x, y)[0]);
                    n += 1;
                }
            }
            let level = (sum / n.max(1) / 16) as u8;
            match runs.last_mut() {
                Some(r) if r.2 == level => r.1 = cx + 1,
                _ => runs.push((cx, cx + 1, level)),
            }
        }
        runs.into_iter().map(move |r| (cy, r))
    });
    let rects: Vec<_> = cells
        .map(|(cy, (x0, x1, level))| {
            let g = 128 + (u32::from(level) * 16 + 8) / 2;
            let a = plan.to_mm([f64::from(x0 * f) - 0.5, f64::from(cy * f) - 0.5]);
            // Half a cell past its end, so that no seam shows between cells (the next
            // cell, drawn later, covers the overlap).
            let over = 0.5 * f64::from(f) - 0.5;
            let b = plan.to_mm([
                f64::from((x1 * f).min(w)) + over,
                f64::from(((cy + 1) * f).min(h)) + over,
            ]);
            let c = RGBColor(g as u8, g as u8, g as u8);
            Rectangle::new([(a[0], a[1]), (b[0], b[1])], c.filled())
        })
        .collect();
    chart.draw_series(rects).map_err(err)?;

    let mut overlays: Vec<Overlay<'_>> = extra.to_vec();
    overlays.push(Overlay {
        label: "traced contour",
        points_mm: &plan.contour_mm,
        closed: plan.closed,
        color: RGBColor(0, 114, 178),
    });
    let fit_label = match plan.fit {
        crate::plan::Fit::Efd(ref e) => format!("EFD fit, {} harmonics", e.harmonics()),
        crate::plan::Fit::Path { ref points_m, .. } => {
            format!("job path, {} points, spline", points_m.len())
        }
    };
    overlays.push(Overlay {
        label: &fit_label,
        points_mm: &fit,
        closed: plan.closed && matches!(plan.fit, crate::plan::Fit::Efd(_)),
        color: RGBColor(213, 94, 0),
    });
    for o in &overlays {
        let mut pts: Vec<(f64, f64)> = o.points_mm.iter().map(|p| (p[0], p[1])).collect();
        if let (true, Some(&first)) = (o.closed, pts.first()) {
            pts.push(first);
        }
        line(&mut chart, pts, o.label, o.color, 2)?;
    }
    if let crate::plan::Fit::Path { ref points_m, .. } = plan.fit {
        let marks = points_m
            .iter()
            .map(|p| Circle::new((p[0] * 1e3, p[1] * 1e3), 3, RGBColor(213, 94, 0).filled()));
        chart.draw_series(marks).map_err(err)?;
    }
    if let Some(s) = plan.contour_mm.first() {
        chart
            .draw_series(std::iter::once(Circle::new(
                (s[0], s[1]),
                6,
                BLACK.filled(),
            )))
            .map_err(err)?
            .label("start")
            .legend(|(x, y)| Circle::new((x + 10, y), 5, BLACK.filled()));
    }
    legend(&mut chart)?;
    root.present().map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a wide picture and on a tall one, a millimetre takes as many pixels across as
    /// up, and the box asked for is inside the ranges.
    #[test]
    fn a_millimetre_is_as_long_across_as_up() {
        for size in [(900, 560), (500, 900)] {
            let mut text = String::new();
            let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
            let (lo, hi) = ([-5.0, -2.0], [5.0, 3.0]);
            let chart = workspace_chart(&root, Some("t"), ["x", "y"], lo, hi, 1.0).unwrap();
            let (w, h) = chart.plotting_area().dim_in_pixel();
            let (x, y) = (chart.x_range(), chart.y_range());
            let across = f64::from(w) / (x.end - x.start);
            let up = f64::from(h) / (y.end - y.start);
            assert!((across / up - 1.0).abs() < 1e-12, "{size:?}: {across} {up}");
            assert!(x.start <= lo[0] && x.end >= hi[0] && y.start <= lo[1] && y.end >= hi[1]);
        }
        // Untitled, and a box of no points: ±0.1 mm about the origin.
        let mut text = String::new();
        let root = SVGBackend::with_string(&mut text, (900, 560)).into_drawing_area();
        let none = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let chart = workspace_chart(&root, None, ["x", "y"], none.0, none.1, 1.0).unwrap();
        let y = chart.y_range();
        assert!(
            (y.start + 0.1).abs() < 1e-12 && (y.end - 0.1).abs() < 1e-12,
            "{y:?}"
        );
    }
}
