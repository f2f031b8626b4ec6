//! SVG pictures of the host scenarios, drawn with `plotters`' SVG backend.
//!
//! Text goes out as SVG `<text>` elements (plotters without its `ttf`/`ab_glyph`
//! features measures text with a built-in estimate), so no font files or fontconfig
//! are needed; the viewer's sans-serif font renders it.
//!
//! Every picture is [`SIZE`] pixels. Each series is drawn as one polyline per run of
//! finite points (a NaN or infinite point leaves a gap), each run cut down by
//! [`decimate`] to at most [`MAX_POINTS`] points so that the files stay small.

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::error::Error;
use std::ops::Range;
use std::path::Path;

pub use plotters::style::RGBColor;

/// Width and height of every picture, px.
pub const SIZE: (u32, u32) = (800, 400);
/// Most points drawn per run of a series (see [`decimate`]).
pub const MAX_POINTS: usize = 2000;
/// Colours for series in order (Okabe–Ito, distinguishable with colour blindness).
pub const PALETTE: [RGBColor; 6] = [
    RGBColor(0, 0, 0),
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(230, 159, 0),
];

const FONT: &str = "sans-serif";

/// What the drawing functions return: I/O and drawing errors boxed.
pub type PlotResult = Result<(), Box<dyn Error>>;

/// One line of a picture.
#[derive(Copy, Clone, Debug)]
pub struct Series<'a> {
    /// Legend text.
    pub label: &'a str,
    /// (x, y) points in the axes' units, in drawing order.
    pub points: &'a [(f64, f64)],
    /// Line colour.
    pub color: RGBColor,
}

impl<'a> Series<'a> {
    /// A series coloured by its position `index` in the [`PALETTE`] (wrapping).
    pub fn new(label: &'a str, points: &'a [(f64, f64)], index: usize) -> Self {
        Self {
            label,
            points,
            color: PALETTE[index % PALETTE.len()],
        }
    }
}

/// A window of the x–y plane, mm (bounds in either order).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct ZoomBox {
    /// x from, to.
    pub x_mm: (f64, f64),
    /// y from, to.
    pub y_mm: (f64, f64),
}

impl ZoomBox {
    /// The square of half-side `half_mm` around `(x, y)`.
    pub fn around(x_mm: f64, y_mm: f64, half_mm: f64) -> Self {
        Self {
            x_mm: (x_mm - half_mm, x_mm + half_mm),
            y_mm: (y_mm - half_mm, y_mm + half_mm),
        }
    }

    fn ranges(&self) -> (Range<f64>, Range<f64>) {
        let (x0, x1) = self.x_mm;
        let (y0, y1) = self.y_mm;
        (x0.min(x1)..x0.max(x1), y0.min(y1)..y0.max(y1))
    }
}

/// Which extremes [`decimate`] keeps in each bucket.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Extremes {
    /// The points of smallest and largest y (curves against time or arc length).
    Y,
    /// The points of smallest and largest x and of smallest and largest y (paths in
    /// the plane: each bucket's bounding box survives).
    XY,
}

/// At most `max_points` of `points` (a subsequence, in order) for drawing.
///
/// Unchanged if it already fits. Otherwise the points are cut into `B` buckets of
/// consecutive indices, bucket `b` holding indices `[b·n/B, (b+1)·n/B)`, and each
/// bucket keeps the points holding its extremes ([`Extremes`]; on ties the first),
/// in their original order; the first and last points are always kept. `B` is
/// `(max_points − 2) / 2` for [`Extremes::Y`] and `(max_points − 2) / 4` for
/// [`Extremes::XY`] (at least one), so each bucket's range, hence every peak and the
/// envelope of a noisy signal, is drawn exactly. `max_points` below 6 counts as 6.
pub fn decimate(points: &[(f64, f64)], max_points: usize, extremes: Extremes) -> Vec<(f64, f64)> {
    let n = points.len();
    let max_points = max_points.max(6);
    if n <= max_points {
        return points.to_vec();
    }
    let per_bucket = match extremes {
        Extremes::Y => 2,
        Extremes::XY => 4,
    };
    let buckets = ((max_points - 2) / per_bucket).max(1);
    let mut out = Vec::with_capacity(max_points);
    out.push(points[0]);
    let mut last_kept = 0;
    for b in 0..buckets {
        let (start, end) = (b * n / buckets, (b + 1) * n / buckets);
        let bucket = &points[start..end];
        let mut keep = [
            start + arg_best(bucket, |p| p.1, |a, b| a < b),
            start + arg_best(bucket, |p| p.1, |a, b| a > b),
            start + arg_best(bucket, |p| p.0, |a, b| a < b),
            start + arg_best(bucket, |p| p.0, |a, b| a > b),
        ];
        let keep = &mut keep[..per_bucket];
        keep.sort_unstable();
        for &i in keep.iter() {
            // Index 0 is already out, and a point holding two extremes goes out once.
            if i > last_kept {
                out.push(points[i]);
                last_kept = i;
            }
        }
    }
    if last_kept != n - 1 {
        out.push(points[n - 1]);
    }
    out
}

/// Index of the first point of `bucket` whose `key` no later point beats.
fn arg_best(
    bucket: &[(f64, f64)],
    key: impl Fn(&(f64, f64)) -> f64,
    better: impl Fn(f64, f64) -> bool,
) -> usize {
    let mut best = 0;
    for (i, p) in bucket.iter().enumerate() {
        if better(key(p), key(&bucket[best])) {
            best = i;
        }
    }
    best
}

/// `<target dir>/<profile>/plots/` (beside the test binary's `deps/`), created: where
/// the scenarios write their pictures.
pub fn plots_dir() -> std::io::Result<std::path::PathBuf> {
    let exe = std::env::current_exe()?;
    let dir = exe
        .parent()
        .and_then(Path::parent)
        .map(|d| d.join("plots"))
        .ok_or_else(|| std::io::Error::other("test binary has no target directory"))?;
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

/// Reference path and responses in the x–y plane, mm, at equal scale on both axes,
/// one line per series with a legend; with a `zoom` window, a second panel on the
/// right shows the same series inside it (lines cut at its edges) and the window is
/// outlined on the first.
pub fn xy_with_zoom(
    path: &Path,
    title: &str,
    series: &[Series],
    zoom: Option<ZoomBox>,
) -> PlotResult {
    let (x, y) = padded_bounds(series)?;
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let area = root.titled(title, (FONT, 18))?;
    match zoom {
        None => xy_panel(&area, series, (x, y), None, true)?,
        Some(window) => {
            let (left, right) = area.split_horizontally(SIZE.0 / 2);
            let left = left.titled("whole path", (FONT, 14))?;
            let right = right.titled("zoom", (FONT, 14))?;
            xy_panel(&left, series, (x, y), Some(window), true)?;
            xy_panel(&right, series, window.ranges(), None, false)?;
        }
    }
    root.present()?;
    Ok(())
}

/// Curves against time: x in s, `y_label` naming the quantity and unit (for
/// example "normal error (µm)").
pub fn time_series(path: &Path, title: &str, y_label: &str, series: &[Series]) -> PlotResult {
    line_plot(path, title, "time (s)", y_label, series)
}

/// Curves along the path: x is arc length in mm (for example energy per length
/// against arc length).
pub fn along_path(path: &Path, title: &str, y_label: &str, series: &[Series]) -> PlotResult {
    line_plot(path, title, "arc length (mm)", y_label, series)
}

/// Curves y(x) with a legend, axes fitted to the data (5 % margin).
pub fn line_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> PlotResult {
    let (x, y) = padded_bounds(series)?;
    let root = SVGBackend::new(path, SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let area = root.titled(title, (FONT, 18))?;
    let mut chart = builder(&area).build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .draw()?;
    for s in series {
        draw_runs(&mut chart, s, finite_runs(s.points), Extremes::Y)?;
    }
    legend(&mut chart)?;
    root.present()?;
    Ok(())
}

type Chart<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn builder<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, Shift>,
) -> ChartBuilder<'a, 'b, SVGBackend<'b>> {
    let mut b = ChartBuilder::on(area);
    b.margin(10).x_label_area_size(35).y_label_area_size(60);
    b
}

/// One x–y panel: `bounds` widened to equal scale, an optional window outlined.
fn xy_panel(
    area: &DrawingArea<SVGBackend, Shift>,
    series: &[Series],
    bounds: (Range<f64>, Range<f64>),
    outline: Option<ZoomBox>,
    with_legend: bool,
) -> PlotResult {
    let mut b = builder(area);
    // Measure the plotting area (building draws nothing without a caption).
    let pixels = b
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)?
        .plotting_area()
        .dim_in_pixel();
    let (x, y) = equal_aspect(bounds.0, bounds.1, pixels);
    let window = (x.clone(), y.clone());
    let mut chart = b.build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_desc("x (mm)")
        .y_desc("y (mm)")
        .draw()?;
    for s in series {
        let runs = finite_runs(s.points)
            .into_iter()
            .flat_map(|run| clip_polyline(&run, &window.0, &window.1))
            .collect();
        draw_runs(&mut chart, s, runs, Extremes::XY)?;
    }
    if let Some(z) = outline {
        let (zx, zy) = z.ranges();
        chart.draw_series(std::iter::once(Rectangle::new(
            [(zx.start, zy.start), (zx.end, zy.end)],
            BLACK.stroke_width(1),
        )))?;
    }
    if with_legend {
        legend(&mut chart)?;
    }
    Ok(())
}

/// Draws each run of a series (decimated), labelling the first for the legend.
fn draw_runs<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    series: &Series,
    runs: Vec<Vec<(f64, f64)>>,
    extremes: Extremes,
) -> PlotResult {
    let color = series.color;
    let budget = (MAX_POINTS / runs.len().max(1)).max(16);
    let mut labelled = false;
    for run in runs {
        let drawn = chart.draw_series(LineSeries::new(
            decimate(&run, budget, extremes),
            color.stroke_width(1),
        ))?;
        if !labelled {
            drawn
                .label(series.label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
            labelled = true;
        }
    }
    Ok(())
}

fn legend<'a, 'b: 'a>(chart: &mut Chart<'a, 'b>) -> PlotResult {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 12))
        .draw()?;
    Ok(())
}

/// The finite points of `points` as runs of consecutive points (a non-finite point
/// ends a run).
fn finite_runs(points: &[(f64, f64)]) -> Vec<Vec<(f64, f64)>> {
    points
        .split(|p| !(p.0.is_finite() && p.1.is_finite()))
        .filter(|run| !run.is_empty())
        .map(<[_]>::to_vec)
        .collect()
}

/// Bounds of every finite point of every series, widened by 5 % (a flat direction by
/// 10 % of its value, or ±1 at zero).
fn padded_bounds(series: &[Series]) -> Result<(Range<f64>, Range<f64>), Box<dyn Error>> {
    let mut lo = (f64::INFINITY, f64::INFINITY);
    let mut hi = (f64::NEG_INFINITY, f64::NEG_INFINITY);
    for &(x, y) in series.iter().flat_map(|s| s.points) {
        if x.is_finite() && y.is_finite() {
            lo = (lo.0.min(x), lo.1.min(y));
            hi = (hi.0.max(x), hi.1.max(y));
        }
    }
    if lo.0 > hi.0 {
        return Err("no finite point to draw".into());
    }
    let pad = |a: f64, b: f64| {
        let d = if b > a {
            0.05 * (b - a)
        } else if a != 0.0 {
            0.1 * a.abs()
        } else {
            1.0
        };
        (a - d)..(b + d)
    };
    Ok((pad(lo.0, hi.0), pad(lo.1, hi.1)))
}

/// `x`, `y` widened about their centres so that one unit takes as many pixels on
/// both axes of a plotting area of `pixels` (width, height).
pub fn equal_aspect(x: Range<f64>, y: Range<f64>, pixels: (u32, u32)) -> (Range<f64>, Range<f64>) {
    let (w, h) = (f64::from(pixels.0.max(1)), f64::from(pixels.1.max(1)));
    let per_px = ((x.end - x.start) / w).max((y.end - y.start) / h);
    let widen = |r: Range<f64>, px: f64| {
        let (c, half) = (0.5 * (r.start + r.end), 0.5 * per_px * px);
        (c - half)..(c + half)
    };
    (widen(x, w), widen(y, h))
}

/// The parts of the polyline inside the window `x` × `y`, each segment cut at the
/// window's edges (Liang–Barsky); a polyline that leaves and re-enters gives several
/// runs.
pub fn clip_polyline(
    points: &[(f64, f64)],
    x: &Range<f64>,
    y: &Range<f64>,
) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    if let [p] = points {
        if let Some((p, _)) = clip_segment(*p, *p, x, y) {
            runs.push(vec![p]);
        }
        return runs;
    }
    for pair in points.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        match clip_segment(a, b, x, y) {
            Some((p, q)) => {
                if current.last() != Some(&p) {
                    if !current.is_empty() {
                        runs.push(std::mem::take(&mut current));
                    }
                    current.push(p);
                }
                current.push(q);
            }
            None => {
                if !current.is_empty() {
                    runs.push(std::mem::take(&mut current));
                }
            }
        }
    }
    if !current.is_empty() {
        runs.push(current);
    }
    runs
}

/// The part of segment a→b inside the closed window, if any (Liang–Barsky).
fn clip_segment(
    a: (f64, f64),
    b: (f64, f64),
    x: &Range<f64>,
    y: &Range<f64>,
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - x.start),
        (dx, x.end - a.0),
        (-dy, a.1 - y.start),
        (dy, y.end - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    if t0 > t1 {
        return None;
    }
    let at = |t: f64| {
        if t == 0.0 {
            a
        } else if t == 1.0 {
            b
        } else {
            (a.0 + t * dx, a.1 + t * dy)
        }
    };
    Some((at(t0), at(t1)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn out_dir() -> PathBuf {
        plots_dir().unwrap()
    }

    /// The file parses as XML with an `<svg>` root; returns the text of its `<text>`
    /// elements.
    fn svg_texts(path: &Path) -> Vec<String> {
        let source = std::fs::read_to_string(path).unwrap();
        let doc = roxmltree::Document::parse(&source).unwrap();
        assert_eq!(doc.root_element().tag_name().name(), "svg");
        doc.descendants()
            .filter(|n| n.has_tag_name("text"))
            .filter_map(|n| n.text().map(str::to_owned))
            .collect()
    }

    /// Brute force: bucket of index i is the b with b·n/B ≤ i < (b+1)·n/B, found by
    /// search; each bucket's extreme values by a full scan.
    fn bucket_extremes(points: &[(f64, f64)], buckets: usize) -> Vec<[f64; 4]> {
        let n = points.len();
        let mut ext = vec![
            [
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY
            ];
            buckets
        ];
        for (i, p) in points.iter().enumerate() {
            let b = (0..buckets)
                .find(|&b| b * n / buckets <= i && i < (b + 1) * n / buckets)
                .unwrap();
            let e = &mut ext[b];
            *e = [e[0].min(p.1), e[1].max(p.1), e[2].min(p.0), e[3].max(p.0)];
        }
        ext
    }

    fn noisy(n: usize) -> Vec<(f64, f64)> {
        let mut x = 0.123_f64;
        (0..n)
            .map(|i| {
                x = 3.97 * x * (1.0 - x);
                let t = i as f64 * 1e-3;
                (t + 0.3e-3 * x, (7.0 * t).sin() + 0.2 * (x - 0.5))
            })
            .collect()
    }

    #[test]
    fn decimation_keeps_each_buckets_extremes() {
        for (n, max_points, extremes) in [
            (100_003, 2000, Extremes::Y),
            (100_003, 2000, Extremes::XY),
            (7_777, 100, Extremes::Y),
            (2_001, 2000, Extremes::XY),
        ] {
            let points = noisy(n);
            let kept = decimate(&points, max_points, extremes);
            assert!(kept.len() <= max_points, "{n} {max_points}: {}", kept.len());
            assert_eq!(kept.first(), points.first());
            assert_eq!(kept.last(), points.last());
            // A subsequence of the input, in order: find each kept point's index.
            let mut indices = Vec::with_capacity(kept.len());
            let mut from = 0;
            for p in &kept {
                let i = from + points[from..].iter().position(|q| q == p).unwrap();
                indices.push(i);
                from = i + 1;
            }
            let (per_bucket, columns) = match extremes {
                Extremes::Y => (2, 2),
                Extremes::XY => (4, 4),
            };
            let buckets = (max_points - 2) / per_bucket;
            for (b, e) in bucket_extremes(&points, buckets).iter().enumerate() {
                let (start, end) = (b * n / buckets, (b + 1) * n / buckets);
                let mine: Vec<_> = indices
                    .iter()
                    .filter(|i| (start..end).contains(*i))
                    .map(|&i| points[i])
                    .collect();
                let got = [
                    mine.iter().map(|p| p.1).fold(f64::INFINITY, f64::min),
                    mine.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max),
                    mine.iter().map(|p| p.0).fold(f64::INFINITY, f64::min),
                    mine.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max),
                ];
                assert_eq!(got[..columns], e[..columns], "bucket {b}");
            }
        }
        let short = noisy(50);
        assert_eq!(decimate(&short, 2000, Extremes::Y), short);
    }

    #[test]
    fn clipping_cuts_segments_at_the_window() {
        let (x, y) = (0.0..1.0, 0.0..1.0);
        // In, out across x = 1, back in across y = 1, out.
        let path = [
            (0.5, 0.5),
            (1.5, 0.5),
            (1.5, 1.5),
            (0.5, 1.5),
            (0.5, 0.5),
            (-1.0, 0.5),
        ];
        let runs = clip_polyline(&path, &x, &y);
        assert_eq!(
            runs,
            vec![
                vec![(0.5, 0.5), (1.0, 0.5)],
                vec![(0.5, 1.0), (0.5, 0.5), (0.0, 0.5)]
            ]
        );
        // Passing through the window without a vertex inside.
        let runs = clip_polyline(&[(-1.0, -1.0), (2.0, 2.0)], &x, &y);
        assert_eq!(runs, vec![vec![(0.0, 0.0), (1.0, 1.0)]]);
        assert!(clip_polyline(&[(2.0, 0.0), (2.0, 1.0)], &x, &y).is_empty());
    }

    #[test]
    fn equal_aspect_widens_the_narrow_axis() {
        let (x, y) = equal_aspect(0.0..10.0, 0.0..2.0, (400, 200));
        assert_eq!((x, y), (0.0..10.0, -1.5..3.5));
        let (x, y) = equal_aspect(0.0..1.0, 0.0..4.0, (300, 300));
        assert_eq!((x, y), (-1.5..2.5, 0.0..4.0));
    }

    #[test]
    fn pictures_are_svg_with_their_legends() {
        let dir = out_dir();
        // A square path with a response that cuts its corners, 20 000 points each.
        let n = 20_000;
        let corner = |t: f64| {
            let s = 4.0 * t;
            match s as usize {
                0 => (10.0 * s, 0.0),
                1 => (10.0, 10.0 * (s - 1.0)),
                2 => (10.0 * (3.0 - s), 10.0),
                _ => (0.0, 10.0 * (4.0 - s)),
            }
        };
        let reference: Vec<_> = (0..n).map(|i| corner(i as f64 / n as f64)).collect();
        let response: Vec<_> = reference
            .iter()
            .zip(
                reference
                    .iter()
                    .skip(40)
                    .chain(std::iter::repeat(&(0.0, 0.0))),
            )
            .map(|(a, b)| (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1)))
            .collect();
        let series = [
            Series::new("reference", &reference, 0),
            Series::new("response (DOB+PD)", &response, 1),
        ];
        let xy = dir.join("xy_zoom.svg");
        xy_with_zoom(
            &xy,
            "square <test>",
            &series,
            Some(ZoomBox::around(10.0, 10.0, 0.5)),
        )
        .unwrap();
        let texts = svg_texts(&xy);
        for label in [
            "reference",
            "response (DOB+PD)",
            "square <test>",
            "zoom",
            "x (mm)",
        ] {
            assert!(
                texts.iter().any(|t| t.trim() == label),
                "{label} not in {texts:?}"
            );
        }
        let size = std::fs::metadata(&xy).unwrap().len();
        assert!(size < 400_000, "{size} bytes");

        let error: Vec<_> = (0..n)
            .map(|i| (i as f64 * 1e-4, 3.0 * (i as f64 * 1e-3).sin()))
            .collect();
        let mut gappy = error.clone();
        gappy[500].1 = f64::NAN;
        let ts = dir.join("time_series.svg");
        let series = [
            Series::new("normal error", &error, 1),
            Series::new("with a gap", &gappy, 2),
        ];
        time_series(&ts, "contour error", "normal error (µm)", &series).unwrap();
        let texts = svg_texts(&ts);
        for label in [
            "normal error",
            "with a gap",
            "normal error (µm)",
            "time (s)",
        ] {
            assert!(
                texts.iter().any(|t| t.trim() == label),
                "{label} not in {texts:?}"
            );
        }

        let ap = dir.join("along_path.svg");
        let flat = [(0.0, 1e4), (1.0, 1e4), (2.0, 2e4), (3.0, 1e4)];
        along_path(
            &ap,
            "depth",
            "energy per length (J/m)",
            &[Series::new("e", &flat, 0)],
        )
        .unwrap();
        assert!(svg_texts(&ap).iter().any(|t| t.trim() == "arc length (mm)"));

        // Nothing finite to draw: an error, and no file.
        let empty = dir.join("empty.svg");
        let _ = std::fs::remove_file(&empty);
        let nan = [(f64::NAN, 1.0)];
        let nothing = [Series::new("empty", &[], 0), Series::new("nan", &nan, 1)];
        assert!(time_series(&empty, "t", "y", &nothing).is_err());
        assert!(!empty.exists());
    }
}
