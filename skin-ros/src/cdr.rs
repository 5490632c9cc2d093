//! A CDR writer (OMG CDR version 1, little-endian, as ROS 2 and rmw_zenoh write it): the 4-byte
//! encapsulation header `00 01 00 00`, then each field aligned to its own size, counted from the
//! end of that header; a string is its length with the terminating NUL (u32), its bytes and the
//! NUL; a sequence is its length (u32) and its elements.
//!
//! One writer is reused for every message: [`CdrWriter::start`] clears it, so encoding allocates
//! only while a message is larger than any before it.

/// The encapsulation header of little-endian plain CDR.
pub const CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Writes one CDR message at a time into a reused buffer.
#[derive(Debug, Clone, Default)]
pub struct CdrWriter {
    buf: Vec<u8>,
}

impl CdrWriter {
    /// An empty writer.
    pub fn new() -> CdrWriter {
        CdrWriter::default()
    }

    /// Begins a message: the buffer holds only the encapsulation header.
    pub fn start(&mut self) -> &mut Self {
        self.buf.clear();
        self.buf.extend_from_slice(&CDR_LE);
        self
    }

    /// The message so far, header included.
    pub fn bytes(&self) -> &[u8] {
        &self.buf
    }

    /// Bytes written after the header (where the next field's alignment counts from).
    pub fn position(&self) -> usize {
        self.buf.len() - CDR_LE.len()
    }

    /// Pads with zeros to a multiple of `n` bytes after the header.
    pub fn align(&mut self, n: usize) -> &mut Self {
        let pad = (n - self.position() % n) % n;
        self.buf.resize(self.buf.len() + pad, 0);
        self
    }

    /// `bool`, one byte.
    pub fn bool(&mut self, v: bool) -> &mut Self {
        self.buf.push(u8::from(v));
        self
    }

    /// `uint8` / `byte`.
    pub fn u8(&mut self, v: u8) -> &mut Self {
        self.buf.push(v);
        self
    }

    /// `int32`.
    pub fn i32(&mut self, v: i32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// `uint32`.
    pub fn u32(&mut self, v: u32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// `uint64`.
    pub fn u64(&mut self, v: u64) -> &mut Self {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// `float32`.
    pub fn f32(&mut self, v: f32) -> &mut Self {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// `float64`.
    pub fn f64(&mut self, v: f64) -> &mut Self {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
        self
    }

    /// A sequence's length. Lengths past `u32::MAX` cannot be written in CDR; callers bound
    /// what they write far below it (a skin's taxels, an image's pixels).
    pub fn seq_len(&mut self, n: usize) -> &mut Self {
        self.u32(u32::try_from(n).unwrap_or(u32::MAX))
    }

    /// `string`: length with its NUL, the bytes, the NUL.
    pub fn string(&mut self, s: &str) -> &mut Self {
        self.seq_len(s.len() + 1);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
        self
    }

    /// `uint8[]`: length and bytes.
    pub fn bytes_seq(&mut self, data: &[u8]) -> &mut Self {
        self.seq_len(data.len());
        self.buf.extend_from_slice(data);
        self
    }

    /// Raw bytes, as they are (a fixed layout written once and patched).
    pub fn raw(&mut self, data: &[u8]) -> &mut Self {
        self.buf.extend_from_slice(data);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alignment_counts_from_after_the_header() {
        let mut w = CdrWriter::new();
        w.start().u8(7).f64(1.0).string("ab").u32(3);
        let b = w.bytes();
        assert_eq!(&b[..4], &CDR_LE);
        // u8 at 0, pad to 8, f64 at 8..16, string length at 16, "ab\0" at 20..23, pad, u32 at 24.
        assert_eq!(b.len(), 4 + 28);
        assert_eq!(b[4], 7);
        assert_eq!(&b[5..12], &[0; 7]);
        assert_eq!(&b[12..20], &1.0f64.to_le_bytes());
        assert_eq!(&b[20..24], &3u32.to_le_bytes());
        assert_eq!(&b[24..27], b"ab\0");
        assert_eq!(b[27], 0);
        assert_eq!(&b[28..32], &3u32.to_le_bytes());
    }

    #[test]
    fn start_reuses_the_buffer() {
        let mut w = CdrWriter::new();
        w.start().string("a long string that grows the buffer");
        w.start().u8(1);
        assert_eq!(w.bytes(), &[0, 1, 0, 0, 1]);
    }
}
