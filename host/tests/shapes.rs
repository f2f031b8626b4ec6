//! The planner on generated images of T's test contours (T fig. 8.1–8.4, in
//! `kerf::trajectory::shapes`): each rendered at a known scale with white noise,
//! planned, and its traced contour compared with the known shape normalised the same
//! way (largest side 12 mm, centroid at the origin) by the symmetric Hausdorff
//! distance, computed by brute force over both point sets densified to 0.01 mm.
//!
//! The bound, in pixels of the traced image (p = 12 mm / the contour's extent in
//! pixels, about 0.043 mm here), adds:
//! - 1 px for where Canny puts an edge: non-maximum suppression keeps one of the two
//!   pixels beside the true boundary (±0.5 px), and noise moves the maximum by a
//!   fraction of a pixel more;
//! - 1 px for the scale and the centroid: both come from the traced chain, whose
//!   extent is off by up to twice the edge error over some 280 px, which moves a point
//!   140 px from the centroid by about a pixel;
//! - corners: the smoothing (σ 1 px, then Canny's 1.4 px: 1.7 px together) moves the
//!   edge off a corner's vertex. At the octagon's 135° corners and on the smooth cam
//!   that is under a pixel: 1 px, **3 px** in all. The gear's roots are concave corners
//!   of about 110° between the root arc and the steep flank, where the blurred edge
//!   cuts across the background wedge by about σ: 2 px, **4 px** in all.
//! - The letters are 3 px strokes: their centre lines come from the two edges of each
//!   stroke merged by the closing and thinned, within a pixel of the stroke's centre
//!   (1 px, for the edges' localisation as above), 1 px for scale and centroid, 1 px
//!   for the skeleton's wander between the two edges (thinning is not symmetric), and
//!   1 px for the ends, put one half-width inside the band's tip (the tip pixel
//!   quantised, the cap's edge about 2.2 px beyond the end and the half-width about
//!   2.8 px): **4 px**.
//!
//! Each input is planned with three noise draws; the distances are printed (run with
//! `--nocapture`) and a picture of each is written to `$CARGO_TARGET_DIR/plots/`.

mod common;

use common::{densify, hausdorff, hausdorff_at, normalised, plot_dir, Raster};
use kerf::trajectory::shapes;
use kerf_host::plan::{plan_image, Fit, PlanConfig};
use kerf_host::plot::{self, Overlay};
use plotters::style::RGBColor;

struct Case {
    name: &'static str,
    points_mm: Vec<[f64; 2]>,
    closed: bool,
    raster: Raster,
    bound_px: f64,
}

fn mm(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    points.iter().map(|p| [p[0] * 1e3, p[1] * 1e3]).collect()
}

fn run(case: &Case, seed: u64) -> (f64, f64) {
    let image = if case.closed {
        case.raster.filled(&case.points_mm, seed)
    } else {
        case.raster.stroke(&case.points_mm, 3.0, seed)
    };
    let config = PlanConfig {
        start_px: (!case.closed).then(|| case.raster.px(case.points_mm[0])),
        ..PlanConfig::default()
    };
    let plan = plan_image(&image, &config, &mut |_| {}).expect(case.name);
    assert_eq!(plan.closed, case.closed, "{}", case.name);
    let truth = normalised(&case.points_mm, case.closed, config.width_mm);
    let traced = if case.closed {
        common::closed(&plan.contour_mm)
    } else {
        plan.contour_mm.clone()
    };
    let step = 0.01;
    let truth_dense = densify(&truth, step);
    let (d, at) = hausdorff_at(&densify(&traced, step), &truth_dense);
    let fit = plan.fit.samples_mm(4096);
    let fit_line = if case.closed {
        common::closed(&fit)
    } else {
        fit.clone()
    };
    let d_fit = hausdorff(&densify(&fit_line, step), &truth_dense);
    let px = plan.mm_per_px;
    let what = match &plan.fit {
        Fit::Efd(e) => format!("EFD {} harmonics", e.harmonics()),
        Fit::Path { points_m, .. } => format!("path of {} points", points_m.len()),
    };
    println!(
        "{:8} seed {seed}: traced: Hausdorff {:.4} mm = {:.2} px at ({:.2}, {:.2}) mm (pixel {:.4} mm, \
         bound {} px = {:.4} mm); {what}: {:.4} mm; {} points, length {:.2} mm",
        case.name,
        d,
        d / px,
        at[0],
        at[1],
        px,
        case.bound_px,
        case.bound_px * px,
        d_fit,
        plan.chain_px.len(),
        plan.length_mm()
    );
    let svg = plot_dir().join(format!("plan_{}_{seed}.svg", case.name));
    let known = Overlay {
        label: "known shape",
        points_mm: &truth,
        closed: false,
        color: RGBColor(0, 0, 0),
    };
    plot::write_svg(
        &svg,
        &format!("{}: traced and fitted", case.name),
        &image,
        &plan,
        &[known],
    )
    .expect("svg");
    // Its start is where asked: the rightmost point for closed contours, the given
    // end for open ones.
    let first = plan.contour_mm[0];
    if case.closed {
        let right = plan
            .contour_mm
            .iter()
            .map(|p| p[0])
            .fold(f64::MIN, f64::max);
        assert_eq!(first[0], right, "{}", case.name);
    } else {
        let d0 = (first[0] - truth[0][0]).hypot(first[1] - truth[0][1]);
        assert!(d0 < case.bound_px * px, "{}: start {d0} mm off", case.name);
    }
    assert!(
        d < case.bound_px * px,
        "{}: Hausdorff {d} mm above {} px",
        case.name,
        case.bound_px
    );
    (d, px)
}

/// Noise draws each input is planned with.
const SEEDS: [u64; 3] = [7, 8, 9];

#[test]
fn the_closed_shapes_are_traced_within_three_pixels_four_at_the_gear_roots() {
    let raster = Raster {
        size: 360,
        px_per_mm: 14.0,
    };
    for (name, points, bound_px) in [
        ("octagon", mm(&shapes::octagon()), 3.0),
        ("gear", mm(&shapes::gear()), 4.0),
        ("cam", mm(&shapes::cam()), 3.0),
    ] {
        let case = Case {
            name,
            points_mm: points,
            closed: true,
            raster,
            bound_px,
        };
        SEEDS.iter().for_each(|&seed| {
            run(&case, seed);
        });
    }
}

#[test]
fn the_letters_are_traced_as_open_contours_within_four_pixels() {
    let e = Case {
        name: "letter_e",
        points_mm: mm(&shapes::letter_e()),
        closed: false,
        raster: Raster {
            size: 360,
            px_per_mm: 25.0,
        },
        bound_px: 4.0,
    };
    let s = Case {
        name: "letter_s",
        points_mm: mm(&shapes::letter_s()),
        closed: false,
        raster: Raster {
            size: 360,
            px_per_mm: 17.0,
        },
        bound_px: 4.0,
    };
    for case in [e, s] {
        SEEDS.iter().for_each(|&seed| {
            run(&case, seed);
        });
    }
}

/// `Plan::to_mm` on the traced octagon's chain against the figures the module docs
/// give the workspace (not the planner's own arithmetic): the mapped chain's bounding
/// box has the configured width as its larger side, its length-weighted centroid
/// (midpoint rule over the closed polyline) is the origin, and image y (down) is
/// workspace −y: the pixel highest in the image is the point highest in the
/// workspace. Tolerances: f64 rounding over some 900 points of ±6 mm, 1e-9 mm.
#[test]
fn pixels_map_to_a_workspace_centred_on_the_contour_at_the_set_width() {
    let raster = Raster {
        size: 360,
        px_per_mm: 14.0,
    };
    let image = raster.filled(&mm(&shapes::octagon()), SEEDS[0]);
    let config = PlanConfig::default();
    let plan = plan_image(&image, &config, &mut |_| {}).expect("octagon");
    let mapped: Vec<[f64; 2]> = plan.chain_px.iter().map(|&p| plan.to_mm(p)).collect();
    let (lo, hi) = mapped.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    );
    let side = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    assert!((side - config.width_mm).abs() < 1e-9, "{side}");
    let (mut moment, mut length) = ([0.0, 0.0], 0.0);
    for (a, b) in mapped.iter().zip(mapped.iter().cycle().skip(1)) {
        let l = (b[0] - a[0]).hypot(b[1] - a[1]);
        moment = [
            moment[0] + l * (a[0] + b[0]) / 2.0,
            moment[1] + l * (a[1] + b[1]) / 2.0,
        ];
        length += l;
    }
    let centre = [moment[0] / length, moment[1] / length];
    assert!(
        centre[0].abs() < 1e-9 && centre[1].abs() < 1e-9,
        "{centre:?}"
    );
    let top = plan
        .chain_px
        .iter()
        .min_by(|a, b| a[1].total_cmp(&b[1]))
        .unwrap();
    assert_eq!(plan.to_mm(*top)[1], hi[1]);
    assert!(hi[1] > 0.0);
}
