//! Reading a fuzz input as fields, and writing seeds in the same layout.
//!
//! Multi-byte fields are little-endian. A *record* is a length (u16) and that many
//! bytes; a record cut short by the end of the input is what is left.

/// A fuzz input read front to back; every read past the end is `None`.
pub struct Input<'a> {
    data: &'a [u8],
}

impl<'a> Input<'a> {
    /// Reads `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Self { data }
    }

    /// The next `n` bytes.
    pub fn bytes(&mut self, n: usize) -> Option<&'a [u8]> {
        let (head, rest) = self.data.split_at_checked(n)?;
        self.data = rest;
        Some(head)
    }

    /// The next byte.
    pub fn u8(&mut self) -> Option<u8> {
        self.bytes(1).map(|b| b[0])
    }

    /// The next u16.
    pub fn u16(&mut self) -> Option<u16> {
        self.bytes(2).map(|b| u16::from_le_bytes([b[0], b[1]]))
    }

    /// The next u32.
    pub fn u32(&mut self) -> Option<u32> {
        self.bytes(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// The next f32 (any bit pattern, NaN and infinities included).
    pub fn f32(&mut self) -> Option<f32> {
        self.u32().map(f32::from_bits)
    }

    /// The next record: a u16 length and up to that many bytes.
    pub fn record(&mut self) -> Option<&'a [u8]> {
        let n = usize::from(self.u16()?);
        let n = n.min(self.data.len());
        self.bytes(n)
    }

    /// Everything left.
    pub fn rest(&mut self) -> &'a [u8] {
        core::mem::take(&mut self.data)
    }

    /// Whether nothing is left.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
}

/// A seed written in [`Input`]'s layout.
#[derive(Clone, Debug, Default)]
pub struct Seed(pub Vec<u8>);

impl Seed {
    /// An empty seed.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends bytes as they are.
    pub fn bytes(mut self, bytes: &[u8]) -> Self {
        self.0.extend_from_slice(bytes);
        self
    }

    /// Appends a byte.
    pub fn u8(self, v: u8) -> Self {
        self.bytes(&[v])
    }

    /// Appends a u16.
    pub fn u16(self, v: u16) -> Self {
        self.bytes(&v.to_le_bytes())
    }

    /// Appends a u32.
    pub fn u32(self, v: u32) -> Self {
        self.bytes(&v.to_le_bytes())
    }

    /// Appends an f32.
    pub fn f32(self, v: f32) -> Self {
        self.bytes(&v.to_le_bytes())
    }

    /// Appends a record (`bytes` must be shorter than 64 KiB).
    pub fn record(self, bytes: &[u8]) -> Self {
        let n = u16::try_from(bytes.len()).expect("a record shorter than 64 KiB");
        self.u16(n).bytes(bytes)
    }
}

/// Bit-for-bit equality of f32s (NaN payloads included): what a decoder that
/// round-trips must give back.
pub fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}
