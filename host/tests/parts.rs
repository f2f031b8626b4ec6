//! `kerf plan --all` (`kerf_host::parts`): every closed contour of a picture as the
//! parts of one job, in one frame, inner contours first and then the nearest; the
//! even-odd inside test against the circles of regular polygons; the size filter; the
//! parts read back, checked and previewed as one program.

mod common;

use common::kerf;
use kerf_host::check::{check, OUTLINE_DIRECTIONS};
use kerf_host::job::{split, Job};
use kerf_host::parts::{cutting_order, inside, plan_all};
use kerf_host::plan::{PlanConfig, PlanError};

/// `n` vertices of a regular polygon of circumradius `r` about `c`, mm.
fn polygon(n: usize, r: f64, c: [f64; 2]) -> Vec<[f64; 2]> {
    (0..n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            [c[0] + r * a.cos(), c[1] + r * a.sin()]
        })
        .collect()
}

/// A point inside a regular polygon's inscribed circle is inside it, one outside its
/// circumscribed circle is not (a different construction than the ray's crossings).
#[test]
fn inside_agrees_with_the_circles_of_regular_polygons() {
    let mut checked = 0;
    for (n, r, c) in [
        (3, 5.0, [0.0, 0.0]),
        (8, 2.0, [3.0, -1.0]),
        (17, 0.7, [-2.0, 4.0]),
    ] {
        let ring = polygon(n, r, c);
        let inradius = r * (std::f64::consts::PI / n as f64).cos();
        for i in 0..60 {
            for j in 0..60 {
                let p = [
                    c[0] - 1.5 * r + 3.0 * r * i as f64 / 59.0,
                    c[1] - 1.5 * r + 3.0 * r * j as f64 / 59.0,
                ];
                let d = (p[0] - c[0]).hypot(p[1] - c[1]);
                if d < inradius * 0.999 {
                    assert!(inside(p, &ring), "{n}-gon: {p:?}");
                    checked += 1;
                } else if d > r * 1.001 {
                    assert!(!inside(p, &ring), "{n}-gon: {p:?}");
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 8000);
}

/// A contour is cut after every contour inside it; the rest by nearest start.
#[test]
fn inner_contours_come_first_then_the_nearest() {
    // A frame around a hole, a shape far to the right, and one near the origin.
    let frame = polygon(4, 10.0, [0.0, 20.0]);
    let hole = polygon(4, 3.0, [0.0, 20.0]);
    let far = polygon(6, 1.0, [40.0, 0.0]);
    let near = polygon(6, 1.0, [2.0, 0.0]);
    let rings = vec![frame, far, hole, near];
    // From the origin: near (start 3, 0); then the hole (its frame waits for it),
    // the frame, and the far one last.
    assert_eq!(cutting_order(&rings), [3, 2, 0, 1]);
    // A ring inside a ring inside a ring: innermost first, whatever the distances.
    let nested = vec![
        polygon(4, 30.0, [0.0, 0.0]),
        polygon(4, 20.0, [0.0, 0.0]),
        polygon(4, 10.0, [50.0, 50.0]),
        polygon(4, 5.0, [0.0, 0.0]),
    ];
    assert_eq!(cutting_order(&nested), [3, 1, 0, 2]);
}

/// An octagonal ring (radius 6 mm with a hole of 2.5 mm) and a disc of 3 mm, 22 mm
/// across together: three contours in one frame, the hole before the ring, each where
/// the drawing puts it.
fn picture() -> image::GrayImage {
    let raster = common::Raster {
        size: 300,
        px_per_mm: 10.0,
    };
    let outer = polygon(8, 6.0, [-5.0, 3.0]);
    let hole = polygon(8, 2.5, [-5.0, 3.0]);
    let disc = polygon(48, 3.0, [8.0, -5.0]);
    raster.composed(&[(&outer, true), (&hole, false), (&disc, true)], 7)
}

#[test]
fn every_contour_of_a_picture_is_a_part_in_its_place() {
    let gray = picture();
    // Read back from a file as the command reads it: the same grey levels.
    let png = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("parts-read.png");
    gray.save(&png).unwrap();
    assert_eq!(kerf_host::plan::read_grey(&png).unwrap(), gray);
    assert!(kerf_host::plan::read_grey(std::path::Path::new("/nonexistent.png")).is_err());
    // The contours traced one by one are those traced all at once.
    let skeleton =
        kerf_host::plan::skeleton(&kerf_host::plan::edges(&gray, &PlanConfig::default()).unwrap());
    let all = kerf_host::trace::closed_chains(&skeleton).unwrap();
    for (k, chain) in all.iter().enumerate() {
        assert_eq!(
            &kerf_host::trace::closed_chain(&skeleton, k).unwrap().0,
            chain
        );
    }
    let config = PlanConfig {
        width_mm: 22.0,
        ..PlanConfig::default()
    };
    let set = plan_all(&gray, &config, 0.0, &mut |_| {}).unwrap();
    assert_eq!((set.found, set.parts.len(), set.too_small), (3, 3, 0));
    // The drawing spans x −11..11 and y −8..9 mm: the frame's origin is the box's
    // centre, (0, 0.5) mm of the drawing.
    let expected = [([-5.0, 2.5], 5.0), ([-5.0, 2.5], 12.0), ([8.0, -5.5], 6.0)];
    for (part, (centre, across)) in set.parts.iter().zip(expected) {
        let Job::Efd { centre_m, .. } = &part.job else {
            panic!("an EFD part")
        };
        let c = centre_m.map(|v| f64::from(v) * 1e3);
        let (lo, hi) = part.contour_mm.iter().fold(
            ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
            |(lo, hi), p| {
                (
                    [lo[0].min(p[0]), lo[1].min(p[1])],
                    [hi[0].max(p[0]), hi[1].max(p[1])],
                )
            },
        );
        let size = (hi[0] - lo[0]).max(hi[1] - lo[1]);
        println!(
            "part at ({:.3}, {:.3}) mm, {size:.3} mm across; drawn at {centre:?}, {across} mm",
            c[0], c[1]
        );
        // Half a pixel (0.05 mm) of edge placement each side, and the scale's error
        // from the box's edges (a pixel in 220).
        assert!((c[0] - centre[0]).hypot(c[1] - centre[1]) < 0.15, "{c:?}");
        assert!((size - across).abs() < 0.2, "{size}");
    }
    // The file reads back as three parts, and the machine takes them as one program
    // whose duration is the parts' sum.
    let bytes = set.to_bytes().unwrap();
    let parts = split(&bytes).unwrap();
    assert_eq!(parts.len(), 3);
    let all = check(&bytes, None).unwrap();
    let sum: f64 = parts
        .iter()
        .map(|p| check(p, None).unwrap().duration_s)
        .sum();
    assert_eq!(all.parts, 3);
    assert!((all.duration_s - sum).abs() < 1e-12);
    let preview = all.preview.unwrap();
    assert_eq!((preview.cuts_m.len(), preview.travels_m.len()), (3, 3));
    // The program's preview has the machine's workspace, as a single part's has.
    let one = check(parts[0], None).unwrap().preview.unwrap();
    assert_eq!(preview.workspace_m.len(), OUTLINE_DIRECTIONS);
    assert_eq!(preview.workspace_m, one.workspace_m);
    // Each travel leads from one part's end to the next one's start.
    for (k, t) in preview.travels_m.iter().enumerate().skip(1) {
        assert_eq!(Some(&t[0]), preview.cuts_m[k - 1].last());
        assert_eq!(Some(&t[1]), preview.cuts_m[k].first());
    }
}

#[test]
fn contours_under_the_size_are_left_out_and_all_of_them_is_an_error_in_words() {
    let gray = picture();
    let config = PlanConfig {
        width_mm: 22.0,
        ..PlanConfig::default()
    };
    let set = plan_all(&gray, &config, 5.5, &mut |_| {}).unwrap();
    assert_eq!((set.found, set.parts.len(), set.too_small), (3, 2, 1));
    match plan_all(&gray, &config, 13.0, &mut |_| {}) {
        Err(e @ PlanError::NothingLargeEnough { largest_mm, .. }) => {
            assert!((largest_mm - 12.0).abs() < 0.2, "{largest_mm}");
            assert!(
                e.to_string().contains("give a smaller --min-size-mm"),
                "{e}"
            );
        }
        other => panic!("{other:?}"),
    }
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            plan_all(&gray, &config, bad, &mut |_| {}),
            Err(PlanError::Config(_))
        ));
    }
}

/// `kerf plan --all` writes the parts as one file and says so; its options are
/// refused with the others they cannot go with.
#[test]
fn kerf_plan_all_writes_one_file_of_parts() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR"));
    let png = dir.join("parts.png");
    picture().save(&png).unwrap();
    let job = dir.join("parts.kjob");
    let png_s = png.to_str().unwrap();
    let out = kerf(&[
        "plan",
        png_s,
        "--all",
        "--width-mm",
        "22",
        "--out",
        job.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains("3 closed, 3 parts in this job, inner ones first"),
        "{said}"
    );
    assert_eq!(split(&std::fs::read(&job).unwrap()).unwrap().len(), 3);
    let out = kerf(&[
        "plan",
        png_s,
        "--all",
        "--width-mm",
        "22",
        "--min-size-mm",
        "5.5",
    ]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 smaller than --min-size-mm left out"));
    for args in [
        &["plan", png_s, "--all", "--contour", "2"][..],
        &["plan", png_s, "--all", "--start", "1,1"],
        &["plan", png_s, "--min-size-mm", "1"],
    ] {
        assert_eq!(kerf(args).status.code(), Some(2), "{args:?}");
    }
    let out = kerf(&["plan", png_s, "--all", "--min-size-mm=-1"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("smallest size"));
}

/// The kerf offset of a program's parts: to the scrap's side, which alternates from an
/// outline to its hole. With the outside as scrap the octagon's hole shrinks and the
/// octagon and the disc grow; with the inside, the other way. Each by half the kerf
/// all round: a closed convex curve moved out by d is 2π·d longer (in: shorter), to
/// 0.02 mm (the fits' ringing at the octagon's corners).
#[test]
fn the_kerf_offset_moves_outlines_out_and_holes_in() {
    use kerf_host::kerf_offset::KerfSide;
    use kerf_host::plan::polyline_length;
    let gray = picture();
    let length = |side: KerfSide, kerf_mm: f64| -> Vec<f64> {
        let config = PlanConfig {
            width_mm: 22.0,
            kerf_mm,
            kerf_side: side,
            ..PlanConfig::default()
        };
        let set = plan_all(&gray, &config, 0.0, &mut |_| {}).unwrap();
        set.parts
            .iter()
            .map(|p| polyline_length(&p.fit.samples_mm(4096), true))
            .collect()
    };
    let drawn = length(KerfSide::Outside, 0.0);
    let step = std::f64::consts::TAU * 0.2;
    // Cutting order: the hole, then the octagon around it, then the disc.
    for (side, signs) in [
        (KerfSide::Outside, [-1.0, 1.0, 1.0]),
        (KerfSide::Inside, [1.0, -1.0, -1.0]),
    ] {
        let cut = length(side, 0.4);
        for k in 0..3 {
            let change = cut[k] - drawn[k];
            println!("{side:?}: part {} {:+.4} mm", k + 1, change);
            assert!(
                (change - signs[k] * step).abs() < 0.02,
                "{side:?} {k}: {change}"
            );
        }
    }
}

/// A lead-in per closed contour, cut just before it: a straight path of the length
/// asked that ends at the contour's start and begins in the scrap — outside an
/// outline, inside a hole (and the other way with the inside as scrap); the program
/// (three lead-ins, three parts) is one the slave takes.
#[test]
fn each_lead_in_comes_from_the_scrap_to_its_contours_start() {
    use kerf_host::kerf_offset::KerfSide;
    let gray = picture();
    for side in [KerfSide::Outside, KerfSide::Inside] {
        let config = PlanConfig {
            width_mm: 22.0,
            lead_in_mm: 1.5,
            kerf_side: side,
            ..PlanConfig::default()
        };
        let set = plan_all(&gray, &config, 0.0, &mut |_| {}).unwrap();
        let bytes = set.to_bytes().unwrap();
        assert_eq!(split(&bytes).unwrap().len(), 6);
        assert_eq!(check(&bytes, None).unwrap().parts, 6);
        // Cutting order: the hole, then the octagon around it, then the disc.
        for (k, part) in set.parts.iter().enumerate() {
            let Some(Job::Path { points_m }) = &part.lead_in else {
                panic!("a lead-in path")
            };
            let mm = |p: &[f32; 2]| [f64::from(p[0]) * 1e3, f64::from(p[1]) * 1e3];
            let (from, to) = (mm(&points_m[0]), mm(&points_m[points_m.len() - 1]));
            let start = part.fit.samples_mm(8)[0];
            assert!(
                (to[0] - start[0]).hypot(to[1] - start[1]) < 1e-5,
                "{to:?} {start:?}"
            );
            assert!(((from[0] - to[0]).hypot(from[1] - to[1]) - 1.5).abs() < 1e-5);
            let in_scrap_inside = (k == 0) == (side == KerfSide::Outside);
            let ring = part.fit.samples_mm(1024);
            assert_eq!(
                inside(from, &ring),
                in_scrap_inside,
                "{side:?} part {}",
                k + 1
            );
        }
    }
}
