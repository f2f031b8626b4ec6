//! Helpers of the planner tests: shapes rendered into noisy rasters, an independent
//! brute-force Hausdorff distance, and where the pictures go.

#![allow(dead_code)]

pub mod edges;

use image::{GrayImage, Luma};
use imageproc::drawing::{draw_filled_circle_mut, draw_polygon_mut};
use imageproc::point::Point;
use std::path::PathBuf;
use std::process::{Command, Output};

/// Supersampling of the renderer (per axis).
pub const SUPER: u32 = 4;
/// Grey of the background and of the shape.
pub const PAPER: u8 = 225;
/// Grey of the shape.
pub const INK: u8 = 35;
/// σ of the added white noise, grey levels.
pub const NOISE: f64 = 12.0;

/// How a shape in mm sits in an image: pixel = centre + mm × px_per_mm (y flipped).
#[derive(Copy, Clone, Debug)]
pub struct Raster {
    /// Image side, pixels.
    pub size: u32,
    /// Pixels per mm.
    pub px_per_mm: f64,
}

impl Raster {
    /// The pixel position (x right, y down; pixel centres at integers) of a point, mm.
    pub fn px(&self, p: [f64; 2]) -> [f64; 2] {
        let c = (f64::from(self.size) - 1.0) / 2.0;
        [c + p[0] * self.px_per_mm, c - p[1] * self.px_per_mm]
    }

    fn fine(&self, p: [f64; 2]) -> [f64; 2] {
        let q = self.px(p);
        let s = f64::from(SUPER);
        [s * (q[0] + 0.5) - 0.5, s * (q[1] + 0.5) - 0.5]
    }

    fn finish(&self, fine: &GrayImage, seed: u64) -> GrayImage {
        let n = SUPER * SUPER;
        let mut out = GrayImage::from_fn(self.size, self.size, |x, y| {
            let mut sum = 0u32;
            for dy in 0..SUPER {
                for dx in 0..SUPER {
                    sum += u32::from(fine.get_pixel(x * SUPER + dx, y * SUPER + dy)[0]);
                }
            }
            Luma([((sum + n / 2) / n) as u8])
        });
        imageproc::noise::gaussian_noise_mut(&mut out, 0.0, NOISE, seed);
        out
    }

    /// A filled polygon (points in mm), antialiased by supersampling, with noise.
    pub fn filled(&self, points_mm: &[[f64; 2]], seed: u64) -> GrayImage {
        self.composed(&[(points_mm, true)], seed)
    }

    /// Filled polygons (points in mm) drawn in order, each in ink or, for a hole, in
    /// paper, antialiased by supersampling, with noise.
    pub fn composed(&self, shapes: &[(&[[f64; 2]], bool)], seed: u64) -> GrayImage {
        let mut fine = GrayImage::from_pixel(self.size * SUPER, self.size * SUPER, Luma([PAPER]));
        for &(points_mm, ink) in shapes {
            let mut poly: Vec<Point<i32>> = points_mm
                .iter()
                .map(|&p| {
                    let q = self.fine(p);
                    Point::new(q[0].round() as i32, q[1].round() as i32)
                })
                .collect();
            poly.dedup();
            if poly.first() == poly.last() {
                poly.pop();
            }
            draw_polygon_mut(&mut fine, &poly, Luma([if ink { INK } else { PAPER }]));
        }
        self.finish(&fine, seed)
    }

    /// A stroke of `width_px` along the polyline (points in mm), with noise.
    pub fn stroke(&self, points_mm: &[[f64; 2]], width_px: f64, seed: u64) -> GrayImage {
        let mut fine = GrayImage::from_pixel(self.size * SUPER, self.size * SUPER, Luma([PAPER]));
        let r = (width_px / 2.0 * f64::from(SUPER)).round() as i32;
        for p in densify(points_mm, 0.25 / self.px_per_mm) {
            let q = self.fine(p);
            draw_filled_circle_mut(
                &mut fine,
                (q[0].round() as i32, q[1].round() as i32),
                r,
                Luma([INK]),
            );
        }
        self.finish(&fine, seed)
    }
}

/// The polyline with points added so that no segment is longer than `step`.
pub fn densify(points: &[[f64; 2]], step: f64) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    for w in points.windows(2) {
        let d = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
        let n = (d / step).ceil().max(1.0) as usize;
        for i in 0..n {
            let u = i as f64 / n as f64;
            out.push([
                w[0][0] + u * (w[1][0] - w[0][0]),
                w[0][1] + u * (w[1][1] - w[0][1]),
            ]);
        }
    }
    if let Some(&last) = points.last() {
        out.push(last);
    }
    out
}

/// `points` closed by repeating the first at the end.
pub fn closed(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut v = points.to_vec();
    if let Some(&first) = points.first() {
        v.push(first);
    }
    v
}

/// The shape as the planner normalises a contour: the larger side of its bounding box
/// `width_mm`, its centroid (mean over arc length) at the origin. Written apart from
/// the planner's code.
pub fn normalised(points: &[[f64; 2]], is_closed: bool, width_mm: f64) -> Vec<[f64; 2]> {
    let line = if is_closed {
        closed(points)
    } else {
        points.to_vec()
    };
    let xs = line.iter().map(|p| p[0]);
    let ys = line.iter().map(|p| p[1]);
    let ext_x = xs.clone().fold(f64::MIN, f64::max) - xs.fold(f64::MAX, f64::min);
    let ext_y = ys.clone().fold(f64::MIN, f64::max) - ys.fold(f64::MAX, f64::min);
    let s = width_mm / ext_x.max(ext_y);
    let (mut cx, mut cy, mut total) = (0.0, 0.0, 0.0);
    for w in line.windows(2) {
        let l = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
        cx += l * (w[0][0] + w[1][0]) / 2.0;
        cy += l * (w[0][1] + w[1][1]) / 2.0;
        total += l;
    }
    let (cx, cy) = (cx / total, cy / total);
    line.iter()
        .map(|p| [s * (p[0] - cx), s * (p[1] - cy)])
        .collect()
}

/// Symmetric Hausdorff distance between two point sets, by brute force over every
/// pair.
pub fn hausdorff(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    hausdorff_at(a, b).0
}

/// [`hausdorff`] and the point of either set where it is attained.
pub fn hausdorff_at(a: &[[f64; 2]], b: &[[f64; 2]]) -> (f64, [f64; 2]) {
    let directed = |from: &[[f64; 2]], to: &[[f64; 2]]| {
        from.iter()
            .map(|p| {
                let d2 = to
                    .iter()
                    .map(|q| (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]))
                    .fold(f64::INFINITY, f64::min);
                (d2, *p)
            })
            .fold((0.0, [f64::NAN; 2]), |m, v| if v.0 > m.0 { v } else { m })
    };
    let (ab, pa) = directed(a, b);
    let (ba, pb) = directed(b, a);
    if ab >= ba {
        (ab.sqrt(), pa)
    } else {
        (ba.sqrt(), pb)
    }
}

/// Where the tests' pictures go: `$CARGO_TARGET_DIR/plots/`, else the tests' own
/// scratch directory.
pub fn plot_dir() -> PathBuf {
    let dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(|d| PathBuf::from(d).join("plots"))
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("plots"));
    std::fs::create_dir_all(&dir).expect("plot directory");
    dir
}

/// Runs the `kerf` binary with `args`.
pub fn kerf(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kerf"))
        .args(args)
        .output()
        .expect("run kerf")
}

/// A file `name` in the tests' temporary folder.
pub fn tmp(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name)
}

/// Bytes as text (lossy).
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}
