//! The picture of a checked job ([`crate::check`]) as SVG, before it is sent: the
//! workspace's edge in the plane of the cuts, the travels (dashed), the cuts, each
//! part's start (the first one larger, the others
//! numbered in cutting order), and the estimated duration in the title. Workspace
//! millimetres, x right and y up.

use crate::check::{Checked, Preview};
use crate::plot::{dashed, err, legend, line, workspace_chart, PlotError};
use plotters::prelude::*;

/// Picture size, px (the plotting area is square).
const SIZE: (u32, u32) = (820, 860);

/// The preview of `checked` titled `title`, as SVG text; `None` when the machine has
/// no preview.
pub fn svg(title: &str, checked: &Checked) -> Result<Option<String>, PlotError> {
    let Some(preview) = &checked.preview else {
        return Ok(None);
    };
    let mut text = String::new();
    // The job's parts, as `kerf check` counts them; one part by what it cuts.
    let what = match (checked.parts, preview.closed.as_slice()) {
        (1, [true]) => "closed contour".to_owned(),
        (1, [false]) => "open path".to_owned(),
        (1, cuts) => format!("{} cuts", cuts.len()),
        (parts, _) => format!("{parts} parts"),
    };
    let caption = format!(
        "{title}: {what} on {}, about {:.1} s",
        checked.machine.name(),
        checked.duration_s
    );
    draw(
        SVGBackend::with_string(&mut text, SIZE).into_drawing_area(),
        &caption,
        preview,
    )?;
    Ok(Some(text))
}

fn mm(points: &[[f64; 2]]) -> impl Iterator<Item = (f64, f64)> + Clone + '_ {
    points.iter().map(|p| (p[0] * 1e3, p[1] * 1e3))
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    caption: &str,
    preview: &Preview,
) -> Result<(), PlotError> {
    let all = preview
        .workspace_m
        .iter()
        .chain(preview.cuts_m.iter().flatten())
        .chain(preview.travels_m.iter().flatten());
    let (lo, hi) = crate::plan::bounds(all);
    if !(lo[0].is_finite() && hi[0].is_finite()) {
        return Err(PlotError::from_words("nothing to draw"));
    }
    let to_mm = |p: [f64; 2]| p.map(|v| v * 1e3);
    let view = &preview.view;
    let mut chart = workspace_chart(&root, Some(caption), view.axes, to_mm(lo), to_mm(hi), 1.05)?;
    let grey = RGBColor(120, 120, 120);
    let mut edge: Vec<[f64; 2]> = preview.workspace_m.clone();
    if let Some(&first) = edge.first() {
        edge.push(first);
    }
    line(&mut chart, mm(&edge), &view.section, grey, 1)?;
    let travel = RGBColor(0, 114, 178);
    for (k, t) in preview.travels_m.iter().enumerate() {
        let label = if k == 0 { view.travel } else { "" };
        dashed(&mut chart, mm(t), label, travel, 2)?;
    }
    for (k, cut) in preview.cuts_m.iter().enumerate() {
        let label = if k == 0 { view.cut } else { "" };
        line(&mut chart, mm(cut), label, RGBColor(213, 94, 0), 2)?;
    }
    for (k, cut) in preview.cuts_m.iter().enumerate() {
        let Some(s) = cut.first() else { continue };
        let at = (s[0] * 1e3, s[1] * 1e3);
        if k == 0 {
            chart
                .draw_series(std::iter::once(Circle::new(at, 6, BLACK.filled())))
                .map_err(err)?
                .label("start (parts numbered in cutting order)")
                .legend(|(x, y)| Circle::new((x + 10, y), 5, BLACK.filled()));
        } else {
            chart
                .draw_series(std::iter::once(Circle::new(at, 3, BLACK.filled())))
                .map_err(err)?;
        }
        if preview.cuts_m.len() > 1 {
            let text = Text::new(format!("{}", k + 1), at, ("sans-serif", 14).into_font());
            chart.draw_series(std::iter::once(text)).map_err(err)?;
        }
    }
    legend(&mut chart)?;
    root.present().map_err(err)?;
    Ok(())
}
