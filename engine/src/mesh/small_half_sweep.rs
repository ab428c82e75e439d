//! The depth deviations of the halves of levels 1 to 3 (half-size `H` = 2,
//! 4 and 8: 98 in 100 of the halves a build scans), a level at a time in
//! f32, sixteen split vertices per step, within `deviation_f32.rs`'s margin
//! above the exact f64 scan (`deviation.rs`'s [`small_half_deviation`], the
//! oracle in the tests and the fallback for extreme depths).
//!
//! The vertices of one kind on one row of a level lie `2H` apart, so their
//! samples at one offset are a strided gather in the depth rows. The sweep
//! first splits each row into 32 *phase planes*, plane `m` holding the
//! samples whose column is `m` modulo 32 (one set for the three levels,
//! built for a band of 32 rows and a halo at a time, so the band's depths
//! are still in cache when its vertices read them); the vertices of a row
//! whose index is one class modulo `32 / 2H` then find their samples
//! at one offset in sixteen consecutive values of one plane row, and
//! sixteen vertices are one step ([`LANES`]). The classes also make each
//! step's centres one shape: a centre's diagonal turns from one to the
//! next.
//!
//! The lanes' code is plain loops over arrays and `#[inline(always)]`
//! functions, no closures or `std::array::from_fn`: inside the AVX2
//! dispatch (`crate::simd`) whatever the compiler keeps apart runs without
//! the features, which cost this sweep half its speed when it did.
//!
//! Each lane does [`half_worst`]'s arithmetic, the same the general kernel
//! runs on one half at a time (`N = 1`, [`small_half_deviation_f32`]), so
//! the pass gets the same bits with or without the sweep. The interpolant
//! is all f32: for an edge midpoint's half `mid + r rise + k g` (`mid = (z_a
//! + z_b) / 2`, `g = (z_b - z_a) / 2H`, `rise = (z_c - mid) / H`, row `r` from
//! the edge, `k` along it), for a centre's `z_c + w g_w + u g_u` (legs `u`,
//! `w` from the apex). Divisions are by powers of two. With `u = 2^-24` and
//! `Z` the largest corner depth, an edge's interpolant is off by at most
//! `u Z` (`mid`) + `u Z` (`g` times `k <= H`) + `3 u Z` (`rise`, through
//! `mid`, times `r <= H`) + `2 u Z` + `u Z` (the product `r rise` and the
//! sum) + `u Z` + `u Z` (`k g` and the sum): `10 u Z`; a centre's by
//! `2 + 2` (the two gradients times legs up to `2H`) `+ 2 + 1 + 2 + 1`: also
//! `10 u Z`, within the margin's `16 u Z`. Level corners give an exact
//! interpolant (`mid = z`, `g = rise = 0`).

use super::deviation::{small_half_deviation, SmallHalf};
use super::deviation_f32::{in_f32_range, widen};
use super::grid::Grid;
use super::levels::round_up;

/// A half of levels 1 to 3 around its split vertex `v`, as offsets
/// `(dy, dx)` from `v`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Shape {
    /// An edge midpoint's half: the bisected edge along a row
    /// (`along_row`) or a column, the apex `H` away across it on the side
    /// `dir` (-1 or 1).
    Edge { along_row: bool, dir: isize },
    /// A centre's half: the apex (its right angle) at `(sy H, sx H)`.
    Centre { sx: isize, sy: isize },
}

impl Shape {
    /// The same half in `deviation.rs`'s terms, for the split vertex at
    /// flat index `v` of rows `gw` long.
    fn small_half<const H: isize>(self, gw: isize, v: isize) -> SmallHalf {
        match self {
            Shape::Edge { along_row, dir } => {
                let (along, across) = if along_row { (1, dir * gw) } else { (gw, dir) };
                SmallHalf::Edge {
                    v,
                    along,
                    across,
                    apex: v + H * across,
                }
            }
            Shape::Centre { sx, sy } => SmallHalf::Centre {
                apex: v + H * (sy * gw + sx),
                su: -sx,
                sw: -sy * gw,
            },
        }
    }
}

/// The largest of `worst` and `|s - lin|`, lane by lane.
#[inline(always)]
fn visit<const N: usize>(worst: &mut [f32; N], s: [f32; N], lin: [f32; N]) {
    for l in 0..N {
        let d = (s[l] - lin[l]).abs();
        worst[l] = if d > worst[l] { d } else { worst[l] };
    }
}

/// `a + t * b`, lane by lane.
#[inline(always)]
fn along<const N: usize>(a: [f32; N], t: isize, b: [f32; N]) -> [f32; N] {
    let mut out = a;
    for l in 0..N {
        out[l] = a[l] + t as f32 * b[l];
    }
    out
}

/// `(b - a) / d`, lane by lane (`d` a power of two).
#[inline(always)]
fn slope<const N: usize>(a: [f32; N], b: [f32; N], d: isize) -> [f32; N] {
    let mut out = a;
    for l in 0..N {
        out[l] = (b[l] - a[l]) / d as f32;
    }
    out
}

/// The f32 scan of a half of half-size `H` in `N` lanes, `at(dy, dx)`
/// giving each lane's depth at that offset from its split vertex: the
/// largest `|z - z_lin|` and the three corner depths, per lane. Plain
/// loops and functions, no closures: this runs inside the AVX2 dispatch,
/// where a closure the compiler keeps apart loses the features
/// (`crate::simd`).
#[inline(always)]
pub(crate) fn half_worst<const H: isize, const N: usize>(
    shape: Shape,
    at: impl Fn(isize, isize) -> [f32; N],
) -> ([f32; N], [[f32; N]; 3]) {
    let mut worst = [0f32; N];
    match shape {
        Shape::Edge { along_row, dir } => {
            // Row `r` from the edge, `k` along it.
            let (sr, sk) = if along_row {
                ((dir, 0), (0, 1))
            } else {
                ((0, dir), (1, 0))
            };
            #[inline(always)]
            fn pos((sr, sk): ((isize, isize), (isize, isize)), r: isize, k: isize) -> (isize, isize) {
                (r * sr.0 + k * sk.0, r * sr.1 + k * sk.1)
            }
            let pos = |r, k| pos((sr, sk), r, k);
            let (a, b, c) = (pos(0, -H), pos(0, H), pos(H, 0));
            let (za, zb, zc) = (at(a.0, a.1), at(b.0, b.1), at(c.0, c.1));
            let mut mid = za;
            for l in 0..N {
                mid[l] = 0.5 * (za[l] + zb[l]);
            }
            let g = slope(za, zb, 2 * H);
            let rise = slope(mid, zc, H);
            for r in 0..H + 1 {
                let base = along(mid, r, rise);
                for k in r - H..H - r + 1 {
                    let (dy, dx) = pos(r, k);
                    visit(&mut worst, at(dy, dx), along(base, k, g));
                }
            }
            (worst, [za, zb, zc])
        }
        Shape::Centre { sx, sy } => {
            // The apex, the corner on its row and the one on its column.
            let (zc, z1, z2) = (at(sy * H, sx * H), at(sy * H, -sx * H), at(-sy * H, sx * H));
            let gu = slope(zc, z1, 2 * H);
            let gw = slope(zc, z2, 2 * H);
            for w in 0..2 * H + 1 {
                let base = along(zc, w, gw);
                for u in 0..2 * H - w + 1 {
                    visit(&mut worst, at(sy * (H - w), sx * (H - u)), along(base, u, gu));
                }
            }
            (worst, [zc, z1, z2])
        }
    }
}

/// The squared deviations, rounded up, of `N` lanes' halves from the f32
/// scan's `worst` and corner depths, widened by the margin, and whether
/// each lane's corners are in f32's range: where not, its value stands for
/// nothing and the caller scans the half in f64 ([`in_f64`]). Straight
/// code over the lanes, so it widens too.
#[inline(always)]
fn squared<const N: usize>(worst: [f32; N], corners: [[f32; N]; 3]) -> ([f32; N], [bool; N]) {
    let (mut out, mut in_range) = ([0f32; N], [false; N]);
    for l in 0..N {
        let lane = [corners[0][l], corners[1][l], corners[2][l]];
        let d = widen(worst[l], lane);
        out[l] = round_up(d * d);
        in_range[l] = in_f32_range(lane);
    }
    (out, in_range)
}

/// The squared exact deviation, rounded up, of the half `shape` of the
/// split vertex at flat index `v`, scanned in f64.
fn in_f64<const H: isize>(z: &[f32], gw: usize, v: usize, shape: Shape) -> f32 {
    let d = small_half_deviation::<H>(z, shape.small_half::<H>(gw as isize, v as isize));
    round_up(d * d)
}

/// The squared deviation, rounded up, of the half `shape` of the split
/// vertex at flat index `v`: one lane of the sweep.
#[inline(always)]
pub(crate) fn small_half_deviation2<const H: isize>(z: &[f32], gw: usize, v: usize, shape: Shape) -> f32 {
    let (vi, gwi) = (v as isize, gw as isize);
    let (worst, corners) = half_worst::<H, 1>(
        shape,
        #[inline(always)]
        |dy, dx| [z[(vi + dy * gwi + dx) as usize]],
    );
    match squared(worst, corners) {
        ([d], [true]) => d,
        _ => in_f64::<H>(z, gw, v, shape),
    }
}

/// The squared deviations, rounded up, of both halves of every split
/// vertex of levels 1 to 3 (those the grid has), in [`super::levels`]'s
/// order (`for_each_split`), into `out[0]`, `out[1]` and `out[2]`
/// (whatever they held): 0 where a half does not exist. Halves with
/// invalid samples get a finite value too, which the pass ignores. Band by
/// band of [`BAND`] rows, the three levels from one band's planes while its
/// depths are in cache.
#[inline(always)]
pub(crate) fn small_level_deviations(grid: Grid, z: &[f32], out: [&mut Vec<[f32; 2]>; 3]) {
    let [one, two, three] = out;
    let levels = grid.k.saturating_sub(1).min(3);
    for (g, out) in (1..=3).zip([&mut *one, &mut *two, &mut *three]) {
        out.clear();
        if g <= levels {
            out.resize(super::split_order::split_count(grid, g), [0.0; 2]);
        }
    }
    if levels == 0 {
        return;
    }
    let gh = grid.gh() as usize;
    let mut planes = Planes::with_capacity(grid);
    for y0 in (0..gh).step_by(BAND) {
        planes.fill(grid, z, y0);
        sweep::<2>(&planes, grid, z, y0, one);
        if levels >= 2 {
            sweep::<4>(&planes, grid, z, y0, two);
        }
        if levels == 3 {
            sweep::<8>(&planes, grid, z, y0, three);
        }
    }
}

/// Grid rows per band: a multiple of the levels' row steps (4, 8 and 16).
const BAND: usize = 32;

/// Rows a band's planes hold beyond it on either side: the largest
/// half-size.
const HALO: usize = 8;

/// Bytes of scratch [`small_level_deviations`] holds while it runs.
pub(crate) fn scratch_bytes(grid: Grid) -> usize {
    if grid.k > 1 {
        (BAND + 2 * HALO) * BIG * Planes::width(grid) * std::mem::size_of::<f32>()
    } else {
        0
    }
}

/// Split vertices swept per step: sixteen, one AVX-512 vector of f32
/// (two AVX2 vectors, which lose nothing by it). Eight, one AVX2 vector,
/// took 0.25 ms more of the coarse stage at 513 x 513 on one thread on an
/// AVX-512 Xeon (`profile_build 513 80 1 alternate`: 3.71 against 3.45 ms
/// with AVX-512, 3.98 against 3.83 with AVX2).
const LANES: usize = 16;

/// Columns apart of the values in one phase plane: a multiple of the
/// levels' `4H`, so one set of planes serves all three.
const BIG: usize = 32;

/// The phase planes of one band of the depths (see the module doc): plane
/// `m` (of [`BIG`]) of grid row `y` at `(((y - first) * BIG + m) * width + 1
/// + j)` holds column `m + BIG j`, with a zero before and zeros after.
struct Planes {
    values: Vec<f32>,
    width: usize,
    /// The grid row of the first row held.
    first: usize,
}

impl Planes {
    /// Values in a plane row: its columns, a zero before, and room for the
    /// last step's lanes (a step starts at a multiple of [`LANES`] below
    /// the columns and reads up to two columns on).
    fn width(grid: Grid) -> usize {
        let columns = (grid.gw() as usize - 1) / BIG + 1;
        (columns - 1) / LANES * LANES + LANES + 2
    }

    fn with_capacity(grid: Grid) -> Self {
        let width = Self::width(grid);
        Self {
            values: vec![0f32; (BAND + 2 * HALO) * BIG * width],
            width,
            first: 0,
        }
    }

    /// Holds the rows of the band from grid row `y0`, with its halo.
    #[inline(always)]
    fn fill(&mut self, grid: Grid, z: &[f32], y0: usize) {
        let (gw, gh) = (grid.gw() as usize, grid.gh() as usize);
        self.first = y0.saturating_sub(HALO);
        let last = (y0 + BAND + HALO).min(gh);
        let width = self.width;
        for (y, row) in z.chunks_exact(gw).enumerate().take(last).skip(self.first) {
            // Column `m + BIG j` is value `m` of the row's `j`-th group of
            // `BIG`: read so, the loop is a load and a store per value (a
            // `step_by` over the row cost four times that).
            let groups = row.chunks_exact(BIG);
            let rest = groups.remainder();
            for m in 0..BIG.min(gw) {
                let plane = &mut self.values[((y - self.first) * BIG + m) * width + 1..][..width - 1];
                for (d, group) in plane.iter_mut().zip(groups.clone()) {
                    *d = group[m];
                }
                if let (Some(d), Some(&s)) = (plane.get_mut(groups.len()), rest.get(m)) {
                    *d = s;
                }
            }
        }
    }

    /// The [`LANES`] values from vertex `j0` of the vertices at columns
    /// `x0 + BIG j`, at offset `dx` and grid row `y`.
    #[inline(always)]
    fn load(&self, y: usize, x0: usize, dx: isize, j0: usize) -> [f32; LANES] {
        let c = x0 as isize + dx;
        let big = BIG as isize;
        let (m, off) = (c.rem_euclid(big) as usize, (c.div_euclid(big) + 1) as usize);
        let start = ((y - self.first) * BIG + m) * self.width + j0 + off;
        self.values[start..start + LANES].try_into().unwrap_or([0.0; LANES])
    }
}

/// One row of split vertices of a kind, for [`sweep`].
struct Row {
    /// Its grid row.
    y: usize,
    /// Vertices on it.
    n: usize,
    /// Column of the first; the others `2H` apart.
    x: usize,
    /// Each half's shape, for even and for odd vertices.
    shapes: [[Shape; 2]; 2],
    /// Whether each half can exist on this row (an edge along a row's
    /// halves above and below).
    rows: [bool; 2],
    /// Whether each half exists at the first and the last vertex (an edge
    /// along a column's halves left and right).
    ends: [bool; 2],
}

/// The rows of one level (half-size `H`, 2 or 4) in the band from grid row
/// `y0`, each written where `for_each_split` puts it in `out`: edge
/// midpoints along rows, along columns, then centres.
#[inline(always)]
fn sweep<const H: isize>(planes: &Planes, grid: Grid, z: &[f32], y0: usize, out: &mut [[f32; 2]]) {
    let (gw, gh) = (grid.gw() as usize, grid.gh() as usize);
    let (h, s) = (H as usize, 2 * H as usize);
    let end = (y0 + BAND).min(gh);
    let edge = |along_row, dir| Shape::Edge { along_row, dir };
    let (along_rows, along_columns) = ((gw - 1) / s, (gw - 1) / s + 1);
    // Rows of each kind, and where each kind's pairs start.
    let (edge_rows, other_rows) = ((gh - 1) / s + 1, (gh - 1) / s);
    let columns_at = edge_rows * along_rows;
    let centres_at = columns_at + other_rows * along_columns;
    for y in (y0..end).step_by(s) {
        let row = Row {
            y,
            n: along_rows,
            x: h,
            shapes: [[edge(true, -1), edge(true, 1)]; 2],
            rows: [y >= h, y + h < gh],
            ends: [true; 2],
        };
        let at = y / s * along_rows;
        emit::<H>(planes, z, gw, &mut out[at..at + along_rows], row);
    }
    for y in (y0 + h..end).step_by(s) {
        let row = Row {
            y,
            n: along_columns,
            x: 0,
            shapes: [[edge(false, -1), edge(false, 1)]; 2],
            rows: [true; 2],
            ends: [false; 2],
        };
        let at = columns_at + (y - h) / s * along_columns;
        emit::<H>(planes, z, gw, &mut out[at..at + along_columns], row);
    }
    for y in (y0 + h..end).step_by(s) {
        // A centre's diagonal runs along the main diagonal where its
        // column's and row's parities (in steps of 2H) agree: the apexes
        // are then at lower left and upper right, else upper left and
        // lower right (half 0 is the one with the smaller x).
        let main = [Shape::Centre { sx: -1, sy: 1 }, Shape::Centre { sx: 1, sy: -1 }];
        let anti = [Shape::Centre { sx: -1, sy: -1 }, Shape::Centre { sx: 1, sy: 1 }];
        let odd_row = ((y - h) / s) % 2 == 1;
        let row = Row {
            y,
            n: along_rows,
            x: h,
            shapes: if odd_row { [anti, main] } else { [main, anti] },
            rows: [true; 2],
            ends: [true; 2],
        };
        let at = centres_at + (y - h) / s * along_rows;
        emit::<H>(planes, z, gw, &mut out[at..at + along_rows], row);
    }
}

/// One row's pairs into `out`: the vertices of each class (their index
/// modulo `BIG / 2H`) [`LANES`] at a time, class by class.
#[inline(always)]
fn emit<const H: isize>(planes: &Planes, z: &[f32], gw: usize, out: &mut [[f32; 2]], row: Row) {
    let s = 2 * H as usize;
    let classes = BIG / s;
    for class in 0..classes {
        let count = (row.n + classes - 1 - class) / classes;
        let x0 = row.x + s * class;
        for j0 in (0..count).step_by(LANES) {
            let lanes = (count - j0).min(LANES);
            let mut pairs = [[0f32; 2]; LANES];
            for half in 0..2 {
                if !row.rows[half] {
                    continue;
                }
                let shape = row.shapes[class % 2][half];
                let (worst, corners) = half_worst::<H, LANES>(
                    shape,
                    #[inline(always)]
                    |dy, dx| planes.load((row.y as isize + dy) as usize, x0, dx, j0),
                );
                let (wide, in_range) = squared(worst, corners);
                for (pair, d) in pairs.iter_mut().zip(wide) {
                    pair[half] = d;
                }
                // The half off the grid at a row's end (an edge along a
                // column's first and last vertices) is 0.
                let end = if half == 0 { 0 } else { row.n - 1 };
                let off = (!row.ends[half] && end % classes == class)
                    .then(|| (end / classes).wrapping_sub(j0))
                    .filter(|&l| l < lanes);
                if let Some(l) = off {
                    pairs[l][half] = 0.0;
                }
                // Lanes out of f32's range, scanned in f64 (rare).
                if !in_range[..lanes].iter().all(|&ok| ok) {
                    for l in (0..lanes).filter(|&l| !in_range[l] && Some(l) != off) {
                        let v = row.y * gw + row.x + s * (classes * (j0 + l) + class);
                        pairs[l][half] = in_f64::<H>(z, gw, v, shape);
                    }
                }
            }
            for (l, pair) in pairs.into_iter().enumerate().take(lanes) {
                out[classes * (j0 + l) + class] = pair;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// One half at a time (`N = 1`), the f32 scan is never below the
        /// exact f64 scan and above it by at most the margin, for every
        /// shape of the three levels, over ramps with noise, jumps and depths
        /// from 1e-25 to 1e25; with `zero_corners`, every corner invalid
        /// (depth 0) around valid samples, which the f32 scan takes too.
        #[test]
        fn a_small_half_in_f32_bounds_the_f64_scan_within_the_margin(
            (seed, scale, slope, noise, jump) in super::super::deviation_f32::tests::rough(),
            zero_corners in any::<bool>(),
        ) {
            use super::super::deviation_f32::tests::rough_depths;
            use super::super::deviation_f32::{MARGIN, RELATIVE};
            let gw = 17usize;
            let mut z = rough_depths(gw, seed, scale, slope, noise, jump);
            if zero_corners {
                // The halves' corners lie two, four or eight from v = (8, 8).
                for (i, z) in z.iter_mut().enumerate() {
                    if (i % gw) % 2 == 0 && (i / gw) % 2 == 0 {
                        *z = 0.0;
                    }
                }
            }
            let v = 8 * gw + 8;
            let shapes = [
                Shape::Edge { along_row: true, dir: -1 },
                Shape::Edge { along_row: true, dir: 1 },
                Shape::Edge { along_row: false, dir: -1 },
                Shape::Edge { along_row: false, dir: 1 },
                Shape::Centre { sx: -1, sy: -1 },
                Shape::Centre { sx: -1, sy: 1 },
                Shape::Centre { sx: 1, sy: -1 },
                Shape::Centre { sx: 1, sy: 1 },
            ];
            for shape in shapes {
                for (fast, exact, corners) in [
                    (
                        small_half_deviation2::<2>(&z, gw, v, shape),
                        small_half_deviation::<2>(&z, shape.small_half::<2>(gw as isize, v as isize)),
                        corners::<2>(&z, gw, v, shape),
                    ),
                    (
                        small_half_deviation2::<4>(&z, gw, v, shape),
                        small_half_deviation::<4>(&z, shape.small_half::<4>(gw as isize, v as isize)),
                        corners::<4>(&z, gw, v, shape),
                    ),
                    (
                        small_half_deviation2::<8>(&z, gw, v, shape),
                        small_half_deviation::<8>(&z, shape.small_half::<8>(gw as isize, v as isize)),
                        corners::<8>(&z, gw, v, shape),
                    ),
                ] {
                    let zmax = f64::from(corners.into_iter().fold(0f32, f32::max));
                    prop_assert!(fast.is_finite());
                    // Squared and rounded up to f32, as the build stores
                    // them (which loses the smallest depths' deviations to
                    // f32's range, upwards).
                    prop_assert!(fast >= round_up(exact * exact), "{:?}: {} below {}", shape, fast, exact);
                    let bound = exact * (1.0 + 2.0 * RELATIVE) + 2.0 * MARGIN * zmax;
                    prop_assert!(fast <= round_up(bound * bound), "{:?}: {} against {}", shape, fast, exact);
                }
            }
        }
    }

    /// The three corner depths of a half.
    fn corners<const H: isize>(z: &[f32], gw: usize, v: usize, shape: Shape) -> [f32; 3] {
        let (vi, gwi) = (v as isize, gw as isize);
        half_worst::<H, 1>(shape, |dy, dx| [z[(vi + dy * gwi + dx) as usize]])
            .1
            .map(|c| c[0])
    }

    /// The sweep gives, for every half of the three levels, the bits of the
    /// one-half scan, on grids padded or not, with holes; with `extreme`,
    /// depths also beyond f32's range for the scan in places (1e25 on the
    /// left, 1e-25 on every third row), whose halves go to the f64 scan.
    #[test]
    fn the_sweep_gives_each_halfs_bits() {
        let sizes = [(33u32, 33u32), (40, 17), (3, 7), (70, 45), (257, 130), (300, 21)];
        for ((w, h), extreme) in sizes.into_iter().flat_map(|s| [(s, false), (s, true)]) {
            let grid = Grid::for_image(w, h);
            let (gw, gh) = (grid.gw() as usize, grid.gh() as usize);
            let z: Vec<f32> = (0..gw * gh)
                .map(|i| {
                    let (x, y) = ((i % gw) as f32, (i / gw) as f32);
                    let scale = match (extreme, x < w as f32 / 3.0, (i / gw) % 3 == 0) {
                        (false, _, _) => 1.0,
                        (true, true, _) => 1e25,
                        (true, false, true) => 1e-25,
                        (true, false, false) => 1.0,
                    };
                    if (x as u32 + 3 * y as u32) % 11 == 0 || x as u32 >= w || y as u32 >= h {
                        0.0
                    } else {
                        scale * (2.0 + 0.3 * (0.7 * x).sin() + 0.01 * y * y)
                    }
                })
                .collect();
            let (mut level1, mut level2, mut level3) = (Vec::new(), Vec::new(), Vec::new());
            small_level_deviations(grid, &z, [&mut level1, &mut level2, &mut level3]);
            for (g, swept) in (1..grid.k.min(4)).zip([level1, level2, level3]) {
                let mut one = Vec::new();
                super::super::split_order::for_each_split(grid, g..g + 1, |s| {
                    let v = s.v.1 as usize * gw + s.v.0 as usize;
                    let pair = s.apex.map(|a| {
                        a.map_or(0.0, |apex| {
                            let shape = s.small_shape(apex);
                            match g {
                                1 => small_half_deviation2::<2>(&z, gw, v, shape),
                                2 => small_half_deviation2::<4>(&z, gw, v, shape),
                                _ => small_half_deviation2::<8>(&z, gw, v, shape),
                            }
                        })
                    });
                    one.push(pair);
                });
                assert_eq!(swept, one, "{w} x {h}, level {g}, extreme {extreme}");
            }
        }
    }
}
