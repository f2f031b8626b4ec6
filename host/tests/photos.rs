//! The planner on real images shipped in `tests/data/` (scikit-image's sample data;
//! sources and licences in `tests/data/LICENSE`): only that a closed contour of a
//! plausible length is found, which is printed with a picture in
//! `$CARGO_TARGET_DIR/plots/`.

mod common;

use kerf_host::plan::{plan_file, PlanConfig};
use kerf_host::plot;
use std::path::PathBuf;

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// Plans `name` and checks that the contour is closed and `length_px` long (in image
/// pixels, along the traced chain).
fn check(name: &str, config: &PlanConfig, length_px: std::ops::Range<f64>, what: &str) {
    let (gray, plan) = plan_file(&data(name), config, &mut |_| {}).expect(name);
    let length = plan.length_mm() / plan.mm_per_px;
    let (w, h) = gray.dimensions();
    println!(
        "{name} ({w} x {h} px): closed contour of {} points, {length:.0} px long ({:.1} mm \
         at {:.4} mm/px), start at pixel ({:.0}, {:.0}): {what}",
        plan.chain_px.len(),
        plan.length_mm(),
        plan.mm_per_px,
        plan.chain_px[0][0],
        plan.chain_px[0][1],
    );
    let svg = common::plot_dir().join(format!("plan_photo_{}.svg", name.replace('.', "_")));
    plot::write_svg(&svg, name, &gray, &plan, &[]).expect("svg");
    assert!(plan.closed, "{name}");
    assert!(length_px.contains(&length), "{name}: {length} px");
}

#[test]
fn a_silhouette_gives_its_outline() {
    // 400 × 328 px, the horse about 370 px wide: its outline with the legs, some
    // 1500–2500 px.
    check(
        "horse.png",
        &PlanConfig::default(),
        1500.0..2500.0,
        "the horse's outline",
    );
}

#[test]
fn a_cell_gives_its_rim() {
    // A soft-edged disc of 64–75 px radius (perimeter 400–470 px, and an 8-connected
    // pixel chain is up to 8 % longer than the curve it follows) on a banded
    // background: more smoothing and lower thresholds than the defaults.
    let config = PlanConfig {
        sigma_px: 2.0,
        canny: (20.0, 40.0),
        ..PlanConfig::default()
    };
    check("cell.png", &config, 350.0..560.0, "the cell's rim");
}

#[test]
fn coins_give_the_outline_of_one_coin() {
    // Coins of 25–45 px radius: one coin's rim is 150–290 px (two touching coins
    // merged by the closing would be twice that).
    let config = PlanConfig {
        close_px: 2,
        ..PlanConfig::default()
    };
    check("coins.png", &config, 150.0..290.0, "one coin's rim");
}

/// A transparent PNG as drawing programs save one: transparent black all round, an
/// opaque 30 px square. Read with its transparency as background, the square's
/// outline is traced (about 4 × 30 px); read as the grey levels alone it would be
/// black on black, with nothing to trace. The same square in white on the
/// transparent sheet gives the same outline (the background then black).
#[test]
fn a_transparent_background_is_background() {
    use image::{Rgba, RgbaImage};
    let dir = common::plot_dir();
    for (shade, name) in [
        (0u8, "square_black_on_transparent.png"),
        (255, "square_white_on_transparent.png"),
    ] {
        let img = RgbaImage::from_fn(80, 80, |x, y| {
            if (25..55).contains(&x) && (25..55).contains(&y) {
                Rgba([shade, shade, shade, 255])
            } else {
                Rgba([0, 0, 0, 0])
            }
        });
        let path = dir.join(name);
        img.save(&path).unwrap();
        let (gray, plan) = plan_file(&path, &PlanConfig::default(), &mut |_| {}).expect(name);
        let length = plan.length_mm() / plan.mm_per_px;
        println!("{name}: closed contour {length:.0} px long");
        assert!(plan.closed, "{name}");
        assert!((100.0..130.0).contains(&length), "{name}: {length} px");
        // Inside and outside are the two levels, as far apart as they go.
        let (inside, outside) = (gray.get_pixel(40, 40).0[0], gray.get_pixel(5, 5).0[0]);
        assert_eq!(u8::abs_diff(inside, outside), 255, "{name}");
    }
}

/// Half-transparent pixels blend with the background: α g + (1 − α) b, rounded.
#[test]
fn partly_transparent_pixels_blend_with_the_background() {
    use image::{DynamicImage, LumaA};
    use kerf_host::plan::grey_on_background;
    let img = image::ImageBuffer::from_fn(4, 1, |x, _| match x {
        0 => LumaA([0u8, 255]),
        1 => LumaA([0, 128]),
        2 => LumaA([100, 64]),
        _ => LumaA([0, 0]),
    });
    let grey = grey_on_background(&DynamicImage::ImageLumaA8(img));
    let blend = |g: f64, a: f64| (a / 255.0 * g + (1.0 - a / 255.0) * 255.0).round() as u8;
    let want = [
        blend(0.0, 255.0),
        blend(0.0, 128.0),
        blend(100.0, 64.0),
        255,
    ];
    let got: Vec<u8> = grey.pixels().map(|p| p.0[0]).collect();
    assert_eq!(got, want);
}

/// A picture of three closed contours (a 50 px square; a ring whose outer and inner
/// edges are circles of radius 35 and 15 px): the report says there are three, the
/// job cuts the largest (the outer circle, 70 px across) unless another is chosen
/// (the square, 50 px; the inner circle, 30 px: each within 3 px, an edge pixel's
/// placement on each side and the rounding of the drawing), and one past them is
/// refused in words.
#[test]
fn every_closed_contour_is_counted_and_each_can_be_chosen() {
    use kerf_host::plan::{plan_image, PlanError};
    use kerf_host::trace::TraceError;
    let gray = image::GrayImage::from_fn(220, 130, |x, y| {
        let (x, y) = (f64::from(x), f64::from(y));
        let square = (20.0..70.0).contains(&x) && (40.0..90.0).contains(&y);
        let r = (x - 150.0).hypot(y - 65.0);
        image::Luma([if square || (15.0..35.0).contains(&r) {
            0
        } else {
            255
        }])
    });
    let mut extents = Vec::new();
    for contour in 0..3 {
        let config = PlanConfig {
            contour,
            ..PlanConfig::default()
        };
        let plan = plan_image(&gray, &config, &mut |_| {}).unwrap();
        assert_eq!(plan.contours, 3);
        assert!(plan.closed);
        let xs = plan.chain_px.iter().map(|p| p[0]);
        let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| {
            (l.min(x), h.max(x))
        });
        extents.push(hi - lo);
    }
    println!("contours, largest first: {extents:.0?} px across");
    for (got, want) in extents.iter().zip([70.0, 50.0, 30.0]) {
        assert!((got - want).abs() <= 3.0, "{extents:?}");
    }
    let past = PlanConfig {
        contour: 3,
        ..PlanConfig::default()
    };
    match plan_image(&gray, &past, &mut |_| {}) {
        Err(PlanError::Trace(TraceError::NoSuchContour { asked: 4, found: 3 })) => {}
        other => panic!("{:?}", other.map(|p| p.contours)),
    }
}

/// A photograph that yields nothing says which option to try, and the option it names
/// finds the contour: the cell's faint rim breaks up at the default thresholds.
#[test]
fn a_photograph_without_a_contour_names_the_option_to_try() {
    let e = plan_file(&data("cell.png"), &PlanConfig::default(), &mut |_| {}).unwrap_err();
    let said = e.to_string();
    assert!(
        said.contains("lower --canny thresholds, such as 20,50"),
        "{said}"
    );
    let hinted = PlanConfig {
        canny: (20.0, 50.0),
        ..PlanConfig::default()
    };
    let (_, plan) = plan_file(&data("cell.png"), &hinted, &mut |_| {}).expect("the hint works");
    assert!(plan.closed);
    // A picture with no edge at all: the thresholds are named too.
    let blank = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("blank.png");
    image::GrayImage::from_pixel(64, 64, image::Luma([200]))
        .save(&blank)
        .unwrap();
    let e = plan_file(&blank, &PlanConfig::default(), &mut |_| {}).unwrap_err();
    assert!(
        e.to_string().contains("no edges found") && e.to_string().contains("--canny"),
        "{e}"
    );
}
