//! Back-projection of grid samples, factored per row and column.
//!
//! `camera.rs` defines `x = ax + bx * z` per column and `y = ay + by * z` per
//! row; caching those four numbers per row and column makes a sample's 3D
//! point one multiply-add per axis.

use glam::DVec3;

use crate::camera::Camera;

/// Cached per-column and per-row back-projection factors of a grid.
#[derive(Clone, Debug)]
pub struct BackProject {
    /// `ax` and `bx` per column, apart: the row loops read them with plain
    /// vector loads (pairs would have to be pulled apart lane by lane).
    col_a: Vec<f64>,
    col_b: Vec<f64>,
    rows: Vec<(f64, f64)>,
}

impl BackProject {
    /// Factors for `gw` columns and `gh` rows (padding included).
    pub fn new(camera: &Camera, gw: u32, gh: u32) -> Self {
        let (col_a, col_b) = (0..gw).map(|u| camera.column_factors(f64::from(u))).unzip();
        Self {
            col_a,
            col_b,
            rows: (0..gh).map(|v| camera.row_factors(f64::from(v))).collect(),
        }
    }

    /// The camera-frame point of grid vertex `(x, y)` at depth `z`.
    #[inline]
    pub fn point(&self, x: u32, y: u32, z: f32) -> DVec3 {
        Self::point_from(self.col(x as usize), self.rows[y as usize], z)
    }

    /// The camera-frame point at depth `z` of the sample whose column
    /// factors are `(ax, bx)` ([`Self::col`]) and row factors `(ay, by)`
    /// ([`Self::row`]): for loops that hold a row's factors already.
    #[inline]
    pub fn point_from((ax, bx): (f64, f64), (ay, by): (f64, f64), z: f32) -> DVec3 {
        let z = f64::from(z);
        DVec3::new(ax + bx * z, ay + by * z, z)
    }

    /// `(ax, bx)` of column `x`: camera-frame `x = ax + bx * z`.
    #[inline]
    pub fn col(&self, x: usize) -> (f64, f64) {
        (self.col_a[x], self.col_b[x])
    }

    /// `ax` and `bx` of every column, as two slices.
    #[inline]
    pub fn cols(&self) -> (&[f64], &[f64]) {
        (&self.col_a, &self.col_b)
    }

    /// `(ay, by)` of row `y`: camera-frame `y = ay + by * z`.
    #[inline]
    pub fn row(&self, y: usize) -> (f64, f64) {
        self.rows[y]
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.col_a.capacity() + self.col_b.capacity()) * std::mem::size_of::<f64>()
            + self.rows.capacity() * std::mem::size_of::<(f64, f64)>()
    }
}
