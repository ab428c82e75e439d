//! Bit fields of the compact stream: bits packed least significant first
//! into bytes, each field byte-aligned on its own so a general-purpose
//! compressor sees like next to like (PROTOCOL.md, "Protocol 6").

/// Appends bits (64 at a time into the bytes: least significant first in
/// a little-endian word is least significant first in each byte).
#[derive(Default)]
pub struct BitWriter {
    bytes: Vec<u8>,
    acc: u64,
    filled: u32,
}

impl BitWriter {
    /// One bit.
    #[inline]
    pub fn bit(&mut self, b: bool) {
        self.acc |= u64::from(b) << self.filled;
        self.filled += 1;
        if self.filled == 64 {
            self.bytes.extend_from_slice(&self.acc.to_le_bytes());
            self.acc = 0;
            self.filled = 0;
        }
    }

    /// Bits written so far.
    pub fn len(&self) -> usize {
        self.bytes.len() * 8 + self.filled as usize
    }

    /// True when nothing was written.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The bytes, the last one padded with zeros.
    pub fn finish(mut self) -> Vec<u8> {
        let tail = self.filled.div_ceil(8) as usize;
        self.bytes.extend_from_slice(&self.acc.to_le_bytes()[..tail]);
        self.bytes
    }
}

/// Reads bits; reading past the end is an error naming the field.
pub struct BitReader<'a> {
    bytes: &'a [u8],
    at: usize,
    what: &'static str,
}

impl<'a> BitReader<'a> {
    /// A reader over the field `what`.
    pub fn new(bytes: &'a [u8], what: &'static str) -> Self {
        Self { bytes, at: 0, what }
    }

    /// The next bit.
    #[inline]
    pub fn bit(&mut self) -> Result<bool, &'static str> {
        let byte = self.bytes.get(self.at / 8).ok_or(self.what)?;
        let b = byte >> (self.at % 8) & 1 == 1;
        self.at += 1;
        Ok(b)
    }

    /// Ok when every byte was used (the last one may be part padding, zeros).
    pub fn end(&self) -> Result<(), &'static str> {
        let used = self.at.div_ceil(8);
        let padding_clear = self.at % 8 == 0 || self.bytes.get(self.at / 8).is_some_and(|b| b >> (self.at % 8) == 0);
        if used == self.bytes.len() && padding_clear {
            Ok(())
        } else {
            Err(self.what)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_round_trip_and_the_end_is_checked() {
        let pattern = [true, false, true, true, false, false, false, true, true, false, true];
        let mut w = BitWriter::default();
        for b in pattern {
            w.bit(b);
        }
        assert_eq!(w.len(), 11);
        let bytes = w.finish();
        assert_eq!(bytes.len(), 2);
        let mut r = BitReader::new(&bytes, "test");
        for b in pattern {
            assert_eq!(r.bit().unwrap(), b);
        }
        r.end().unwrap();
        assert!(BitReader::new(&bytes, "test").end().is_err());
        let mut r = BitReader::new(&bytes, "test");
        for _ in 0..16 {
            r.bit().unwrap();
        }
        assert_eq!(r.bit(), Err("test"));
    }
}
