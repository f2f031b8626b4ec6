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
