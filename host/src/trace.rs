//! From an edge map to one ordered chain of pixels (T 3.1.2–3.1.3).
//!
//! T 3.1.3 moves a window along the edge in the direction of the image gradient and
//! collects its centroids. Here the edges (after T 3.1.1's closing) are thinned to a
//! one-pixel skeleton (Zhang & Suen 1984) and the chain is walked over the skeleton's
//! neighbours, which gives the same ordered points without a gradient step to tune:
//!
//! - Neighbours are *m-adjacent* (4-neighbours, and diagonal ones only where no
//!   4-neighbour links the two): a thin diagonal line then has two neighbours per
//!   pixel, so pixels with three or more are real junctions.
//! - The skeleton becomes a graph: junction pixels (clustered, and clusters joined by
//!   a branch of at most [`MERGE_PX`] pixels merged into one node, so that a crossing
//!   thinned into two close forks is one node) and branches between them.
//! - **Closed** contours (T 3.1.2: automatic start): every dangling branch is pruned
//!   (a closed contour has no ends), the largest remaining component is taken, and its
//!   outer boundary is walked from its rightmost pixel, upwards (counter-clockwise in
//!   the workspace, whose y axis points up), taking the rightmost turn at each node:
//!   the outside stays on the right, so the walk follows the outer face of the graph
//!   and comes back to its first branch.
//! - **Open** contours (T 3.1.2: the user gives the start): the largest component,
//!   dangling branches shorter than the prune length removed (shortest first, and only
//!   where their node keeps two other branches, so that a blunt end thinned into a
//!   fork keeps one prong), except the one the walk starts on, walked from the free end nearest the user's point, going straight at
//!   each node (the smallest turn among the unused branches: the loop of an 'e' that
//!   crosses its bar goes through the crossing twice), to a free end or a node whose
//!   branches are all used. Its two ends are then moved out to where the medial
//!   axis of the edge band ends (thinning shortens a band's end by about its
//!   half-width): w short of the band's tip, with w the distance from the skeleton's
//!   end to the band's border.

pub use crate::mask::{Mask, Px};
use std::collections::VecDeque;

/// Node clusters joined by a branch of at most this many pixels are one node.
pub const MERGE_PX: usize = 4;
/// Pixels along a branch over which its direction at a node is measured.
const DIRECTION_PX: usize = 6;

/// A junction of the skeleton (or the forced start pixel).
#[derive(Clone, Debug)]
struct Node {
    pixels: Vec<Px>,
    at: [f64; 2],
}

/// A run of two-neighbour pixels between nodes or free ends, in order from `ends[0]`
/// to `ends[1]` (`None`: a free end, whose pixel is the run's first or last).
#[derive(Clone, Debug)]
struct Branch {
    pixels: Vec<Px>,
    ends: [Option<usize>; 2],
}

/// A branch walked one way.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
struct Dart {
    branch: usize,
    forward: bool,
}

/// The skeleton as nodes and branches.
#[derive(Clone, Debug)]
struct Graph {
    nodes: Vec<Node>,
    branches: Vec<Branch>,
}

fn centre(pixels: &[Px]) -> [f64; 2] {
    let n = pixels.len().max(1) as f64;
    let (sx, sy) = pixels.iter().fold((0.0, 0.0), |(sx, sy), p| {
        (sx + f64::from(p.0), sy + f64::from(p.1))
    });
    [sx / n, sy / n]
}

fn px(p: Px) -> [f64; 2] {
    [f64::from(p.0), f64::from(p.1)]
}

impl Graph {
    /// The graph of `mask`, with `forced` a node even where it has two neighbours.
    fn new(mask: &Mask, forced: Option<Px>) -> Self {
        let (w, h) = mask.size();
        let mut node_of = vec![None; (w as usize) * (h as usize)];
        let at = |p: Px| (p.1 as usize) * (w as usize) + p.0 as usize;
        let junction = |p: Px| mask.degree(p) >= 3 || Some(p) == forced;
        let mut nodes: Vec<Node> = Vec::new();
        for p in mask.pixels().filter(|&p| junction(p)) {
            if node_of[at(p)].is_some() {
                continue;
            }
            // Cluster 8-adjacent junction pixels.
            let id = nodes.len();
            let mut pixels = vec![p];
            node_of[at(p)] = Some(id);
            let mut i = 0;
            while let Some(&q) = pixels.get(i) {
                i += 1;
                let (x, y) = (i64::from(q.0), i64::from(q.1));
                for (dx, dy) in (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))) {
                    if !mask.get(x + dx, y + dy) {
                        continue;
                    }
                    let r = ((x + dx) as u32, (y + dy) as u32);
                    if junction(r) && node_of[at(r)].is_none() {
                        node_of[at(r)] = Some(id);
                        pixels.push(r);
                    }
                }
            }
            nodes.push(Node {
                at: centre(&pixels),
                pixels,
            });
        }
        let mut graph = Self {
            nodes,
            branches: Vec::new(),
        };
        let mut visited = vec![false; node_of.len()];
        // Branches from nodes, then free chains from their ends, then rings.
        for id in 0..graph.nodes.len() {
            for j in graph.nodes[id].pixels.clone() {
                for q in mask.neighbours(j).collect::<Vec<_>>() {
                    if node_of[at(q)].is_none() && !visited[at(q)] {
                        let b = trace(mask, &node_of, &mut visited, Some(id), j, q);
                        graph.branches.push(b);
                    }
                }
            }
        }
        loop {
            let free = mask
                .pixels()
                .find(|&p| !visited[at(p)] && node_of[at(p)].is_none() && mask.degree(p) == 1);
            let ring = || {
                mask.pixels()
                    .find(|&p| !visited[at(p)] && node_of[at(p)].is_none() && mask.degree(p) == 2)
            };
            if let Some(p) = free {
                visited[at(p)] = true;
                let b = match mask.neighbours(p).next() {
                    Some(q) if node_of[at(q)].is_none() && !visited[at(q)] => {
                        let mut b = trace(mask, &node_of, &mut visited, None, p, q);
                        b.pixels.insert(0, p);
                        b
                    }
                    _ => Branch {
                        pixels: vec![p],
                        ends: [None, None],
                    },
                };
                graph.branches.push(b);
            } else if let Some(p) = ring() {
                let id = graph.nodes.len();
                node_of[at(p)] = Some(id);
                graph.nodes.push(Node {
                    pixels: vec![p],
                    at: px(p),
                });
                if let Some(q) = mask.neighbours(p).next() {
                    let b = trace(mask, &node_of, &mut visited, Some(id), p, q);
                    graph.branches.push(b);
                }
            } else {
                break;
            }
        }
        graph.merge_close_nodes();
        graph
    }

    /// Merges nodes joined by a branch of at most [`MERGE_PX`] pixels (module docs).
    fn merge_close_nodes(&mut self) {
        let mut parent: Vec<usize> = (0..self.nodes.len()).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        let mut absorbed = vec![false; self.branches.len()];
        for (k, b) in self.branches.iter().enumerate() {
            if let [Some(a), Some(c)] = b.ends {
                let (ra, rc) = (root(&mut parent, a), root(&mut parent, c));
                if ra != rc && b.pixels.len() <= MERGE_PX {
                    parent[ra] = rc;
                    absorbed[k] = true;
                }
            }
        }
        if !absorbed.iter().any(|&a| a) {
            return;
        }
        let mut new_id = vec![usize::MAX; self.nodes.len()];
        let mut nodes: Vec<Node> = Vec::new();
        for i in 0..self.nodes.len() {
            let r = root(&mut parent, i);
            if new_id[r] == usize::MAX {
                new_id[r] = nodes.len();
                nodes.push(Node {
                    pixels: Vec::new(),
                    at: [0.0; 2],
                });
            }
            let id = new_id[r];
            new_id[i] = id;
            nodes[id].pixels.extend_from_slice(&self.nodes[i].pixels);
        }
        let mut branches = Vec::new();
        for (k, b) in self.branches.drain(..).enumerate() {
            let ends = b.ends.map(|e| e.map(|n| new_id[n]));
            if absorbed[k] {
                if let Some(n) = ends[0] {
                    nodes[n].pixels.extend_from_slice(&b.pixels);
                }
            } else {
                branches.push(Branch {
                    pixels: b.pixels,
                    ends,
                });
            }
        }
        for n in &mut nodes {
            n.at = centre(&n.pixels);
        }
        self.nodes = nodes;
        self.branches = branches;
    }

    fn start_node(&self, d: Dart) -> Option<usize> {
        self.branches[d.branch].ends[usize::from(!d.forward)]
    }

    fn to_node(&self, d: Dart) -> Option<usize> {
        self.branches[d.branch].ends[usize::from(d.forward)]
    }

    /// The pixels of `d` in walking order.
    fn points(&self, d: Dart) -> Vec<[f64; 2]> {
        let p = self.branches[d.branch].pixels.iter().map(|&p| px(p));
        if d.forward {
            p.collect()
        } else {
            p.rev().collect()
        }
    }

    /// Where `d` leaves from and where it arrives.
    fn end_points(&self, d: Dart) -> ([f64; 2], [f64; 2]) {
        let pts = self.points(d);
        let first = pts.first().copied().unwrap_or_default();
        let last = pts.last().copied().unwrap_or_default();
        let from = self.start_node(d).map_or(first, |n| self.nodes[n].at);
        let to = self.to_node(d).map_or(last, |n| self.nodes[n].at);
        (from, to)
    }

    /// Direction in which `d` leaves its start (image axes).
    fn departure(&self, d: Dart) -> [f64; 2] {
        let pts = self.points(d);
        let (from, to) = self.end_points(d);
        let q = pts
            .get(DIRECTION_PX.min(pts.len().saturating_sub(1)))
            .copied()
            .unwrap_or(to);
        let v = sub(q, from);
        if v == [0.0, 0.0] {
            sub(to, from)
        } else {
            v
        }
    }

    /// Direction in which `d` arrives at its end (image axes).
    fn arrival(&self, d: Dart) -> [f64; 2] {
        let back = Dart {
            forward: !d.forward,
            ..d
        };
        let v = self.departure(back);
        [-v[0], -v[1]]
    }

    /// Darts leaving node `n`.
    fn darts_from(&self, n: usize) -> Vec<Dart> {
        let mut out = Vec::new();
        for (k, b) in self.branches.iter().enumerate() {
            if b.ends[0] == Some(n) {
                out.push(Dart {
                    branch: k,
                    forward: true,
                });
            }
            if b.ends[1] == Some(n) {
                out.push(Dart {
                    branch: k,
                    forward: false,
                });
            }
        }
        out
    }
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// Turn from direction `a` to `b` in the workspace (y up; image directions given),
/// rad in (−π, π]: positive to the left.
fn turn(a: [f64; 2], b: [f64; 2]) -> f64 {
    let cross_image = a[0] * b[1] - a[1] * b[0];
    let dot = a[0] * b[0] + a[1] * b[1];
    (-cross_image).atan2(dot)
}

/// The run of two-neighbour pixels from `first` (a neighbour of `prev`) to the next
/// node or free end.
fn trace(
    mask: &Mask,
    node_of: &[Option<usize>],
    visited: &mut [bool],
    from: Option<usize>,
    mut prev: Px,
    mut cur: Px,
) -> Branch {
    let (w, _) = mask.size();
    let at = |p: Px| (p.1 as usize) * (w as usize) + p.0 as usize;
    let mut pixels = Vec::new();
    loop {
        visited[at(cur)] = true;
        pixels.push(cur);
        let next: Vec<Px> = mask.neighbours(cur).filter(|&q| q != prev).collect();
        let Some(&q) = next.first() else {
            return Branch {
                pixels,
                ends: [from, None],
            };
        };
        if let Some(n) = node_of[at(q)] {
            return Branch {
                pixels,
                ends: [from, Some(n)],
            };
        }
        if visited[at(q)] {
            return Branch {
                pixels,
                ends: [from, None],
            };
        }
        prev = cur;
        cur = q;
    }
}

/// Why no chain was found.
#[derive(Copy, Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TraceError {
    /// No edge pixels at all.
    #[error("no edges found in the image (for a faint or low-contrast picture try lower --canny thresholds, such as 20,50, less smoothing, --sigma 0.5, or cutting it into ink and paper, --threshold 128)")]
    NoEdges,
    /// No cycle: the edges form no closed contour.
    #[error("no closed contour in the image: its edges do not close (for a faint picture try lower --canny thresholds, such as 20,50, or a larger --close-px to bridge gaps, such as 5; for an open contour give --start X,Y)")]
    NoClosedContour,
    /// The largest edge chain has no free end, but an open contour was asked for.
    #[error("the contour is closed (it has no ends): leave out --start")]
    NoFreeEnd,
    /// A closed contour past the number found was asked for (1-based, largest first).
    #[error("contour {asked} asked for, but the image has {found} closed contours (--contour 1 to {found}, largest first)")]
    NoSuchContour {
        /// The contour asked for, 1-based.
        asked: usize,
        /// Closed contours found.
        found: usize,
    },
}

/// Closed contour `index` (0: the largest; the contours are the cycles' connected
/// parts, largest first) and how many closed contours there are (module docs): pixel
/// positions in walking order, starting at the rightmost pixel (top-most of those),
/// counter-clockwise in the workspace; the first point is not repeated at the end.
pub fn closed_chain(skeleton: &Mask, index: usize) -> Result<(Vec<[f64; 2]>, usize), TraceError> {
    let components = cycle_components(skeleton)?;
    let found = components.len();
    let component = components
        .into_iter()
        .nth(index)
        .ok_or(TraceError::NoSuchContour {
            asked: index.saturating_add(1),
            found,
        })?;
    Ok((walk_closed(&component)?, found))
}

/// Every closed contour, largest first, each as [`closed_chain`] walks it.
pub fn closed_chains(skeleton: &Mask) -> Result<Vec<Vec<[f64; 2]>>, TraceError> {
    cycle_components(skeleton)?
        .iter()
        .map(walk_closed)
        .collect()
}

/// The connected parts of the skeleton's cycles, largest first.
fn cycle_components(skeleton: &Mask) -> Result<Vec<Mask>, TraceError> {
    if skeleton.count() == 0 {
        return Err(TraceError::NoEdges);
    }
    let components = skeleton.pruned_to_cycles().components();
    if components.is_empty() {
        return Err(TraceError::NoClosedContour);
    }
    Ok(components)
}

/// One connected part of the cycles walked round its outside (module docs).
fn walk_closed(component: &Mask) -> Result<Vec<[f64; 2]>, TraceError> {
    let start = component
        .pixels()
        .max_by_key(|p| (p.0, std::cmp::Reverse(p.1)))
        .ok_or(TraceError::NoClosedContour)?;
    let graph = Graph::new(component, Some(start));
    let s = graph
        .nodes
        .iter()
        .position(|n| n.pixels.contains(&start))
        .ok_or(TraceError::NoClosedContour)?;
    // Leave upwards: the outside (+x of the rightmost pixel) on the right.
    let darts = graph.darts_from(s);
    let first = darts
        .iter()
        .copied()
        .min_by(|a, b| {
            let up = |d: Dart| {
                let v = graph.departure(d);
                v[1] / v[0].hypot(v[1]).max(1e-12)
            };
            up(*a).total_cmp(&up(*b))
        })
        .ok_or(TraceError::NoClosedContour)?;
    let mut chain = vec![graph.nodes[s].at];
    let mut cur = first;
    for _ in 0..=2 * graph.branches.len() {
        chain.extend(graph.points(cur));
        let Some(v) = graph.to_node(cur) else {
            return Err(TraceError::NoClosedContour);
        };
        let arrival = graph.arrival(cur);
        let next = graph
            .darts_from(v)
            .into_iter()
            .map(|d| {
                let reverse = d.branch == cur.branch && d.forward != cur.forward;
                let t = if reverse {
                    std::f64::consts::PI
                } else {
                    turn(arrival, graph.departure(d))
                };
                (d, t)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(d, _)| d)
            .ok_or(TraceError::NoClosedContour)?;
        if v == s && next == first {
            dedup(&mut chain);
            if chain.len() >= 2 && chain.first() == chain.last() {
                chain.pop();
            }
            return Ok(chain);
        }
        chain.push(graph.nodes[v].at);
        cur = next;
    }
    Err(TraceError::NoClosedContour)
}

/// The open contour (module docs) from the free end nearest `start` (pixels), spurs
/// shorter than `prune_px` removed, its ends moved out to the ends of the medial axis
/// of `band` (the edges before thinning; the module docs say how): pixel positions in
/// walking order.
pub fn open_chain(
    skeleton: &Mask,
    band: &Mask,
    start: [f64; 2],
    prune_px: usize,
) -> Result<Vec<[f64; 2]>, TraceError> {
    let component = skeleton
        .components()
        .into_iter()
        .next()
        .ok_or(TraceError::NoEdges)?;
    let nearest_end = |g: &Graph| {
        g.branches
            .iter()
            .enumerate()
            .flat_map(|(k, b)| {
                let first = b.pixels.first().map(|&p| (k, true, p));
                let last = b.pixels.last().map(|&p| (k, false, p));
                [(b.ends[0].is_none(), first), (b.ends[1].is_none(), last)]
            })
            .filter_map(|(free, e)| if free { e } else { None })
            .min_by(|a, b| {
                let d = |p: Px| (f64::from(p.0) - start[0]).hypot(f64::from(p.1) - start[1]);
                d(a.2).total_cmp(&d(b.2))
            })
    };
    // Prune the short spurs (all but the start's), then rebuild the graph.
    let graph = Graph::new(&component, None);
    let (keep, _, _) = nearest_end(&graph).ok_or(TraceError::NoFreeEnd)?;
    // Shortest first, and only while the node keeps two other branches: a blunt end
    // thinned into a short fork keeps its longer prong, so the path keeps its length.
    let mut degree = vec![0usize; graph.nodes.len()];
    for n in graph.branches.iter().flat_map(|b| b.ends.iter().flatten()) {
        degree[*n] += 1;
    }
    let mut spurs: Vec<(usize, usize)> = graph
        .branches
        .iter()
        .enumerate()
        .filter(|&(k, b)| k != keep && b.pixels.len() < prune_px)
        .filter_map(|(k, b)| match b.ends {
            [None, Some(n)] | [Some(n), None] => Some((k, n)),
            _ => None,
        })
        .collect();
    spurs.sort_by_key(|&(k, _)| graph.branches[k].pixels.len());
    let mut pruned = component.clone();
    for (k, n) in spurs {
        if degree[n] >= 3 {
            degree[n] -= 1;
            graph.branches[k]
                .pixels
                .iter()
                .for_each(|&p| pruned.set(p, false));
        }
    }
    let graph = Graph::new(&pruned, None);
    let (k, forward, _) = nearest_end(&graph).ok_or(TraceError::NoFreeEnd)?;
    let mut used = vec![false; graph.branches.len()];
    let mut cur = Dart { branch: k, forward };
    let mut chain = Vec::new();
    for _ in 0..graph.branches.len() {
        used[cur.branch] = true;
        chain.extend(graph.points(cur));
        let Some(v) = graph.to_node(cur) else {
            break;
        };
        let arrival = graph.arrival(cur);
        let next = graph
            .darts_from(v)
            .into_iter()
            .filter(|d| !used[d.branch])
            .min_by(|a, b| {
                let t = |d: &Dart| turn(arrival, graph.departure(*d)).abs();
                t(a).total_cmp(&t(b))
            });
        let Some(next) = next else {
            break;
        };
        chain.push(graph.nodes[v].at);
        cur = next;
    }
    dedup(&mut chain);
    extend_ends(&mut chain, band);
    Ok(chain)
}

/// Each end of an open chain moved out to where the medial axis of `band` ends:
/// thinning shortens a band's end by about its half-width (more on the side its first
/// sub-iteration erodes, and bent towards it), while the centre of the end's inscribed
/// circle lies one half-width inside the band's tip. From the end point e with the
/// chain's direction d over its last [`DIRECTION_PX`] pixels: w, the distance from e to
/// the nearest pixel outside the band; the tip, the band pixel connected to e ahead of
/// it (within 6w + 8 pixels) farthest along d; the end moves to w short of the tip on
/// the line from e when that is beyond e.
fn extend_ends(chain: &mut Vec<[f64; 2]>, band: &Mask) {
    for _ in 0..2 {
        chain.reverse();
        let n = chain.len();
        if n < 2 {
            continue;
        }
        let e = chain[n - 1];
        let d = sub(e, chain[n.saturating_sub(1 + DIRECTION_PX)]);
        let len = d[0].hypot(d[1]);
        let (ex, ey) = (e[0].round() as i64, e[1].round() as i64);
        if len == 0.0 || !band.get(ex, ey) {
            continue;
        }
        let d = [d[0] / len, d[1] / len];
        let w = (-32i64..=32)
            .flat_map(|dy| (-32i64..=32).map(move |dx| (dx, dy)))
            .filter(|&(dx, dy)| !band.get(ex + dx, ey + dy))
            .map(|(dx, dy)| (dx as f64).hypot(dy as f64))
            .fold(f64::INFINITY, f64::min);
        if !w.is_finite() {
            continue;
        }
        let reach = 6.0 * w + 8.0;
        let along = |p: (i64, i64)| (p.0 - ex) as f64 * d[0] + (p.1 - ey) as f64 * d[1];
        let near = |p: (i64, i64)| ((p.0 - ex) as f64).hypot((p.1 - ey) as f64) <= reach;
        let mut seen = std::collections::HashSet::from([(ex, ey)]);
        let mut queue = VecDeque::from([(ex, ey)]);
        let mut tip = (ex, ey);
        while let Some(p) = queue.pop_front() {
            if along(p) > along(tip) {
                tip = p;
            }
            for (dx, dy) in (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))) {
                let q = (p.0 + dx, p.1 + dy);
                if band.get(q.0, q.1) && along(q) >= -1.0 && near(q) && seen.insert(q) {
                    queue.push_back(q);
                }
            }
        }
        let to_tip = [tip.0 as f64 - e[0], tip.1 as f64 - e[1]];
        let l = to_tip[0].hypot(to_tip[1]);
        let t = l - w;
        if l > 0.0 && t >= 1.0 {
            chain.push([e[0] + t * to_tip[0] / l, e[1] + t * to_tip[1] / l]);
        }
    }
}

fn dedup(chain: &mut Vec<[f64; 2]>) {
    chain.dedup_by(|a, b| a == b);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(r: f64) -> Mask {
        Mask::from_fn(64, 64, |x, y| {
            let d = (f64::from(x) - 32.0).hypot(f64::from(y) - 32.0);
            (d - r).abs() < 1.5
        })
    }

    #[test]
    fn a_thick_ring_thins_to_one_closed_chain_counter_clockwise() {
        let skel = ring(20.0).thinned();
        let (chain, found) = closed_chain(&skel, 0).unwrap();
        assert_eq!(found, 1);
        assert!(chain.len() > 100, "{}", chain.len());
        // Starts at the rightmost pixel and goes up (image y decreasing).
        assert!((chain[0][0] - 52.0).abs() <= 1.0, "{:?}", chain[0]);
        assert!(chain[5][1] < chain[0][1]);
        for w in chain.windows(2) {
            let d = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
            assert!(d < 1.5, "gap {d}");
        }
    }

    #[test]
    fn a_plus_crossing_is_walked_straight_through() {
        let m = Mask::from_fn(41, 41, |x, y| x == 20 || y == 20);
        let chain = open_chain(&m, &m, [0.0, 20.0], 3).unwrap();
        assert_eq!(chain.first(), Some(&[0.0, 20.0]));
        assert_eq!(chain.last(), Some(&[40.0, 20.0]));
    }

    #[test]
    fn a_ring_has_no_free_end_and_a_line_no_cycle() {
        assert_eq!(
            open_chain(&ring(20.0).thinned(), &ring(20.0), [0.0, 0.0], 5),
            Err(TraceError::NoFreeEnd)
        );
        let line = Mask::from_fn(20, 20, |x, y| y == 3 && x > 2);
        assert_eq!(closed_chain(&line, 0), Err(TraceError::NoClosedContour));
    }
}
