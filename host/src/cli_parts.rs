//! `kerf plan --all`: the report and the files of a program of several parts
//! ([`kerf_host::parts`]).

use crate::report::{say, Report};
use crate::Failure;
use image::GrayImage;
use kerf_host::output::OutputFile;
use kerf_host::parts::PlanSet;
use kerf_host::plan::{self, PlanConfig};
use kerf_host::plot::{self, Overlay};
use plotters::style::RGBColor;

/// Reports the parts of `set` planned from the image `name` (with `config`'s kerf),
/// draws them into `svg` when given, and returns the program's job file.
pub(crate) fn report_parts(
    name: &str,
    gray: &GrayImage,
    set: &PlanSet,
    config: &PlanConfig,
    svg: Option<&OutputFile>,
    report: &mut Report,
) -> Result<Vec<u8>, Failure> {
    let (w, h) = gray.dimensions();
    say!(report, "image      {name}: {w} x {h} px");
    let left_out = match set.too_small {
        0 => String::new(),
        n => format!("; {n} smaller than --min-size-mm left out"),
    };
    say!(
        report,
        "contours   {} closed, {} parts in this job, inner ones first{left_out}",
        set.found,
        set.parts.len()
    );
    let mut fits = Vec::with_capacity(set.parts.len());
    for (k, p) in set.parts.iter().enumerate() {
        let fit = p.fit.samples_mm(2048);
        let off = plan::deviation(&fit, &p.contour_mm, true).max(plan::deviation(
            &p.contour_mm,
            &fit,
            true,
        ));
        let start = p.contour_mm.first().copied().unwrap_or([0.0; 2]);
        say!(
            report,
            "part {:>3}   {:.2} mm long, starts at ({:.2}, {:.2}) mm, fit {:.3} mm from the contour at most",
            k + 1,
            p.length_mm(),
            start[0],
            start[1],
            off
        );
        fits.push(fit);
    }
    crate::kerf_line(config, report);
    if let (Some(svg), Some(first)) = (svg, set.parts.first()) {
        // The first part drawn as a single plan is (labelled); the others over it.
        let mut extra = Vec::new();
        for (p, fit) in set.parts.iter().zip(&fits).skip(1) {
            extra.push(Overlay {
                label: "",
                points_mm: &p.contour_mm,
                closed: true,
                color: RGBColor(0, 114, 178),
            });
            extra.push(Overlay {
                label: "",
                points_mm: fit,
                closed: true,
                color: RGBColor(213, 94, 0),
            });
        }
        let text = plot::svg(name, gray, first, &extra)
            .map_err(|e| Failure::Output(format!("{}: {e}", svg.shown())))?;
        svg.write_bytes(text.as_bytes())?;
        say!(report, "wrote {}", svg.shown());
    }
    set.to_bytes()
        .map_err(|e| Failure::Input(format!("{name}: {e}")))
}
