//! The image-to-contour planner of T 3.1, ending in a job file.
//!
//! 1. T 3.1.1: the image in grey levels (its transparent parts as background:
//!    [`grey_on_background`]), smoothed by a Gaussian of [`PlanConfig::sigma_px`]
//!    (the noise model of T: white noise), edges by Canny ([`imageproc::edges::canny`],
//!    which smooths once more with σ = 1.4 px before its Sobel gradients), then gap
//!    closing by dilation followed by erosion with a square of radius
//!    [`PlanConfig::close_px`]: gaps of up to 2 r pixels close, and the two edges of a
//!    thin stroke (an open contour drawn as a line) merge into one band.
//! 2. T 3.1.2–3.1.3: the band thinned to a skeleton and walked into one ordered chain
//!    ([`crate::trace`]): closed contours start automatically at the rightmost point
//!    (top-most of those) and run counter-clockwise; open ones start at the free end
//!    nearest the user's point ([`PlanConfig::start_px`], in image pixels, x right and
//!    y down as image viewers show them).
//! 3. T 3.1.4: scaled into the workspace (below).
//! 4. T 3.2.2 / 3.1.5: a closed contour becomes an EFD of
//!    [`PlanConfig::harmonics`] harmonics (`kerf::trajectory::efd`, the firmware's own
//!    code), an open one (or a closed one on request) a list of at most
//!    [`OPEN_PATH_POINTS`] points for the firmware's open-path spline.
//!
//! # Scaling (T 3.1.4, eq. 2–4)
//!
//! One scale for both axes, so that the shape is not distorted (eq. 2 scales x by
//! O_W/I_W and y by O_H/I_H, which stretches a non-square image): the larger side of
//! the chain's bounding box becomes [`PlanConfig::width_mm`]. The default, 12 mm, is
//! the ±6 mm octagon the contouring slave's tests and benchmarks cut
//! (`kerf::machines::delta_slave`). The image's y axis points down
//! and the workspace's up, so y changes sign (without it the cut would be mirrored).
//! The offset puts the chain's centroid (its mean over arc length, which is the EFD's
//! (a0, c0)) at the origin: the firmware places the curve's centre at the job's centre.

use crate::job::Job;
pub use crate::kerf_offset::segment_distance;
use crate::kerf_offset::{offset_ring, signed_area2, KerfSide, OffsetError, OFFSET_SAMPLES};
use crate::trace::{self, Mask, TraceError};
use image::{DynamicImage, GrayImage};
use imageproc::distance_transform::Norm;
use kerf::machines::delta_slave::{CONTOUR_HARMONICS, OPEN_PATH_POINTS};
use kerf::trajectory::curve::Curve;
use kerf::trajectory::efd::Efd;
use kerf::trajectory::open_path::OpenPath;
use kerf::trajectory::ContourError;
use thiserror::Error;

/// What the job carries.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Format {
    /// Elliptic Fourier descriptors (closed contours only).
    Efd,
    /// A list of points (open contours; a closed one is closed by repeating its start).
    Points,
}

/// The planner's settings (module docs). [`Default`] gives the documented defaults.
#[derive(Clone, Debug, PartialEq)]
pub struct PlanConfig {
    /// σ of the Gaussian smoothing before Canny, pixels: 0 (none), or from
    /// [`SIGMA_MIN_PX`] to the image's larger side.
    pub sigma_px: f32,
    /// Canny's hysteresis thresholds on the Sobel gradient magnitude, (low, high) with
    /// 0 < low ≤ high ≤ [`CANNY_MAX`] (a black-to-white step).
    pub canny: (f32, f32),
    /// Radius of the square of the dilation and erosion, pixels: gaps of up to twice
    /// this close, and the two edges of a stroke up to about 2 r − 2 pixels wide merge.
    pub close_px: u8,
    /// Dangling branches shorter than this are removed from open contours, pixels.
    pub prune_px: usize,
    /// The larger side of the contour in the workspace, mm.
    pub width_mm: f64,
    /// EFD harmonics (1..=30, the firmware's capacity).
    pub harmonics: usize,
    /// Start of an open contour, image pixels (x right, y down); `None`: a closed
    /// contour with the automatic start.
    pub start_px: Option<[f64; 2]>,
    /// The job's payload; `None`: EFD for closed contours, points for open ones.
    pub format: Option<Format>,
    /// Which closed contour the job cuts, 0-based, largest first (a job carries one).
    pub contour: usize,
    /// Width of the cut, mm: closed contours are offset by half of it to the scrap's
    /// side ([`crate::kerf_offset`]); 0 for none.
    pub kerf_mm: f64,
    /// Which side of the drawn line is scrap (a single contour is an outline; with
    /// every contour, holes take the other side).
    pub kerf_side: KerfSide,
    /// Grey level at which the image is cut into ink and paper before its edges are
    /// sought (darker pixels ink, the rest paper): a photograph's shading and a faint
    /// drawing's low contrast become one clean step. `None`: the grey levels as they
    /// are. (Which side is ink does not matter: an edge is the same either way.)
    pub threshold: Option<u8>,
    /// Length of a straight lead-in from the scrap's side to each closed contour's
    /// start, mm (a part of its own, cut just before the contour, so the beam comes
    /// on away from the part); 0 for none.
    pub lead_in_mm: f64,
}

impl Default for PlanConfig {
    /// σ 1 px, Canny (40, 100), closing radius 3 px, spurs under 10 px, 12 mm wide, 30
    /// harmonics, automatic start, EFD or points by the contour, the largest contour.
    fn default() -> Self {
        Self {
            sigma_px: 1.0,
            canny: (40.0, 100.0),
            close_px: 3,
            prune_px: 10,
            width_mm: 12.0,
            harmonics: CONTOUR_HARMONICS,
            start_px: None,
            format: None,
            contour: 0,
            kerf_mm: 0.0,
            kerf_side: KerfSide::Outside,
            lead_in_mm: 0.0,
            threshold: None,
        }
    }
}

/// Why no job was planned.
#[derive(Debug, Error)]
pub enum PlanError {
    /// A setting is out of range (names it).
    #[error("bad setting: {0}")]
    Config(&'static str),
    /// The start of an open contour lies outside the image.
    #[error("--start {x},{y} lies outside the image ({w} × {h} pixels, x from the left, y from the top)")]
    Start {
        /// The start asked for, pixels.
        x: f64,
        /// The start asked for, pixels.
        y: f64,
        /// The image's width, pixels.
        w: f64,
        /// The image's height, pixels.
        h: f64,
    },
    /// The image could not be read or decoded.
    #[error("cannot read the image: {}", image_words(.0))]
    Image(#[from] image::ImageError),
    /// No chain could be traced.
    #[error("{0}")]
    Trace(#[from] TraceError),
    /// The chain is too short or has no extent.
    #[error("the traced contour is too small ({0} points)")]
    TooSmall(usize),
    /// EFD asked for an open contour.
    #[error("an open contour cannot be an EFD job (use --format points)")]
    OpenAsEfd,
    /// The firmware's EFD code refused the contour.
    #[error("the firmware refuses the EFD: {}", contour_words(.0))]
    Efd(ContourError),
    /// The firmware's open-path code refused the points.
    #[error("the firmware refuses the path: {}", contour_words(.0))]
    Path(ContourError),
    /// A laser program with no move while the beam is on.
    #[error("the program cuts nothing: no feed move with the beam on (M3 or M4 with S above 0)")]
    NoCut,
    /// The kerf offset cannot be taken.
    #[error("{0}")]
    Offset(#[from] OffsetError),
    /// Every closed contour is smaller than the size asked.
    #[error("no closed contour is {min_mm} mm across or more (the largest is {largest_mm:.2} mm): give a smaller --min-size-mm")]
    NothingLargeEnough {
        /// The size asked, mm.
        min_mm: f64,
        /// The largest contour's size, mm.
        largest_mm: f64,
    },
}

/// Why an image could not be read, in words.
fn image_words(e: &image::ImageError) -> String {
    match e {
        image::ImageError::IoError(io) => crate::output::io_words(io),
        image::ImageError::Unsupported(_) => {
            format!("{e} (the planner reads PNG and JPEG)")
        }
        other => other.to_string(),
    }
}

/// The firmware's refusal of a planned curve, in words; the job stores metres as
/// f32, so a contour scaled too large or too small is refused here.
fn contour_words(e: &ContourError) -> String {
    match e {
        ContourError::Config(c) => {
            format!("{c} (is --width-mm too large or too small for f32 metres?)")
        }
        ContourError::NotFinitePoint(i) => {
            format!("point {i} is not a number in f32 metres (is --width-mm too large?)")
        }
        ContourError::TooFewPoints => {
            "fewer than 3 distinct points (is --width-mm too small?)".into()
        }
        ContourError::RepeatedPoint(i) => {
            format!("point {i} falls on the one before it (is --width-mm too small?)")
        }
        ContourError::ZeroLength => "the contour has no length".into(),
        ContourError::Collinear => {
            "every point lies on one line: a stroke, not a contour to cut round".into()
        }
        ContourError::FarFromContour | ContourError::LostContour => {
            "the contour cannot be followed (it nearly doubles back on itself)".into()
        }
        ContourError::TooManyHarmonics | ContourError::Capacity => {
            "the contour needs more terms or points than a job holds (try --harmonics lower)".into()
        }
        ContourError::StepLongerThanContour => {
            "the contour is shorter than one control period's step (is --width-mm too small?)"
                .into()
        }
        ContourError::SpeedAboveCurvatureLimit { max_speed_m_s } => format!(
            "the contour bends too tightly for the speed (at most {:.1} mm/s there)",
            max_speed_m_s * 1e3
        ),
    }
}

/// The fitted curve of a plan.
#[derive(Clone, Debug)]
pub enum Fit {
    /// The EFD of a closed contour, m.
    Efd(Box<Efd<f64, CONTOUR_HARMONICS>>),
    /// The points of a path and the firmware's spline through them, m.
    Path {
        /// The points, m.
        points_m: Vec<[f64; 2]>,
        /// The spline through them.
        spline: Box<OpenPath<f64, OPEN_PATH_POINTS>>,
    },
}

impl Fit {
    /// `n` points along the curve, mm (a closed curve's first point not repeated).
    pub fn samples_mm(&self, n: usize) -> Vec<[f64; 2]> {
        let n = n.max(2);
        let (span, closed, centre) = match self {
            Fit::Efd(e) => (e.span(), true, e.centre()),
            Fit::Path { spline, .. } => (spline.span(), false, spline.centre()),
        };
        let steps = if closed { n } else { n - 1 };
        (0..n)
            .map(|i| {
                let theta = span * i as f64 / steps as f64;
                let p = match self {
                    Fit::Efd(e) => e.evaluate(theta).position,
                    Fit::Path { spline, .. } => spline.evaluate(theta).position,
                };
                [(p.x + centre.x) * 1e3, (p.y + centre.y) * 1e3]
            })
            .collect()
    }
}

/// A planned contour.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Whether the contour is closed.
    pub closed: bool,
    /// Closed contours the image has (the job cuts one: [`PlanConfig::contour`]); 1
    /// for an open contour.
    pub contours: usize,
    /// The traced chain in image pixels (x right, y down), in cutting order.
    pub chain_px: Vec<[f64; 2]>,
    /// Workspace mm per image pixel.
    pub mm_per_px: f64,
    /// The chain's centroid in the image, pixels: the workspace origin.
    pub centroid_px: [f64; 2],
    /// The chain in the workspace, mm.
    pub contour_mm: Vec<[f64; 2]>,
    /// The curve the job carries.
    pub fit: Fit,
    /// The job.
    pub job: Job,
    /// The lead-in cut just before it ([`PlanConfig::lead_in_mm`]).
    pub lead_in: Option<Job>,
}

impl Plan {
    /// The job file: the lead-in's, when there is one, then the contour's.
    pub fn to_bytes(&self) -> Result<Vec<u8>, crate::job::JobFileError> {
        let mut out = match &self.lead_in {
            Some(job) => job.to_bytes()?,
            None => Vec::new(),
        };
        out.extend(self.job.to_bytes()?);
        Ok(out)
    }

    /// An image pixel position in the workspace, mm (module docs).
    pub fn to_mm(&self, p: [f64; 2]) -> [f64; 2] {
        to_mm(p, self.centroid_px, self.mm_per_px)
    }

    /// The contour's length in the workspace, mm (closing segment included when
    /// closed).
    pub fn length_mm(&self) -> f64 {
        polyline_length(&self.contour_mm, self.closed)
    }
}

pub(crate) fn to_mm(p: [f64; 2], centroid: [f64; 2], s: f64) -> [f64; 2] {
    // T eq. 2–4 print β = x_F·(O_W/I_W) + O_W/2: that adds the first point's own
    // (scaled) coordinate instead of subtracting it, so x_O = s(x_I + x_F) + O_W/2
    // lies in [s·x_F + O_W/2, s·x_F + 3·O_W/2] for x_I in [0, I_W]: beside a workspace
    // centred on the origin, not on it. Centring needs β = −s·x_c; with the centroid
    // as x_c the curve's centre is the origin.
    [s * (p[0] - centroid[0]), -s * (p[1] - centroid[1])]
}

/// The box around `points`: (lowest, highest) per axis; infinite both ways when there
/// are none.
pub fn bounds<'a>(points: impl IntoIterator<Item = &'a [f64; 2]>) -> ([f64; 2], [f64; 2]) {
    points.into_iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    )
}

/// Length of a polyline, closed or not.
pub fn polyline_length(points: &[[f64; 2]], closed: bool) -> f64 {
    let open: f64 = points
        .windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum();
    let closing = match (closed, points.first(), points.last()) {
        (true, Some(a), Some(b)) => (a[0] - b[0]).hypot(a[1] - b[1]),
        _ => 0.0,
    };
    open + closing
}

/// Mean of a polyline over its arc length (the centre of its segments weighted by
/// their lengths); the plain mean of the points when it has no length.
fn centroid(points: &[[f64; 2]], closed: bool) -> [f64; 2] {
    let n = points.len();
    let segments = if closed { n } else { n.saturating_sub(1) };
    let (mut sx, mut sy, mut sl) = (0.0, 0.0, 0.0);
    for i in 0..segments {
        let (a, b) = (points[i], points[(i + 1) % n]);
        let l = (b[0] - a[0]).hypot(b[1] - a[1]);
        sx += l * (a[0] + b[0]) / 2.0;
        sy += l * (a[1] + b[1]) / 2.0;
        sl += l;
    }
    if sl > 0.0 {
        [sx / sl, sy / sl]
    } else {
        let m = n.max(1) as f64;
        let s = points
            .iter()
            .fold([0.0, 0.0], |s, p| [s[0] + p[0], s[1] + p[1]]);
        [s[0] / m, s[1] / m]
    }
}

/// The stages of T 3.1.1 on a grey image: the binary edge map after closing.
///
/// Errors: settings out of range (σ wider than the image included).
pub fn edges(gray: &GrayImage, config: &PlanConfig) -> Result<GrayImage, PlanError> {
    check(config)?;
    // The kernel reaches 2σ each way: wider than the image, it blurs it flat (and
    // a huge σ would allocate a kernel of 4σ + 1 weights).
    if f64::from(config.sigma_px) > f64::from(gray.width().max(gray.height())) {
        return Err(PlanError::Config(
            "sigma must be at most the image's larger side, in pixels",
        ));
    }
    let binary;
    let gray = match config.threshold {
        Some(t) => {
            binary = GrayImage::from_fn(gray.width(), gray.height(), |x, y| {
                image::Luma([if gray.get_pixel(x, y)[0] < t { 0 } else { 255 }])
            });
            &binary
        }
        None => gray,
    };
    let smoothed = if config.sigma_px > 0.0 {
        imageproc::filter::gaussian_blur_f32(gray, config.sigma_px)
    } else {
        gray.clone()
    };
    let edges = imageproc::edges::canny(&smoothed, config.canny.0, config.canny.1);
    let dilated = imageproc::morphology::dilate(&edges, Norm::LInf, config.close_px);
    Ok(imageproc::morphology::erode(
        &dilated,
        Norm::LInf,
        config.close_px,
    ))
}

/// The one-pixel skeleton of an edge map.
pub fn skeleton(edges: &GrayImage) -> Mask {
    band(edges).thinned()
}

pub(crate) fn band(edges: &GrayImage) -> Mask {
    Mask::from_fn(edges.width(), edges.height(), |x, y| {
        edges.get_pixel(x, y)[0] > 0
    })
}

/// The smallest σ that smooths: below it a neighbour's weight in the Gaussian kernel,
/// exp(−1/(2σ²)), is under f32's resolution (e^−12.5 ≈ 4e−6 at 0.2 px, e^−50 at
/// 0.1 px), and for σ² below f32's range the kernel is NaN.
pub const SIGMA_MIN_PX: f32 = 0.2;

/// The strongest Sobel magnitude, a black-to-white step: 2·√5·255 (imageproc's Canny).
pub const CANNY_MAX: f32 = 1140.4;

pub(crate) fn check(config: &PlanConfig) -> Result<(), PlanError> {
    let sigma = config.sigma_px;
    if !(sigma.is_finite() && (sigma == 0.0 || sigma >= SIGMA_MIN_PX)) {
        return Err(PlanError::Config(
            "sigma must be 0 (no smoothing) or at least 0.2 px (a smaller Gaussian does not smooth)",
        ));
    }
    let (lo, hi) = config.canny;
    // LOW = 0 makes every pixel an edge, the image's border too (where imageproc's
    // hysteresis would step outside the image).
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
        return Err(PlanError::Config(
            "canny thresholds must be 0 < LOW <= HIGH",
        ));
    }
    if hi > CANNY_MAX {
        return Err(PlanError::Config(
            "canny HIGH above 1140 finds no edges (a black-to-white step is 1140)",
        ));
    }
    if !(config.width_mm.is_finite() && config.width_mm > 0.0) {
        return Err(PlanError::Config("width must be finite and positive"));
    }
    if !(1..=CONTOUR_HARMONICS).contains(&config.harmonics) {
        return Err(PlanError::Config(
            "harmonics must be 1..=30 (the firmware's capacity)",
        ));
    }
    if config
        .start_px
        .is_some_and(|s| !s.iter().all(|v| v.is_finite()))
    {
        return Err(PlanError::Config("start must be finite"));
    }
    if !(config.kerf_mm.is_finite()
        && config.kerf_mm >= 0.0
        && config.kerf_mm < config.width_mm / 2.0)
    {
        return Err(PlanError::Config(
            "the kerf must be finite, 0 or more, and narrower than half the width",
        ));
    }
    if config.kerf_mm > 0.0 && config.start_px.is_some() {
        return Err(PlanError::Config(
            "the kerf offset is for closed contours (without --start)",
        ));
    }
    if !(config.lead_in_mm.is_finite()
        && config.lead_in_mm >= 0.0
        && config.lead_in_mm <= config.width_mm)
    {
        return Err(PlanError::Config(
            "the lead-in must be finite, 0 or more, and no longer than the width",
        ));
    }
    if config.threshold == Some(0) {
        return Err(PlanError::Config(
            "the threshold must be 1 to 255 (at 0 no pixel is ink)",
        ));
    }
    if config.lead_in_mm > 0.0 && config.start_px.is_some() {
        return Err(PlanError::Config(
            "the lead-in is for closed contours (without --start)",
        ));
    }
    Ok(())
}

/// The lead-in of `config` to the start of the closed curve `fit` inside `depth`
/// others: a straight path of [`PlanConfig::lead_in_mm`] along the curve's normal at
/// its start, from the scrap's side to the start (`None` without a lead-in).
pub(crate) fn lead_in(
    fit: &Fit,
    config: &PlanConfig,
    depth: usize,
) -> Result<Option<Job>, PlanError> {
    if config.lead_in_mm <= 0.0 {
        return Ok(None);
    }
    let samples = fit.samples_mm(OFFSET_SAMPLES);
    let (Some(&start), Some(&next), Some(&before)) =
        (samples.first(), samples.get(1), samples.last())
    else {
        return Err(PlanError::TooSmall(samples.len()));
    };
    let (tx, ty) = (next[0] - before[0], next[1] - before[1]);
    let length = tx.hypot(ty);
    // The outward normal of a counter-clockwise curve is its tangent turned clockwise;
    // towards the scrap, as the kerf goes.
    let side =
        signed_area2(&samples).signum() * kerf_sign(config, depth) * config.lead_in_mm / length;
    let from = [start[0] + ty * side, start[1] - tx * side];
    let middle = [(from[0] + start[0]) / 2.0, (from[1] + start[1]) / 2.0];
    Ok(Some(path_job(&[from, middle, start], false)?.1))
}

/// The fit `fit` of a closed contour offset by `distance_mm` (away from its inside
/// when positive; [`crate::kerf_offset`]) and fitted again as the same kind of job.
pub(crate) fn offset_fit(
    fit: &Fit,
    distance_mm: f64,
    harmonics: usize,
) -> Result<(Fit, Job), PlanError> {
    let ring = offset_ring(&fit.samples_mm(OFFSET_SAMPLES), distance_mm)?;
    match fit {
        Fit::Efd(_) => efd_job(&ring, harmonics),
        Fit::Path { .. } => path_job(&ring, true),
    }
}

/// 1 where the scrap lies outside a contour inside `depth` others, −1 where inside
/// ([`KerfSide`]: the side alternates from an outline to its holes).
pub(crate) fn kerf_sign(config: &PlanConfig, depth: usize) -> f64 {
    if (config.kerf_side == KerfSide::Outside) == (depth % 2 == 0) {
        1.0
    } else {
        -1.0
    }
}

/// Half the kerf of `config`, signed for a contour inside `depth` others: to the
/// scrap's side.
pub(crate) fn kerf_distance_mm(config: &PlanConfig, depth: usize) -> f64 {
    kerf_sign(config, depth) * config.kerf_mm / 2.0
}

/// Plans the job of an image file (module docs); `stage` is told each step's name.
pub fn plan_file(
    path: &std::path::Path,
    config: &PlanConfig,
    stage: &mut dyn FnMut(&str),
) -> Result<(GrayImage, Plan), PlanError> {
    check(config)?;
    stage("reading the image");
    let gray = read_grey(path)?;
    let plan = plan_image(&gray, config, stage)?;
    Ok((gray, plan))
}

/// An image file (PNG or JPEG) in grey levels, its transparent parts as background
/// ([`grey_on_background`]).
pub fn read_grey(path: &std::path::Path) -> Result<GrayImage, PlanError> {
    let image: DynamicImage = image::ImageReader::open(path)
        .map_err(image::ImageError::IoError)?
        .with_guessed_format()
        .map_err(image::ImageError::IoError)?
        .decode()?;
    Ok(grey_on_background(&image))
}

/// The image in grey levels with its transparent parts as background: a pixel of
/// opacity α and grey level g becomes α g + (1 − α) b, where the background b is
/// white, or black when the opaque pixels are mostly light (a white logo on a
/// transparent sheet). Without it a transparent background, stored as transparent
/// black, reads as black, and a dark shape on it has no edge to trace.
pub fn grey_on_background(image: &DynamicImage) -> GrayImage {
    let la = image.to_luma_alpha8();
    let (mut weighted, mut opacity) = (0.0f64, 0.0f64);
    for p in la.pixels() {
        let [g, a] = p.0;
        weighted += f64::from(g) * f64::from(a);
        opacity += f64::from(a);
    }
    let light_shapes = opacity > 0.0 && weighted / opacity > 127.5;
    let background = if light_shapes { 0u32 } else { 255 };
    GrayImage::from_fn(la.width(), la.height(), |x, y| {
        let [g, a] = la.get_pixel(x, y).0;
        let (g, a) = (u32::from(g), u32::from(a));
        // Rounded to the nearest level: (α g + (255 − α) b + 127) / 255 ≤ 255.
        image::Luma([((a * g + (255 - a) * background + 127) / 255) as u8])
    })
}

/// Plans the job of a grey image (module docs); `stage` is told each step's name.
pub fn plan_image(
    gray: &GrayImage,
    config: &PlanConfig,
    stage: &mut dyn FnMut(&str),
) -> Result<Plan, PlanError> {
    check(config)?;
    let (w, h) = (f64::from(gray.width()), f64::from(gray.height()));
    if let Some([x, y]) = config
        .start_px
        .filter(|&[x, y]| !(0.0..=w).contains(&x) || !(0.0..=h).contains(&y))
    {
        return Err(PlanError::Start { x, y, w, h });
    }
    stage("smoothing, edges and gap closing");
    let closed_edges = edges(gray, config)?;
    stage("thinning");
    let band = band(&closed_edges);
    let skel = band.thinned();
    stage("tracing the contour");
    let (closed, chain_px, contours) = match config.start_px {
        None => {
            let (chain, found) = trace::closed_chain(&skel, config.contour)?;
            (true, chain, found)
        }
        Some(s) => (
            false,
            trace::open_chain(&skel, &band, s, config.prune_px)?,
            1,
        ),
    };
    let (min, max) = bounds(&chain_px);
    let extent_px = (max[0] - min[0]).max(max[1] - min[1]);
    if chain_px.len() < 3 || extent_px.is_nan() || extent_px <= 0.0 {
        return Err(PlanError::TooSmall(chain_px.len()));
    }
    stage("scaling and fitting");
    let mm_per_px = config.width_mm / extent_px;
    let centroid_px = centroid(&chain_px, closed);
    let contour_mm: Vec<[f64; 2]> = chain_px
        .iter()
        .map(|&p| to_mm(p, centroid_px, mm_per_px))
        .collect();
    let format = config
        .format
        .unwrap_or(if closed { Format::Efd } else { Format::Points });
    let (mut fit, mut job) = match format {
        Format::Efd if !closed => return Err(PlanError::OpenAsEfd),
        Format::Efd => efd_job(&contour_mm, config.harmonics)?,
        Format::Points => path_job(&contour_mm, closed)?,
    };
    if config.kerf_mm > 0.0 {
        (fit, job) = offset_fit(&fit, kerf_distance_mm(config, 0), config.harmonics)?;
    }
    let lead_in = lead_in(&fit, config, 0)?;
    Ok(Plan {
        closed,
        contours,
        chain_px,
        mm_per_px,
        centroid_px,
        contour_mm,
        fit,
        job,
        lead_in,
    })
}

pub(crate) fn efd_job(contour_mm: &[[f64; 2]], harmonics: usize) -> Result<(Fit, Job), PlanError> {
    let points_m: Vec<[f64; 2]> = contour_mm
        .iter()
        .map(|p| [p[0] * 1e-3, p[1] * 1e-3])
        .collect();
    let efd = Efd::<f64, CONTOUR_HARMONICS>::from_polygon(&points_m, harmonics)
        .map_err(PlanError::Efd)?;
    let centre = efd.centre();
    let centre_m = [centre.x as f32, centre.y as f32];
    let coefficients: Vec<[f32; 4]> = efd
        .coefficients()
        .iter()
        .take(efd.harmonics())
        .map(|c| c.map(|v| v as f32))
        .collect();
    // What the firmware will do with the file: the f32 curve from these numbers.
    let wide: Vec<[f64; 4]> = coefficients.iter().map(|c| c.map(f64::from)).collect();
    Efd::<f32, CONTOUR_HARMONICS>::from_coefficients(centre_m.map(f64::from), &wide)
        .map_err(PlanError::Efd)?;
    let job = Job::Efd {
        centre_m,
        coefficients,
    };
    Ok((Fit::Efd(Box::new(efd)), job))
}

pub(crate) fn path_job(contour_mm: &[[f64; 2]], closed: bool) -> Result<(Fit, Job), PlanError> {
    let mut line: Vec<[f64; 2]> = contour_mm
        .iter()
        .map(|p| [p[0] * 1e-3, p[1] * 1e-3])
        .collect();
    if closed {
        if let Some(&first) = line.first() {
            line.push(first);
        }
    }
    let (points_m, spline) = spline_points(&line, OPEN_PATH_POINTS)?;
    OpenPath::<f32, OPEN_PATH_POINTS>::from_f64(&spline).map_err(PlanError::Path)?;
    let job = Job::Path {
        points_m: points_m.iter().map(|p| p.map(|v| v as f32)).collect(),
    };
    Ok((
        Fit::Path {
            points_m,
            spline: Box::new(spline),
        },
        job,
    ))
}

/// At most `n` (≥ 3) points of `line` (m) for the firmware's open-path spline, its
/// ends kept, rounded to f32 as the file stores them, and the spline through them.
///
/// Greedy: start from the ends and the point farthest from the chord between them
/// (Ramer–Douglas–Peucker's first step), then repeatedly add the point of `line`
/// farthest from the spline through the points chosen so far — a point's place on
/// the spline is its share of the arc length between its two chosen neighbours —
/// until `n` points or no distance left. Choosing by the polyline alone (plain RDP)
/// leaves long straight runs as one knot interval, across which a natural cubic
/// spline bulges by millimetres beside the short intervals of a curve.
fn spline_points(
    line: &[[f64; 2]],
    n: usize,
) -> Result<(Vec<[f64; 2]>, OpenPath<f64, OPEN_PATH_POINTS>), PlanError> {
    let round = |p: [f64; 2]| p.map(|v| f64::from(v as f32));
    let mut line: Vec<[f64; 2]> = line.iter().map(|&p| round(p)).collect();
    line.dedup();
    let last = line.len().saturating_sub(1);
    let mut keep = vec![0, last];
    if let Some((i, _)) = (1..last)
        .map(|i| (i, segment_distance(line[i], line[0], line[last])))
        .max_by(|a, b| a.1.total_cmp(&b.1))
    {
        keep.insert(1, i);
    }
    // Arc length along the line.
    let mut s = vec![0.0; line.len()];
    for i in 1..line.len() {
        s[i] = s[i - 1] + (line[i][0] - line[i - 1][0]).hypot(line[i][1] - line[i - 1][1]);
    }
    loop {
        let points: Vec<[f64; 2]> = keep.iter().map(|&i| line[i]).collect();
        let spline =
            OpenPath::<f64, OPEN_PATH_POINTS>::from_points(&points).map_err(PlanError::Path)?;
        if keep.len() >= n.clamp(3, OPEN_PATH_POINTS) {
            return Ok((points, spline));
        }
        let centre = spline.centre();
        let mut u0 = 0.0;
        let mut worst: Option<(usize, f64)> = None;
        for w in keep.windows(2) {
            let (a, b) = (w[0], w[1]);
            let chord = (line[b][0] - line[a][0]).hypot(line[b][1] - line[a][1]);
            let arc = s[b] - s[a];
            for j in a + 1..b {
                let u = u0 + chord * (s[j] - s[a]) / arc.max(f64::MIN_POSITIVE);
                let p = spline.evaluate(u).position;
                let d = (p.x + centre.x - line[j][0]).hypot(p.y + centre.y - line[j][1]);
                if worst.is_none_or(|(_, wd)| d > wd) {
                    worst = Some((j, d));
                }
            }
            u0 += chord;
        }
        match worst {
            Some((j, d)) if d > 0.0 => {
                let at = keep.partition_point(|&k| k < j);
                keep.insert(at, j);
            }
            _ => return Ok((points, spline)),
        }
    }
}

/// Largest distance from a point of `a` to the polyline `b` (closed or not): how far
/// `a` strays from `b`, by brute force over every point and segment.
pub fn deviation(a: &[[f64; 2]], b: &[[f64; 2]], b_closed: bool) -> f64 {
    let n = b.len();
    if n == 0 {
        return f64::INFINITY;
    }
    let segments = if b_closed { n } else { n - 1 };
    a.iter()
        .map(|&p| {
            (0..segments.max(1))
                .map(|i| segment_distance(p, b[i % n], b[(i + 1) % n]))
                .fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max)
}
