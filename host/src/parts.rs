//! `kerf plan --all`: every closed contour of an image as the parts of one job, in
//! the order a laser cutter cuts them.
//!
//! The contours are traced as [`crate::plan`] traces one ([`trace::closed_chains`]),
//! and placed in one frame: one scale for all (the larger side of their common
//! bounding box becomes [`PlanConfig::width_mm`]) and the box's centre at the origin,
//! so each part keeps its place in the picture. Contours smaller than the size the
//! operator gives (the larger side of their own box, in the workspace) are left out
//! and counted. The order: a contour inside another (a hole, a letter's counter, a
//! shape on a sheet) is cut before the one around it, so that nothing is cut free
//! before what lies inside it is cut; among the contours whose insides are done, the
//! one whose start is nearest the last start comes next (from the workspace's
//! centre). Each part is fitted as a single plan is (EFD, or points on request; the
//! kerf offset to the scrap's side, which alternates from an outline to its holes) and
//! the parts' job files are written back to back: one file, read part by part
//! ([`crate::job::split`]).

use crate::job::Job;
use crate::plan::{self, efd_job, path_job, to_mm, Format, Plan, PlanConfig, PlanError};
use crate::trace;
use image::GrayImage;

/// The parts of an image, in cutting order.
#[derive(Clone, Debug)]
pub struct PlanSet {
    /// Each part as a plan of its own, all in one frame (the same scale and origin).
    pub parts: Vec<Plan>,
    /// Closed contours the image has.
    pub found: usize,
    /// Of them, left out as smaller than the size asked.
    pub too_small: usize,
}

impl PlanSet {
    /// The job file: the parts' files back to back (each lead-in before its part).
    pub fn to_bytes(&self) -> Result<Vec<u8>, crate::job::JobFileError> {
        let mut out = Vec::new();
        for part in &self.parts {
            out.extend(part.to_bytes()?);
        }
        Ok(out)
    }
}

/// Whether `p` lies inside the polygon `ring` (even-odd rule: a ray to +x crosses its
/// edges an odd number of times).
pub fn inside(p: [f64; 2], ring: &[[f64; 2]]) -> bool {
    let n = ring.len();
    let mut crossings = false;
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if x > p[0] {
                crossings = !crossings;
            }
        }
    }
    crossings
}

/// Twice the area enclosed by `ring`, unsigned (the shoelace formula).
fn area2(ring: &[[f64; 2]]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f64>()
        .abs()
}

/// For each of `rings`, the rings that enclose it (larger, and containing its start).
pub(crate) fn enclosing(rings: &[Vec<[f64; 2]>]) -> Vec<Vec<usize>> {
    let n = rings.len();
    (0..n)
        .map(|a| {
            (0..n)
                .filter(|&b| {
                    b != a
                        && area2(&rings[b]) > area2(&rings[a])
                        && rings[a].first().is_some_and(|&p| inside(p, &rings[b]))
                })
                .collect()
        })
        .collect()
}

/// The cutting order of closed `rings` (module docs): indices into `rings`.
pub fn cutting_order(rings: &[Vec<[f64; 2]>]) -> Vec<usize> {
    let n = rings.len();
    let around = enclosing(rings);
    let mut done = vec![false; n];
    let mut order = Vec::with_capacity(n);
    let mut at = [0.0, 0.0];
    while order.len() < n {
        // A ring may be cut once every ring it encloses is.
        let ready = |b: usize| (0..n).all(|a| done[a] || !around[a].contains(&b));
        let distance = |r: usize| {
            rings[r]
                .first()
                .map_or(f64::INFINITY, |p| (p[0] - at[0]).hypot(p[1] - at[1]))
        };
        let Some(next) = (0..n)
            .filter(|&r| !done[r] && ready(r))
            .min_by(|&a, &b| distance(a).total_cmp(&distance(b)))
        else {
            // Enclosure is a strict order by area: some ring is always ready.
            break;
        };
        done[next] = true;
        at = rings[next].first().copied().unwrap_or(at);
        order.push(next);
    }
    order
}

/// Plans every closed contour of `gray` at least `min_size_mm` across as the parts of
/// one job (module docs); `stage` is told each step's name.
///
/// Errors: the settings, no closed contour, none as large as `min_size_mm` (the
/// message names the largest), a part the firmware's code refuses.
pub fn plan_all(
    gray: &GrayImage,
    config: &PlanConfig,
    min_size_mm: f64,
    stage: &mut dyn FnMut(&str),
) -> Result<PlanSet, PlanError> {
    plan::check(config)?;
    if !(min_size_mm.is_finite() && min_size_mm >= 0.0) {
        return Err(PlanError::Config(
            "the smallest size must be finite and not negative",
        ));
    }
    stage("smoothing, edges and gap closing");
    let closed_edges = plan::edges(gray, config)?;
    stage("thinning");
    let skel = plan::band(&closed_edges).thinned();
    stage("tracing the contours");
    let chains = trace::closed_chains(&skel)?;
    let found = chains.len();
    let (lo, hi) = plan::bounds(chains.iter().flatten());
    let extent_px = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    if extent_px.is_nan() || extent_px <= 0.0 {
        return Err(PlanError::TooSmall(chains.first().map_or(0, Vec::len)));
    }
    stage("scaling, ordering and fitting");
    let mm_per_px = config.width_mm / extent_px;
    let origin_px = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let size_mm = |c: &[[f64; 2]]| {
        let (lo, hi) = plan::bounds(c);
        (hi[0] - lo[0]).max(hi[1] - lo[1]) * mm_per_px
    };
    let largest_mm = chains.iter().map(|c| size_mm(c)).fold(0.0, f64::max);
    let kept: Vec<Vec<[f64; 2]>> = chains
        .into_iter()
        .filter(|c| c.len() >= 3 && size_mm(c) >= min_size_mm)
        .collect();
    if kept.is_empty() {
        return Err(PlanError::NothingLargeEnough {
            min_mm: min_size_mm,
            largest_mm,
        });
    }
    let too_small = found - kept.len();
    let rings_mm: Vec<Vec<[f64; 2]>> = kept
        .iter()
        .map(|c| c.iter().map(|&p| to_mm(p, origin_px, mm_per_px)).collect())
        .collect();
    let mut parts = Vec::with_capacity(kept.len());
    let around = enclosing(&rings_mm);
    for index in cutting_order(&rings_mm) {
        let contour_mm = rings_mm[index].clone();
        let (mut fit, mut job): (_, Job) = match config.format.unwrap_or(Format::Efd) {
            Format::Efd => efd_job(&contour_mm, config.harmonics)?,
            Format::Points => path_job(&contour_mm, true)?,
        };
        let depth = around[index].len();
        if config.kerf_mm > 0.0 {
            let distance_mm = plan::kerf_distance_mm(config, depth);
            (fit, job) = plan::offset_fit(&fit, distance_mm, config.harmonics)?;
        }
        let lead_in = plan::lead_in(&fit, config, depth)?;
        parts.push(Plan {
            closed: true,
            contours: found,
            chain_px: kept[index].clone(),
            mm_per_px,
            centroid_px: origin_px,
            contour_mm,
            fit,
            job,
            lead_in,
        });
    }
    Ok(PlanSet {
        parts,
        found,
        too_small,
    })
}
