//! Bits packed least significant first into bytes, as the compact stream
//! (PROTOCOL.md, "Protocol 7": each field byte-aligned on its own, so a
//! general-purpose compressor sees like next to like) and the residual
//! codes (`residual.rs`) write them.

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

    /// The low `bits` bits of `value` (at most 32; the others must be 0),
    /// least significant first.
    #[inline]
    pub fn field(&mut self, value: u32, bits: u8) {
        debug_assert!(bits <= 32 && u64::from(value) >> bits == 0, "{value} in {bits} bits");
        let value = u64::from(value);
        // `filled` is below 64, so the shift keeps what fits in the word.
        self.acc |= value << self.filled;
        let room = 64 - self.filled;
        if u32::from(bits) < room {
            self.filled += u32::from(bits);
        } else {
            // The word is full (`room` is at most 32 here): the rest of the
            // field starts the next one.
            self.bytes.extend_from_slice(&self.acc.to_le_bytes());
            self.acc = value >> room;
            self.filled = u32::from(bits) - room;
        }
    }

    /// The low `n` bits of `value` (`n` at most 64; the others must be
    /// 0), least significant first.
    #[inline]
    pub fn bits(&mut self, value: u64, n: u32) {
        debug_assert!(n <= 64 && (n == 64 || value >> n == 0));
        if n > 32 {
            self.field(value as u32, 32);
            self.field((value >> 32) as u32, (n - 32) as u8);
        } else {
            self.field(value as u32, n as u8);
        }
    }

    /// The bits `other` holds, after these.
    pub fn append(&mut self, other: BitWriter) {
        for chunk in other.bytes.chunks_exact(8) {
            let mut word = [0u8; 8];
            word.copy_from_slice(chunk);
            self.bits(u64::from_le_bytes(word), 64);
        }
        self.bits(other.acc, other.filled);
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

    /// The next `bits` bits (at most 32) as a number, the first read the
    /// least significant.
    #[inline]
    pub fn field(&mut self, bits: u8) -> Result<u32, &'static str> {
        debug_assert!(bits <= 32);
        let end = self.at + usize::from(bits);
        if end > self.bytes.len() * 8 {
            return Err(self.what);
        }
        // The field lies within the five bytes from the one `at` is in.
        let first = self.at / 8;
        let mut word = [0u8; 8];
        let have = (self.bytes.len() - first).min(8);
        word[..have].copy_from_slice(&self.bytes[first..first + have]);
        let value = (u64::from_le_bytes(word) >> (self.at % 8)) & ((1u64 << bits) - 1);
        self.at = end;
        Ok(value as u32)
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

    /// Fields of every width at every offset read back as written, bit by
    /// bit too, and the bytes are those of the same bits one at a time.
    #[test]
    fn fields_round_trip_at_every_offset() {
        let mut fields = Vec::new();
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        for lead in 0..64u8 {
            fields.push((1u32 & u32::from(lead), 1u8));
            for bits in [0u8, 1, 2, 7, 8, 9, 15, 16, 17, 31, 32] {
                s = s
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                let value = if bits == 0 {
                    0
                } else {
                    (s >> 32) as u32 >> (32 - u32::from(bits))
                };
                fields.push((value, bits));
            }
        }
        let (mut w, mut one_by_one) = (BitWriter::default(), BitWriter::default());
        for &(value, bits) in &fields {
            w.field(value, bits);
            for i in 0..bits {
                one_by_one.bit(value >> i & 1 == 1);
            }
        }
        let bytes = w.finish();
        assert_eq!(bytes, one_by_one.finish());
        let mut r = BitReader::new(&bytes, "test");
        for &(value, bits) in &fields {
            assert_eq!(r.field(bits), Ok(value), "{bits} bits");
        }
        r.end().unwrap();
        assert_eq!(r.field(1), Err("test"));
    }
}
