//! A joint-space job: rest-to-rest moves of every axis, kept in a fixed-capacity list.

/// Most segments a job holds.
pub const MAX_SEGMENTS: usize = 16;

/// One move of every axis.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct Segment<const N: usize> {
    /// Where each axis ends, m.
    pub target_m: [f64; N],
    /// How long the move takes, s.
    pub duration_s: f64,
}

/// A joint-space job: its segments in order (at most [`MAX_SEGMENTS`]), read as a
/// slice.
///
/// `clone_from` copies in place: the supervisor loads a job into the one it keeps
/// from the control period, where a temporary of the job's size (0.5 KB) would land on
/// the interrupt's stack.
#[derive(Debug, Default, PartialEq)]
pub struct JointJob<const N: usize> {
    segments: heapless::Vec<Segment<N>, MAX_SEGMENTS>,
}

impl<const N: usize> JointJob<N> {
    /// An empty job.
    pub const fn new() -> Self {
        Self {
            segments: heapless::Vec::new(),
        }
    }

    /// A job of `segments`; `None` beyond [`MAX_SEGMENTS`].
    pub fn from_slice(segments: &[Segment<N>]) -> Option<Self> {
        let mut job = Self::new();
        job.segments.extend_from_slice(segments).ok()?;
        Some(job)
    }

    /// Appends a segment; gives it back when the job is full.
    pub fn push(&mut self, segment: Segment<N>) -> Result<(), Segment<N>> {
        self.segments.push(segment)
    }

    /// Removes every segment.
    pub fn clear(&mut self) {
        self.segments.clear();
    }
}

impl<const N: usize> core::ops::Deref for JointJob<N> {
    type Target = [Segment<N>];

    fn deref(&self) -> &[Segment<N>] {
        &self.segments
    }
}

impl<const N: usize> Clone for JointJob<N> {
    fn clone(&self) -> Self {
        let mut job = Self::new();
        job.clone_from(self);
        job
    }

    fn clone_from(&mut self, source: &Self) {
        self.segments.clear();
        // Same capacity on both sides: every segment fits.
        let _ = self.segments.extend_from_slice(&source.segments);
    }
}
