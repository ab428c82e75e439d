//! Segmentation flags of the hierarchy and their propagation up it (DMesh
//! Sec. 5.3, Fig. 11-12).
//!
//! A hierarchy triangle is *segmented* when any full-resolution triangle
//! inside it is (it must not be drawn whole), and *fully* segmented when all
//! of them are (nothing of it is drawn). Both propagate bottom-up: a half of
//! a split vertex's diamond is the union of its two children, so its "any"
//! is the OR of theirs and its "all" the AND ([`Half::join`]). DMesh's eight
//! flags of a quadtree node are the half flags of the four edge midpoints
//! and the centre of that node.
//!
//! One byte per grid vertex ([`Flags`]): the two halves of the diamond the
//! vertex splits, and the two finest triangles of the unit cell whose min
//! corner it is (the leaves, from `segmentation.rs`).

/// The flags of one grid vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(transparent)]
pub(crate) struct Flags(u8);

/// What the flags say of one hierarchy triangle (a half of a diamond).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Half {
    /// Some full-resolution triangle inside is segmented.
    pub any: bool,
    /// Every full-resolution triangle inside is segmented.
    pub all: bool,
}

/// Two halves' bits ([`Flags::half_bits`]) joined ([`Half::join`]).
#[inline(always)]
pub(crate) const fn join_bits(a: u8, b: u8) -> u8 {
    (a | b) & 1 | a & b & 4
}

/// Two leaves' bits ([`Flags::leaf_bit`]) joined as the half they make.
#[inline(always)]
pub(crate) const fn join_leaves(a: u8, b: u8) -> u8 {
    a | b | (a & b) << 2
}

/// A vertex's flags from two halves' bits, with what the pass needs of
/// them: whether some half is unflagged (its geometric error counts) and
/// whether some is partly segmented, as 1 or 0 (for straight loops).
#[inline(always)]
pub(crate) const fn finish_halves(cells: Flags, h0: u8, h1: u8) -> (Flags, bool, u8) {
    let flags = cells.with_halves([h0, h1]);
    (flags, h0 & h1 & 1 == 0, (h0 == 1) as u8 | (h1 == 1) as u8)
}

impl Half {
    /// A half off the grid: nothing in it to draw, so it counts as fully
    /// segmented.
    pub const ABSENT: Self = Self { any: true, all: true };

    /// A full-resolution triangle, segmented or not (the tests' general
    /// kernel; the pass joins leaves as bits: [`join_leaves`]).
    #[cfg(test)]
    pub const fn leaf(segmented: bool) -> Self {
        Self {
            any: segmented,
            all: segmented,
        }
    }

    /// The union of two triangles: OR of "any", AND of "all".
    pub const fn join(self, other: Self) -> Self {
        Self {
            any: self.any || other.any,
            all: self.all && other.all,
        }
    }

    /// Nothing inside is segmented: its errors are the geometric ones.
    pub const fn unflagged(self) -> bool {
        !self.any
    }

    /// Segmented, but not fully: dropping it would drop valid samples, so its
    /// footprint counts as error.
    pub const fn partial(self) -> bool {
        self.any && !self.all
    }

    /// As bits for straight loops, as [`Flags::half_bits`] gives them:
    /// "any" in bit 0, "all" in bit 2.
    #[inline(always)]
    pub const fn bits(self) -> u8 {
        self.any as u8 | (self.all as u8) << 2
    }
}

impl Flags {
    const fn any_bit(h: usize) -> u8 {
        1 << h
    }

    const fn all_bit(h: usize) -> u8 {
        4 << h
    }

    const fn cell_bit(h: usize) -> u8 {
        16 << h
    }

    /// The flags of a vertex before the pass: its unit cell's two finest
    /// triangles, bit `h` of `cell` for half `h`.
    pub const fn of_cell(cell: u8) -> Self {
        Self((cell & 3) << 4)
    }

    /// The same with no half flags, to be set by [`Self::set_half`].
    pub const fn cell_only(self) -> Self {
        Self(self.0 & 0xf0)
    }

    /// True when the full-resolution triangle `h` of the vertex's unit cell is segmented.
    pub const fn cell(self, h: usize) -> bool {
        self.0 & Self::cell_bit(h) != 0
    }

    /// Half `h` of the diamond the vertex splits.
    pub const fn half(self, h: usize) -> Half {
        Half {
            any: self.0 & Self::any_bit(h) != 0,
            all: self.0 & Self::all_bit(h) != 0,
        }
    }

    /// Half `h`'s flags as bits for straight loops: "any" in bit 0, "all"
    /// in bit 2 (so two halves join as `(a | b) & 1 | a & b & 4`).
    #[inline(always)]
    pub const fn half_bits(self, h: usize) -> u8 {
        (self.0 >> h) & 5
    }

    /// The cell's flags with both halves' set from their bits (as
    /// [`Self::half_bits`] gives them).
    #[inline(always)]
    pub const fn with_halves(self, halves: [u8; 2]) -> Self {
        Self(self.0 & 0xf0 | halves[0] | halves[1] << 1)
    }

    /// Leaf `h` of the vertex's unit cell as a bit (1: segmented).
    #[inline(always)]
    pub const fn leaf_bit(self, h: usize) -> u8 {
        (self.0 >> (4 + h)) & 1
    }

    /// Whether some half is unflagged, and whether some is partly
    /// segmented ([`Half::unflagged`], [`Half::partial`]).
    #[inline(always)]
    pub const fn halves_unflagged_partial(self) -> (bool, bool) {
        let (h0, h1) = (self.half_bits(0), self.half_bits(1));
        (h0 & 1 == 0 || h1 & 1 == 0, h0 == 1 || h1 == 1)
    }

    /// Bit `h` set when half `h` is partly segmented ([`Half::partial`]):
    /// "any" without "all".
    #[inline(always)]
    pub const fn partial_halves(self) -> u8 {
        self.0 & !(self.0 >> 2) & 3
    }

    /// Sets half `h`'s flags (on flags whose half `h` is clear).
    pub fn set_half(&mut self, h: usize, half: Half) {
        debug_assert_eq!(self.0 & (Self::any_bit(h) | Self::all_bit(h)), 0, "half {h} set twice");
        if half.any {
            self.0 |= Self::any_bit(h);
        }
        if half.all {
            self.0 |= Self::all_bit(h);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_propagate_or_and_and_and_keep_the_cell_bits() {
        let (seg, free) = (Half::leaf(true), Half::leaf(false));
        assert_eq!(seg.join(free), Half { any: true, all: false });
        assert!(seg.join(free).partial() && !seg.join(seg).partial());
        assert!(free.join(free).unflagged() && !Half::ABSENT.unflagged());
        let mut f = Flags::of_cell(0b10).cell_only();
        assert!(!f.cell(0) && f.cell(1));
        f.set_half(0, seg.join(free));
        f.set_half(1, Half::ABSENT);
        assert_eq!(f.half(0), Half { any: true, all: false });
        assert_eq!(f.half(1), Half::ABSENT);
        assert!(f.cell(1) && !f.cell(0));
        // The byte layout the hierarchy has always had (16 bytes per vertex).
        assert_eq!(f.0, 0b10_1011);
        assert_eq!(std::mem::size_of::<Flags>(), 1);
    }

    #[test]
    fn the_bit_joins_are_the_halves_joins() {
        let halves = [
            Half::leaf(false),
            Half::leaf(true),
            Half { any: true, all: false },
            Half::ABSENT,
        ];
        for a in halves {
            for b in halves {
                assert_eq!(join_bits(a.bits(), b.bits()), a.join(b).bits(), "{a:?} {b:?}");
            }
        }
        for (a, b) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            let leaf = |bit: u8| Half::leaf(bit == 1);
            assert_eq!(join_leaves(a, b), leaf(a).join(leaf(b)).bits());
        }
        for byte in 0..=u8::MAX {
            let f = Flags(byte);
            assert_eq!(f.leaf_bit(0), u8::from(f.cell(0)));
            assert_eq!(f.leaf_bit(1), u8::from(f.cell(1)));
            for (h0, h1) in [(0, 5), (1, 0), (5, 5), (4, 1)] {
                let (flags, unflagged, partial) = finish_halves(f.cell_only(), h0, h1);
                assert_eq!(flags, f.cell_only().with_halves([h0, h1]));
                assert_eq!((unflagged, partial == 1), flags.halves_unflagged_partial());
            }
        }
    }

    #[test]
    fn partial_halves_are_the_halves_partly_segmented() {
        for byte in 0..=u8::MAX {
            let f = Flags(byte);
            let expected = (0..2).fold(0, |bits, h| bits | u8::from(f.half(h).partial()) << h);
            assert_eq!(f.partial_halves(), expected, "{byte:#010b}");
        }
    }
}
