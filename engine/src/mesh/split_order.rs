//! The split vertices of the 4-8 hierarchy, level by level, in the order
//! the bottom-up pass takes them (DMesh Sec. 3, Fig. 1 and 3: every vertex
//! of the restricted quadtree bisects an edge, along a row, along a column
//! or a diagonal, and its two halves have apexes on either side).
//!
//! The pass's row loops (`levels.rs`, `coarse_rows.rs`) visit the same
//! vertices in the same order without this enumeration; the deviations of
//! the coarser levels (`coarse_deviations`) and the general kernel of the
//! tests walk it, and [`split_count`] sizes their arrays.

use super::grid::{Grid, Pt};
use super::small_half_sweep::Shape;

/// Which edge a split vertex bisects: Eq. 1 for diagonals, Eq. 2 in the
/// x,z-plane for an edge along a row and in the y,z-plane along a column.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Bisects {
    Diagonal,
    Row,
    Column,
}

impl Bisects {
    /// Length in pixels of the edge a split vertex of half-size `h` bisects.
    pub(super) fn hypotenuse(self, h: u32) -> f64 {
        f64::from(2 * h)
            * if self == Self::Diagonal {
                std::f64::consts::SQRT_2
            } else {
                1.0
            }
    }
}

/// A split vertex above level 0: `v` bisects `a-b`; `apex` are its halves'
/// apexes (`None` off the grid).
#[derive(Clone, Copy)]
pub(super) struct Split {
    pub(super) v: Pt,
    pub(super) a: Pt,
    pub(super) b: Pt,
    pub(super) apex: [Option<Pt>; 2],
    pub(super) bisects: Bisects,
}

impl Split {
    /// The split vertex `v` of half-size `h` that bisects an edge of kind
    /// `bisects`: the ends of that edge and its halves' apexes (a
    /// diagonal's ends alternate with the parity of `v`'s quad in each
    /// axis).
    #[inline(always)]
    pub(super) fn at(grid: Grid, v: Pt, h: u32, bisects: Bisects) -> Self {
        let (gw, gh) = (grid.gw(), grid.gh());
        let (x, y) = v;
        let (a, b, apex) = match bisects {
            Bisects::Row => (
                (x - h, y),
                (x + h, y),
                [(y >= h).then(|| (x, y - h)), (y + h < gh).then_some((x, y + h))],
            ),
            Bisects::Column => (
                (x, y - h),
                (x, y + h),
                [(x >= h).then(|| (x - h, y)), (x + h < gw).then_some((x + h, y))],
            ),
            Bisects::Diagonal => {
                let px = if ((x - h) / (2 * h)) % 2 == 1 { x - h } else { x + h };
                let py = if ((y - h) / (2 * h)) % 2 == 1 { y - h } else { y + h };
                let (qx, qy) = (2 * x - px, 2 * y - py);
                let apex = if px < qx {
                    [(px, qy), (qx, py)]
                } else {
                    [(qx, py), (px, qy)]
                };
                ((px, py), (qx, qy), apex.map(Some))
            }
        };
        Self { v, a, b, apex, bisects }
    }

    /// Half the length of the bisected edge along the grid axes.
    #[cfg(test)]
    pub(super) fn h(&self) -> u32 {
        self.a.0.abs_diff(self.b.0).max(self.a.1.abs_diff(self.b.1)) / 2
    }

    /// Its half with apex `apex` as a shape around `v`.
    pub(super) fn small_shape(&self, apex: Pt) -> Shape {
        let toward = |from: u32, to: u32| if to < from { -1 } else { 1 };
        match self.bisects {
            Bisects::Row => Shape::Edge {
                along_row: true,
                dir: toward(self.v.1, apex.1),
            },
            Bisects::Column => Shape::Edge {
                along_row: false,
                dir: toward(self.v.0, apex.0),
            },
            Bisects::Diagonal => Shape::Centre {
                sx: toward(self.v.0, apex.0),
                sy: toward(self.v.1, apex.1),
            },
        }
    }
}

/// The split vertices of the given levels (0 is the finest) in the order
/// the pass needs them: per level, the edge midpoints along rows, those
/// along columns, then the centres, each row by row ([`split_rows`]).
#[inline(always)]
pub(super) fn for_each_split(grid: Grid, levels: std::ops::Range<u32>, mut f: impl FnMut(Split)) {
    for g in levels {
        let h = 1u32 << g;
        for (bisects, y, xs) in split_rows(grid, g) {
            for x in xs {
                f(Split::at(grid, (x, y), h, bisects));
            }
        }
    }
}

/// The rows of split vertices of level `g` in [`for_each_split`]'s order:
/// each row's kind, grid row and columns.
#[inline(always)]
pub(super) fn split_rows(
    grid: Grid,
    g: u32,
) -> impl Iterator<Item = (Bisects, u32, std::iter::StepBy<std::ops::Range<u32>>)> {
    let (gw, gh) = (grid.gw(), grid.gh());
    let h = 1u32 << g;
    let step = 2 * h as usize;
    // Each kind's first row and column.
    [(Bisects::Row, 0, h), (Bisects::Column, h, 0), (Bisects::Diagonal, h, h)]
        .into_iter()
        .flat_map(move |(bisects, y0, x0)| {
            (y0..gh)
                .step_by(step)
                .map(move |y| (bisects, y, (x0..gw).step_by(step)))
        })
}

/// How many split vertices [`for_each_split`] visits on level `g` (and so
/// how many halves' pairs `coarse_deviations` gives), counted from its
/// ranges.
pub(crate) fn split_count(grid: Grid, g: u32) -> usize {
    let (gw, gh, h) = (grid.gw() as usize, grid.gh() as usize, 1usize << g);
    // Of `start, start + 2h, ...` below `end`.
    let steps = |start: usize, end: usize| end.saturating_sub(start).div_ceil(2 * h);
    // Edge midpoints along rows, along columns, then centres.
    steps(0, gh) * steps(h, gw) + steps(h, gh) * steps(0, gw) + steps(h, gh) * steps(h, gw)
}
