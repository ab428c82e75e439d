//! Adaptive remeshing by shortest-edge collapse: Naik Sec. 5.2.2 (after
//! Hoppe's edge collapse, the thesis's reference [30], as MATLAB's built-in
//! reduction runs it). From the full-resolution mesh, the shortest edge in
//! space is collapsed to its midpoint, the faces that shared it are removed
//! and the lengths of the edges around the new vertex are updated, until
//! the triangle target is met.
//!
//! What keeps the result a valid triangulation of the image, which the
//! thesis leaves to MATLAB:
//! - the link condition: the two end points may share no neighbour but the
//!   apexes of the faces on the edge, else the collapse is skipped (it would
//!   make the mesh non-manifold);
//! - no fold-over: every face that moves must keep its orientation, and a
//!   nonzero area, in the reference image;
//! - borders keep their shape: an edge from a border vertex to an interior
//!   one collapses onto the border vertex, an interior edge between two
//!   border vertices is not collapsed, and the image's corners never move.
//!
//! Vertices are kept in camera space; the midpoint of two points of a
//! surface is projected back into the reference image for its pixel, so
//! vertices leave the sample grid.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::DVec3;

use super::{full_mesh, Knob, Mesher, TriMesh};
use crate::camera::Camera;
use crate::error::Result;
use crate::image::DepthImage;

/// Shortest-edge collapse to the midpoint.
#[derive(Clone, Copy, Debug, Default)]
pub struct Remesh;

/// A queued edge: squared length (its bits, which order like the value for
/// non-negative floats), end points and their versions when queued.
type Entry = Reverse<(u64, u32, u32, u32, u32)>;

struct State {
    points: Vec<DVec3>,
    pixels: Vec<[f64; 2]>,
    version: Vec<u32>,
    gone: Vec<bool>,
    /// An image corner: never moves.
    pinned: Vec<bool>,
    faces: Vec<[u32; 3]>,
    live: Vec<bool>,
    around: Vec<Vec<u32>>,
    heap: BinaryHeap<Entry>,
}

impl State {
    fn push(&mut self, a: u32, b: u32) {
        let d = (self.points[a as usize] - self.points[b as usize]).length_squared();
        self.heap.push(Reverse((
            d.to_bits(),
            a,
            b,
            self.version[a as usize],
            self.version[b as usize],
        )));
    }

    /// Live faces around `v`.
    fn faces_of(&self, v: u32) -> impl Iterator<Item = u32> + '_ {
        self.around[v as usize]
            .iter()
            .copied()
            .filter(|&f| self.live[f as usize])
    }

    /// Neighbours of `v` with the number of live faces on each edge.
    fn neighbours(&self, v: u32) -> Vec<(u32, u32)> {
        let mut out: Vec<(u32, u32)> = Vec::new();
        for f in self.faces_of(v) {
            for &n in &self.faces[f as usize] {
                if n == v {
                    continue;
                }
                match out.iter_mut().find(|(m, _)| *m == n) {
                    Some(e) => e.1 += 1,
                    None => out.push((n, 1)),
                }
            }
        }
        out
    }

    /// Signed area of face `f` in the image with vertex `from` moved to `to`.
    fn area_with(&self, f: u32, from: [u32; 2], to: [f64; 2]) -> f64 {
        let p = self.faces[f as usize].map(|i| if from.contains(&i) { to } else { self.pixels[i as usize] });
        (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0])
    }

    /// Collapses edge `a`-`b` into `a` if that keeps a valid triangulation;
    /// returns the faces removed.
    fn collapse(&mut self, a: u32, b: u32, camera: &Camera) -> usize {
        let shared: Vec<u32> = self
            .faces_of(a)
            .filter(|&f| self.faces[f as usize].contains(&b))
            .collect();
        if shared.is_empty() {
            return 0;
        }
        let (na, nb) = (self.neighbours(a), self.neighbours(b));
        // Link condition: common neighbours are exactly the apexes of the shared faces.
        let apexes = shared.len();
        let common = na.iter().filter(|(n, _)| nb.iter().any(|(m, _)| m == n)).count();
        if common != apexes {
            return 0;
        }
        let border = |ns: &[(u32, u32)]| ns.iter().any(|&(_, k)| k == 1);
        let (border_a, border_b) = (border(&na), border(&nb));
        if apexes == 2 && border_a && border_b {
            return 0;
        }
        let (ua, ub) = (a as usize, b as usize);
        let rank = |pinned: bool, border: bool| 2 * u8::from(pinned) + u8::from(border);
        let (ra, rb) = (rank(self.pinned[ua], border_a), rank(self.pinned[ub], border_b));
        let (point, pixel) = match ra.cmp(&rb) {
            std::cmp::Ordering::Greater => (self.points[ua], self.pixels[ua]),
            std::cmp::Ordering::Less => (self.points[ub], self.pixels[ub]),
            std::cmp::Ordering::Equal if self.pinned[ua] => return 0,
            std::cmp::Ordering::Equal => {
                let mid = 0.5 * (self.points[ua] + self.points[ub]);
                match camera.project(mid) {
                    Some((u, v, _)) => (mid, [u, v]),
                    None => return 0,
                }
            }
        };
        // No face may flip or flatten in the image.
        let moving: Vec<u32> = self
            .faces_of(a)
            .chain(self.faces_of(b))
            .filter(|f| !shared.contains(f))
            .collect();
        for &f in &moving {
            let before = self.area_with(f, [u32::MAX; 2], [0.0; 2]);
            let after = self.area_with(f, [a, b], pixel);
            if before * after <= 0.0 || after.abs() < 1e-9 {
                return 0;
            }
        }
        for &f in &shared {
            self.live[f as usize] = false;
        }
        let from_b: Vec<u32> = self.faces_of(b).collect();
        for f in from_b {
            for i in &mut self.faces[f as usize] {
                if *i == b {
                    *i = a;
                }
            }
            self.around[ua].push(f);
        }
        self.around[ub] = Vec::new();
        self.gone[ub] = true;
        let live = &self.live;
        self.around[ua].retain(|&f| live[f as usize]);
        self.points[ua] = point;
        self.pixels[ua] = pixel;
        self.pinned[ua] |= self.pinned[ub];
        self.version[ua] += 1;
        for (n, _) in self.neighbours(a) {
            self.push(a, n);
        }
        shared.len()
    }
}

impl Mesher for Remesh {
    fn name(&self) -> &'static str {
        "remesh"
    }

    fn knob_name(&self) -> String {
        "triangles".into()
    }

    fn knob(&self, _depth: &DepthImage) -> Knob {
        Knob::Triangles
    }

    fn mesh(&self, depth: &DepthImage, camera: &Camera, triangles: f64) -> Result<TriMesh> {
        let full = full_mesh(depth);
        let (w, h) = (depth.width as f32 - 1.0, depth.height as f32 - 1.0);
        let n = full.vertices.len();
        let mut s = State {
            points: full
                .vertices
                .iter()
                .map(|&[u, v, z]| camera.back_project(f64::from(u), f64::from(v), f64::from(z)))
                .collect(),
            pixels: full
                .vertices
                .iter()
                .map(|&[u, v, _]| [f64::from(u), f64::from(v)])
                .collect(),
            version: vec![0; n],
            gone: vec![false; n],
            pinned: full
                .vertices
                .iter()
                .map(|&[u, v, _]| (u == 0.0 || u == w) && (v == 0.0 || v == h))
                .collect(),
            live: vec![true; full.triangles.len()],
            around: vec![Vec::new(); n],
            faces: full.triangles,
            heap: BinaryHeap::new(),
        };
        for (f, t) in s.faces.iter().enumerate() {
            for &i in t {
                s.around[i as usize].push(f as u32);
            }
        }
        for f in 0..s.faces.len() {
            let t = s.faces[f];
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                // Each interior edge is in two faces: queue it once.
                if a < b || !s.faces_of(a).any(|g| g != f as u32 && s.faces[g as usize].contains(&b)) {
                    s.push(a, b);
                }
            }
        }
        let target = triangles.max(1.0) as usize;
        let mut count = s.faces.len();
        while count > target {
            let Some(Reverse((_, a, b, va, vb))) = s.heap.pop() else {
                break;
            };
            let (ua, ub) = (a as usize, b as usize);
            if s.gone[ua] || s.gone[ub] || s.version[ua] != va || s.version[ub] != vb {
                continue;
            }
            count -= s.collapse(a, b, camera);
        }
        let vertices = s
            .points
            .iter()
            .zip(&s.pixels)
            .map(|(p, &[u, v])| [(u as f32).clamp(0.0, w), (v as f32).clamp(0.0, h), p.z as f32])
            .collect();
        let triangles = s
            .faces
            .iter()
            .zip(&s.live)
            .filter(|(_, &live)| live)
            .map(|(t, _)| *t)
            .collect();
        Ok(TriMesh { vertices, triangles }.compact())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn meets_rates_is_valid_and_exact_on_planes() {
        super::super::tests::check_mesher(&Remesh, true, &[5.0, 20.0]);
    }

    #[test]
    fn one_collapse_removes_the_two_faces_of_its_edge_and_keeps_the_image_covered() {
        let camera = Camera::orthographic(4, 3, 1.0, 1.0, 0.0, 0.0).unwrap();
        let depth = DepthImage::from_z(4, 3, vec![1.0; 12]).unwrap();
        let full = full_mesh(&depth);
        let m = Remesh.mesh(&depth, &camera, (full.triangles.len() - 2) as f64).unwrap();
        assert_eq!(m.triangles.len(), full.triangles.len() - 2);
        // An interior edge lost its two faces (a border edge has one) and
        // the border kept its shape.
        assert!((super::super::tests::image_area(&m) - 6.0).abs() < 1e-9);
    }
}
