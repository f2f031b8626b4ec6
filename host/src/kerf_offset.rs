//! The kerf offset: the beam removes material on both sides of its path, so a part cut
//! along its drawn contour comes out smaller by half the kerf's width all round (and
//! its holes larger). Laser cutters therefore move the path off the drawn line by half
//! the kerf, to the side that is scrap: outside a part's outline and inside its holes
//! ([`KerfSide::Outside`], the default), or the other way when the part is the hole
//! (a window cut out of a sheet that is kept, [`KerfSide::Inside`]).
//!
//! The offset is taken of the fitted curve (smooth, sampled at [`OFFSET_SAMPLES`]
//! points): each point moves by the distance along the curve's normal there (the
//! central difference of its neighbours, turned a quarter outward by the ring's
//! orientation). Where the offset moves into a corner tighter than itself, the moved
//! points fold into a loop whose points lie nearer the contour than the offset; those
//! are dropped and the path goes straight from the last point before the loop to the
//! first after it (the trimmed offset: the corner comes out sharp, as the beam leaves
//! it), and the result is fitted again as the job's curve. A stretch dropped that is
//! not a corner's loop — where the points on either side are farther apart than the
//! kerf, because another stretch of the contour lies nearer than the offset (a gap or a
//! neck narrower than the kerf) — is refused with where: the path cannot pass there.

use thiserror::Error;

/// Points the fitted curve is sampled at for its offset.
pub const OFFSET_SAMPLES: usize = 2048;

/// Which side of the drawn line is scrap.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum KerfSide {
    /// Outside a part's outline and inside its holes: the part keeps its size.
    #[default]
    Outside,
    /// Inside an outline and outside its holes: the hole keeps its size.
    Inside,
}

/// Why a contour has no offset.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum OffsetError {
    /// Another stretch of the contour lies nearer the offset path than the offset.
    #[error(
        "the kerf offset of {offset_mm:.3} mm runs into the contour near ({x:.2}, {y:.2}) mm: a gap or neck there is narrower than the kerf (a smaller --kerf-mm)",
        x = at_mm[0],
        y = at_mm[1]
    )]
    Collision {
        /// The offset, mm.
        offset_mm: f64,
        /// Where, on the offset path (the last point kept before the stretch), mm.
        at_mm: [f64; 2],
    },
    /// Fewer than three points, or not a number.
    #[error("the contour has no offset: fewer than three points, or a number that is not finite")]
    Degenerate,
}

/// Distance from `p` to the segment `a`–`b`.
pub fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * d[0]).hypot(p[1] - a[1] - t * d[1])
}

/// Twice the signed area of `ring` (positive counter-clockwise).
pub(crate) fn signed_area2(ring: &[[f64; 2]]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

/// The closed `ring` (mm, either orientation, its first point not repeated) moved by
/// `distance_mm` along its normals: away from its inside when positive, into it when
/// negative (module docs).
///
/// Errors: a fold or a collision (module docs), a ring of fewer than three points or
/// with a number not finite.
pub fn offset_ring(ring: &[[f64; 2]], distance_mm: f64) -> Result<Vec<[f64; 2]>, OffsetError> {
    let n = ring.len();
    let area2 = signed_area2(ring);
    if n < 3 || !area2.is_finite() || area2 == 0.0 || !distance_mm.is_finite() {
        return Err(OffsetError::Degenerate);
    }
    // Counter-clockwise, the outward normal is the tangent turned clockwise.
    let outward = area2.signum();
    let offset: Vec<[f64; 2]> = (0..n)
        .map(|i| {
            let (a, b) = (ring[(i + n - 1) % n], ring[(i + 1) % n]);
            let (tx, ty) = (b[0] - a[0], b[1] - a[1]);
            let length = tx.hypot(ty);
            let scale = if length > 0.0 {
                outward * distance_mm / length
            } else {
                0.0
            };
            [ring[i][0] + ty * scale, ring[i][1] - tx * scale]
        })
        .collect();
    let magnitude = distance_mm.abs();
    // Each offset point is the offset from its own stretch of the contour; nearer
    // another, it is in a corner's loop or past a neck. The tolerance covers the chords
    // between samples (their sagitta is under a micrometre at these sample counts).
    let tolerance = 1e-3 * magnitude + 1e-6;
    let kept: Vec<bool> = offset
        .iter()
        .map(|q| {
            (0..n)
                .map(|k| segment_distance(*q, ring[k], ring[(k + 1) % n]))
                .fold(f64::INFINITY, f64::min)
                >= magnitude - tolerance
        })
        .collect();
    let Some(first) = kept.iter().position(|&k| k) else {
        return Err(OffsetError::Degenerate);
    };
    // Around from a kept point: each run of dropped points must be a corner's loop,
    // bridged by a step no longer than the kerf.
    let mut path = Vec::with_capacity(n);
    let mut last = first;
    for step in 1..=n {
        let i = (first + step) % n;
        if !kept[i] {
            continue;
        }
        if step - (last + n - first) % n > 1 {
            let (a, b) = (offset[last], offset[i]);
            if (b[0] - a[0]).hypot(b[1] - a[1]) > 2.0 * magnitude {
                return Err(OffsetError::Collision {
                    offset_mm: magnitude,
                    at_mm: a,
                });
            }
        }
        path.push(offset[i]);
        last = i;
    }
    if path.len() < 3 {
        return Err(OffsetError::Degenerate);
    }
    Ok(path)
}

/// Largest ratio of a mitred corner's distance from the drawn corner to the offset:
/// a corner sharper than 60° is rounded instead (a mitre's spike would run far out).
pub const MITRE_LIMIT: f64 = 2.0;

/// Largest angle between the points of a rounded corner, radians (15°: the arc's chords
/// stay within 0.9 % of the offset of it).
const ROUND_STEP_RAD: f64 = std::f64::consts::PI / 12.0;

/// The closed polygon `ring` (mm, either orientation, its first point not repeated)
/// moved by `distance_mm` off its edges, its corners kept sharp: away from its inside
/// when positive, into it when negative. Each point comes with the index of the corner
/// of `ring` it was made from.
///
/// Each edge moves along its normal and neighbouring edges meet where their moved lines
/// cross (the mitre). A corner that the moved path goes round (outside the turn) and
/// that is sharper than [`MITRE_LIMIT`] allows is rounded about the drawn corner at the
/// offset instead, so the beam never comes nearer the drawn line than the offset.
/// Where the moved lines of short edges cross beyond each other (a corner's loop), the
/// points nearer the drawn line than the offset are dropped.
///
/// Errors: a ring of fewer than three points, one of no area or a number not finite
/// (`Degenerate`); an edge of the result passing nearer the drawn line than the
/// offset (`Collision`: a gap or neck narrower than the kerf; a rounded corner's
/// chords may pass inside its arc by their sagitta, 0.9 % of the offset).
pub fn offset_polygon(
    ring: &[[f64; 2]],
    distance_mm: f64,
) -> Result<Vec<([f64; 2], usize)>, OffsetError> {
    let n = ring.len();
    let area2 = signed_area2(ring);
    if n < 3 || !area2.is_finite() || area2 == 0.0 || !distance_mm.is_finite() {
        return Err(OffsetError::Degenerate);
    }
    let unit = |a: [f64; 2], b: [f64; 2]| {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let length = dx.hypot(dy);
        (length > 0.0).then(|| [dx / length, dy / length])
    };
    // The normal that points away from the inside (module docs of `offset_ring`).
    let outward = area2.signum();
    let normal = |t: [f64; 2]| [outward * t[1], -outward * t[0]];
    let d = distance_mm;
    let mut moved = Vec::with_capacity(n);
    for i in 0..n {
        let (before, p, after) = (ring[(i + n - 1) % n], ring[i], ring[(i + 1) % n]);
        let (Some(t1), Some(t2)) = (unit(before, p), unit(p, after)) else {
            return Err(OffsetError::Degenerate);
        };
        let (n1, n2) = (normal(t1), normal(t2));
        let cos = n1[0] * n2[0] + n1[1] * n2[1];
        // The path goes round the corner where the turn's outside is the offset's side.
        let turn = t1[0] * t2[1] - t1[1] * t2[0];
        let around = turn * outward * d > 0.0;
        if around && 1.0 + cos < 2.0 / (MITRE_LIMIT * MITRE_LIMIT) {
            let (a1, a2) = (n1[1].atan2(n1[0]), n2[1].atan2(n2[0]));
            let sweep = (a2 - a1 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            let steps = (sweep.abs() / ROUND_STEP_RAD).ceil().max(1.0) as usize;
            for k in 0..=steps {
                let a = a1 + sweep * k as f64 / steps as f64;
                moved.push(([p[0] + d * a.cos(), p[1] + d * a.sin()], i));
            }
        } else if 1.0 + cos > 1e-12 {
            let scale = d / (1.0 + cos);
            let mitre = [
                p[0] + scale * (n1[0] + n2[0]),
                p[1] + scale * (n1[1] + n2[1]),
            ];
            moved.push((mitre, i));
        }
        // A full reversal inside the offset's side adds no point: its loop is dropped.
    }
    let nearest = |q: [f64; 2]| {
        (0..n)
            .map(|k| segment_distance(q, ring[k], ring[(k + 1) % n]))
            .fold(f64::INFINITY, f64::min)
    };
    let magnitude = d.abs();
    let tolerance = 1e-6 * magnitude + 1e-9;
    let kept: Vec<([f64; 2], usize)> = moved
        .into_iter()
        .filter(|&(q, _)| nearest(q) >= magnitude - tolerance)
        .collect();
    if kept.len() < 3 {
        // Every corner fell into a loop: a contour narrower than the kerf all through.
        return Err(OffsetError::Collision {
            offset_mm: magnitude,
            at_mm: ring[0],
        });
    }
    // A rounded corner's chords pass inside its arc by their sagitta.
    let chord = 1.0 - (0.5 * ROUND_STEP_RAD).cos();
    let closest = magnitude * (1.0 - chord) - tolerance;
    for (k, &(a, _)) in kept.iter().enumerate() {
        let b = kept[(k + 1) % kept.len()].0;
        // Sampled along the edge: a neck shows as a point nearer the drawn line.
        for j in 1..8 {
            let t = j as f64 / 8.0;
            let q = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            if nearest(q) < closest {
                return Err(OffsetError::Collision {
                    offset_mm: magnitude,
                    at_mm: a,
                });
            }
        }
    }
    Ok(kept)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ellipse(a: f64, b: f64, n: usize, clockwise: bool) -> Vec<[f64; 2]> {
        (0..n)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / n as f64;
                let t = if clockwise { -t } else { t };
                [a * t.cos(), b * t.sin()]
            })
            .collect()
    }

    /// A circle's offset is the circle of the radius plus the offset (or minus), in
    /// either orientation: every point to round-off.
    #[test]
    fn a_circle_grows_and_shrinks_by_the_offset() {
        for clockwise in [false, true] {
            let ring = ellipse(5.0, 5.0, 720, clockwise);
            for d in [0.1, -0.1, 2.0, -2.0] {
                let out = offset_ring(&ring, d).unwrap();
                for p in out {
                    assert!((p[0].hypot(p[1]) - (5.0 + d)).abs() < 1e-9, "{p:?} {d}");
                }
            }
        }
    }

    /// Past a corner's radius the moved points fold into a loop: dropped, the corner
    /// comes out sharp and every point of the path is at least the offset from the
    /// contour. The ellipse's tightest radius is b²/a = 1.5 mm, at its ends on x.
    #[test]
    fn a_corners_loop_is_trimmed() {
        let ring = ellipse(6.0, 3.0, 720, false);
        let within = offset_ring(&ring, -1.4).unwrap();
        assert_eq!(within.len(), 720);
        let trimmed = offset_ring(&ring, -1.6).unwrap();
        assert!(trimmed.len() < 720, "{}", trimmed.len());
        for q in &trimmed {
            let gap = (0..ring.len())
                .map(|k| segment_distance(*q, ring[k], ring[(k + 1) % ring.len()]))
                .fold(f64::INFINITY, f64::min);
            assert!(gap > 1.6 - 2e-3, "{q:?} {gap}");
        }
        // The trimmed ends are the farthest the inner path reaches along x: the
        // points where the offsets from the ellipse's two sides meet on the axis.
        let reach = trimmed.iter().map(|p| p[0].abs()).fold(0.0, f64::max);
        assert!(reach < 6.0 - 1.6, "{reach}");
        assert_eq!(offset_ring(&ring[..2], 0.1), Err(OffsetError::Degenerate));
        assert_eq!(offset_ring(&ring, f64::NAN), Err(OffsetError::Degenerate));
    }

    /// A 'C' whose ends are 0.74 mm apart (round ends of 1 mm radius at 4 mm from the
    /// centre, ±20°): an offset of 0.3 mm passes the gap on both sides; one of 0.5 mm
    /// does not fit it (2 · 1.5 mm against 2.74 mm between the ends' centres) and is
    /// refused at the gap.
    #[test]
    fn a_gap_narrower_than_the_kerf_is_refused_where_it_is() {
        let c = letter_c();
        let fits = offset_ring(&c, 0.3).unwrap();
        assert_eq!(fits.len(), c.len());
        let e = offset_ring(&c, 0.5).unwrap_err();
        let OffsetError::Collision { at_mm, .. } = e else {
            panic!("{e:?}")
        };
        // Near the gap: about 4 mm out along +x.
        assert!(at_mm[0] > 2.5 && at_mm[1].abs() < 2.5, "{at_mm:?}");
    }

    /// A smooth convex ring's offset encloses the area Steiner's formula gives for a
    /// convex body moved out by d, A + L·d + π·d² (in, while d stays under the
    /// tightest radius: A − L·d + π·d²), A and L the ring's own: to 10⁻⁵ of the area
    /// (the chords of 4096 points).
    #[test]
    fn the_offset_encloses_steiners_area() {
        let ring = ellipse(6.0, 3.0, 4096, false);
        let area = signed_area2(&ring) / 2.0;
        let n = ring.len();
        let length: f64 = (0..n)
            .map(|i| {
                let (a, b) = (ring[i], ring[(i + 1) % n]);
                (b[0] - a[0]).hypot(b[1] - a[1])
            })
            .sum();
        for d in [0.5, -0.5, 1.0] {
            let got = signed_area2(&offset_ring(&ring, d).unwrap()) / 2.0;
            let steiner = area + length * d + std::f64::consts::PI * d * d;
            assert!(
                (got - steiner).abs() < 1e-5 * steiner,
                "{d}: {got} against {steiner}"
            );
        }
    }

    /// The 'C' of the test above, counter-clockwise, every 0.01 rad of arc.
    fn letter_c() -> Vec<[f64; 2]> {
        let arc = |c: [f64; 2], r: f64, from: f64, to: f64| -> Vec<[f64; 2]> {
            let n = ((to - from).abs() * r / 0.01).ceil() as usize;
            (0..n)
                .map(|k| {
                    let t = from + (to - from) * k as f64 / n as f64;
                    [c[0] + r * t.cos(), c[1] + r * t.sin()]
                })
                .collect()
        };
        let end = 20f64.to_radians();
        let pi = std::f64::consts::PI;
        let cap = |t: f64| [4.0 * t.cos(), 4.0 * t.sin()];
        let mut ring = arc([0.0, 0.0], 5.0, end, 2.0 * pi - end);
        ring.extend(arc(cap(-end), 1.0, -end, -end + pi));
        ring.extend(arc([0.0, 0.0], 3.0, 2.0 * pi - end, end));
        ring.extend(arc(cap(end), 1.0, end + pi, end + 2.0 * pi));
        ring
    }

    /// Area by the shoelace formula of the offset's points.
    fn area(points: &[([f64; 2], usize)]) -> f64 {
        let ring: Vec<[f64; 2]> = points.iter().map(|&(p, _)| p).collect();
        signed_area2(&ring).abs() / 2.0
    }

    /// Steiner's formula, computed from the drawn polygon alone: a polygon of area A
    /// and perimeter P moved out by d, each corner of exterior angle β mitred, gains
    /// P d + d² Σ tan(β/2) (β < 0 at a corner turning the other way).
    #[test]
    fn mitred_offsets_have_steiners_area_and_sharp_corners() {
        let square = [[-5.0, -5.0], [5.0, -5.0], [5.0, 5.0], [-5.0, 5.0]];
        for ring in [square.to_vec(), square.iter().rev().copied().collect()] {
            let out = offset_polygon(&ring, 0.1).unwrap();
            assert_eq!(out.len(), 4);
            for (p, i) in &out {
                let corner = ring[*i];
                assert!((p[0] - corner[0] * 5.1 / 5.0).abs() < 1e-12, "{p:?}");
                assert!((p[1] - corner[1] * 5.1 / 5.0).abs() < 1e-12, "{p:?}");
            }
            let inner = offset_polygon(&ring, -0.1).unwrap();
            assert!((area(&inner) - 9.8 * 9.8).abs() < 1e-9);
        }
        // An L: five corners turning one way, one the other.
        let l = [
            [0.0, 0.0],
            [6.0, 0.0],
            [6.0, 2.0],
            [2.0, 2.0],
            [2.0, 5.0],
            [0.0, 5.0],
        ];
        let (a, p, d) = (6.0 * 2.0 + 2.0 * 3.0, 22.0, 0.25);
        let steiner = a + p * d + d * d * (5.0 - 1.0);
        assert!((area(&offset_polygon(&l, d).unwrap()) - steiner).abs() < 1e-9);
        let steiner_in = a - p * d + d * d * (5.0 - 1.0);
        assert!((area(&offset_polygon(&l, -d).unwrap()) - steiner_in).abs() < 1e-9);
    }

    /// A corner sharper than the mitre limit is rounded: its points lie on the circle
    /// of the offset about the drawn corner, and the area is Steiner's with the
    /// rounded corner's fan of chords in place of its mitre.
    #[test]
    fn sharp_corners_are_rounded_at_the_offset() {
        // A thin triangle: a 20° corner at the origin.
        let tip = 20f64.to_radians();
        let tri = [
            [0.0, 0.0],
            [10.0, 0.0],
            [10.0 * tip.cos(), 10.0 * tip.sin()],
        ];
        let d = 0.2;
        let out = offset_polygon(&tri, d).unwrap();
        let at_tip: Vec<[f64; 2]> = out
            .iter()
            .filter(|(_, i)| *i == 0)
            .map(|&(p, _)| p)
            .collect();
        assert!(at_tip.len() > 2);
        for p in &at_tip {
            assert!((p[0].hypot(p[1]) - d).abs() < 1e-12, "{p:?}");
        }
        let exterior = |k: usize| {
            let (a, b, c) = (tri[(k + 2) % 3], tri[k], tri[(k + 1) % 3]);
            let (t1, t2) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
            (t1[0] * t2[1] - t1[1] * t2[0]).atan2(t1[0] * t2[0] + t1[1] * t2[1])
        };
        let perimeter: f64 = (0..3)
            .map(|k| (tri[(k + 1) % 3][0] - tri[k][0]).hypot(tri[(k + 1) % 3][1] - tri[k][1]))
            .sum();
        let mut steiner = signed_area2(&tri).abs() / 2.0 + perimeter * d;
        for k in 0..3 {
            let beta = exterior(k);
            // The normals of the two edges are β apart.
            let mitred = 1.0 + beta.cos() >= 2.0 / (MITRE_LIMIT * MITRE_LIMIT);
            steiner += if mitred {
                d * d * (beta / 2.0).tan()
            } else {
                let steps = (beta / ROUND_STEP_RAD).ceil();
                steps * 0.5 * d * d * (beta / steps).sin()
            };
        }
        assert!(
            (area(&out) - steiner).abs() < 1e-9,
            "{} {steiner}",
            area(&out)
        );
    }

    /// Short edges whose moved lines cross beyond each other leave no loop; a neck
    /// narrower than the kerf is refused where it is.
    #[test]
    fn loops_are_dropped_and_necks_refused() {
        // A square with a notch 0.1 mm wide and deep, moved out by 0.3 mm: the notch
        // closes over.
        let notched = [
            [0.0, 0.0],
            [4.95, 0.0],
            [4.95, 0.1],
            [5.05, 0.1],
            [5.05, 0.0],
            [10.0, 0.0],
            [10.0, 10.0],
            [0.0, 10.0],
        ];
        let out = offset_polygon(&notched, 0.3).unwrap();
        for (p, _) in &out {
            let nearest = (0..notched.len())
                .map(|k| segment_distance(*p, notched[k], notched[(k + 1) % notched.len()]))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest >= 0.3 - 1e-9, "{p:?} {nearest}");
        }
        // Two squares joined by a bridge 0.2 mm wide, moved in by 0.15 mm.
        let dumbbell = [
            [0.0, 0.0],
            [4.0, 0.0],
            [4.0, 1.9],
            [6.0, 1.9],
            [6.0, 0.0],
            [10.0, 0.0],
            [10.0, 4.0],
            [6.0, 4.0],
            [6.0, 2.1],
            [4.0, 2.1],
            [4.0, 4.0],
            [0.0, 4.0],
        ];
        assert!(matches!(
            offset_polygon(&dumbbell, -0.15),
            Err(OffsetError::Collision { .. })
        ));
        // A hole narrower than the kerf has no path inside it.
        let small = [[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.0, 0.1]];
        assert!(matches!(
            offset_polygon(&small, -0.1),
            Err(OffsetError::Collision { .. })
        ));
        assert!(offset_polygon(&dumbbell, -0.05).is_ok());
        assert_eq!(
            offset_polygon(&[[0.0, 0.0], [1.0, 0.0]], 0.1),
            Err(OffsetError::Degenerate)
        );
    }
}
