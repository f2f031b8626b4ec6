//! Binary images for the tracer: m-adjacent neighbours, Zhang–Suen thinning,
//! connected components, and pruning to cycles (see [`crate::trace`]).

use std::collections::VecDeque;

/// A pixel, (x, y), y down as in the image.
pub type Px = (u32, u32);

/// A binary image: which pixels are set.
#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    width: u32,
    height: u32,
    on: Vec<bool>,
}

impl Mask {
    /// `width` × `height` pixels, set where `on(x, y)`.
    pub fn from_fn(width: u32, height: u32, on: impl Fn(u32, u32) -> bool) -> Self {
        let on = (0..height)
            .flat_map(|y| (0..width).map(move |x| (x, y)))
            .map(|(x, y)| on(x, y))
            .collect();
        Self { width, height, on }
    }

    /// Width and height, pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    fn index(&self, x: i64, y: i64) -> Option<usize> {
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        ((0..w).contains(&x) && (0..h).contains(&y)).then(|| (y * w + x) as usize)
    }

    /// Whether (x, y) is set (false outside the image).
    pub fn get(&self, x: i64, y: i64) -> bool {
        self.index(x, y).is_some_and(|i| self.on[i])
    }

    pub(crate) fn set(&mut self, p: Px, value: bool) {
        if let Some(i) = self.index(p.0.into(), p.1.into()) {
            self.on[i] = value;
        }
    }

    /// The set pixels, row by row.
    pub fn pixels(&self) -> impl Iterator<Item = Px> + '_ {
        let w = self.width.max(1);
        self.on
            .iter()
            .enumerate()
            .filter(|(_, &on)| on)
            .map(move |(i, _)| ((i as u32) % w, (i as u32) / w))
    }

    /// The number of set pixels.
    pub fn count(&self) -> usize {
        self.on.iter().filter(|&&on| on).count()
    }

    /// The m-adjacent set neighbours of `p` (module docs).
    pub fn neighbours(&self, p: Px) -> impl Iterator<Item = Px> + '_ {
        let (x, y) = (i64::from(p.0), i64::from(p.1));
        const STEPS: [(i64, i64); 8] = [
            (1, 0),
            (0, -1),
            (-1, 0),
            (0, 1),
            (1, -1),
            (-1, -1),
            (-1, 1),
            (1, 1),
        ];
        STEPS.iter().filter_map(move |&(dx, dy)| {
            let (qx, qy) = (x + dx, y + dy);
            let diagonal = dx != 0 && dy != 0;
            let linked = self.get(qx, qy) && !(diagonal && (self.get(qx, y) || self.get(x, qy)));
            linked.then_some((qx as u32, qy as u32))
        })
    }

    pub(crate) fn degree(&self, p: Px) -> usize {
        self.neighbours(p).count()
    }

    /// Thinned to a one-pixel skeleton by Zhang & Suen's two sub-iterations (each
    /// removes boundary pixels whose removal keeps the 8-connectivity and that are not
    /// line ends), until nothing changes: at most one pass per pixel of the thickest
    /// part.
    pub fn thinned(&self) -> Self {
        let mut m = self.clone();
        loop {
            let mut changed = false;
            for step in 0..2 {
                let remove: Vec<Px> = m.pixels().filter(|&p| m.zs_removable(p, step)).collect();
                changed |= !remove.is_empty();
                for p in remove {
                    m.set(p, false);
                }
            }
            if !changed {
                return m;
            }
        }
    }

    fn zs_removable(&self, p: Px, step: usize) -> bool {
        let (x, y) = (i64::from(p.0), i64::from(p.1));
        // P2..P9: N, NE, E, SE, S, SW, W, NW.
        let n = [
            self.get(x, y - 1),
            self.get(x + 1, y - 1),
            self.get(x + 1, y),
            self.get(x + 1, y + 1),
            self.get(x, y + 1),
            self.get(x - 1, y + 1),
            self.get(x - 1, y),
            self.get(x - 1, y - 1),
        ];
        let b = n.iter().filter(|&&v| v).count();
        let a = (0..8).filter(|&i| !n[i] && n[(i + 1) % 8]).count();
        let (p2, p4, p6, p8) = (n[0], n[2], n[4], n[6]);
        let side = if step == 0 {
            !(p4 && p6 && (p2 || p8))
        } else {
            !(p2 && p8 && (p4 || p6))
        };
        (2..=6).contains(&b) && a == 1 && side
    }

    /// The connected components (m-adjacency, the same as 8-connectivity), largest
    /// first.
    pub fn components(&self) -> Vec<Mask> {
        let mut seen = Self::from_fn(self.width, self.height, |_, _| false);
        let mut out = Vec::new();
        for p in self.pixels() {
            if seen.get(p.0.into(), p.1.into()) {
                continue;
            }
            let mut part = Self::from_fn(self.width, self.height, |_, _| false);
            let mut queue = VecDeque::from([p]);
            seen.set(p, true);
            while let Some(q) = queue.pop_front() {
                part.set(q, true);
                for r in self.neighbours(q) {
                    if !seen.get(r.0.into(), r.1.into()) {
                        seen.set(r, true);
                        queue.push_back(r);
                    }
                }
            }
            out.push(part);
        }
        out.sort_by_key(|m| std::cmp::Reverse(m.count()));
        out
    }

    /// Without any dangling branch: pixels with fewer than two neighbours removed
    /// until none is left (what remains lies on cycles).
    pub fn pruned_to_cycles(&self) -> Self {
        let mut m = self.clone();
        let mut queue: VecDeque<Px> = m.pixels().filter(|&p| m.degree(p) < 2).collect();
        while let Some(p) = queue.pop_front() {
            if !m.get(p.0.into(), p.1.into()) || m.degree(p) >= 2 {
                continue;
            }
            m.set(p, false);
            let (x, y) = (i64::from(p.0), i64::from(p.1));
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if m.get(x + dx, y + dy) {
                        queue.push_back(((x + dx) as u32, (y + dy) as u32));
                    }
                }
            }
        }
        m
    }
}
