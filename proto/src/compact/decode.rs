//! Decoding the compact stream: a whole mesh, a change against the mesh a
//! client holds, and a plane update of a stream it holds (PROTOCOL.md,
//! "Protocol 7").

use super::forest::Pt;
use super::{
    bitplanes, connectivity, cut, pt, side_vertices, CompactError, Connectivity, CutTriangle, DecodedMesh, DepthCode,
    Forest, MeshChange, MeshStream, PlaneUpdate, Shape, COMPACT_VERSION,
};
use crate::residual::RawGrid;

impl DecodedMesh {
    /// Its depth at each of `points`, `None` where it has no vertex.
    pub(super) fn depths_at(&self, points: &[Pt]) -> Vec<Option<f32>> {
        let at: rustc_hash::FxHashMap<Pt, f32> = self
            .shape
            .vertices
            .iter()
            .copied()
            .zip(self.depths.iter().copied())
            .collect();
        points.iter().map(|p| at.get(p).copied()).collect()
    }

    /// A mesh as a client holding it decoded it, from the encoder's side:
    /// vertices `ij` with `depths`, `triangles` indexing them, the `cuts`,
    /// coded on [`bitplanes::lattice_for`] `raw`. `complete` when the
    /// client holds all its planes; only then are its depths the decoded
    /// ones (a change reuses no others). What a server needs to code a
    /// change against it, without coding it again: its vertices (the cuts'
    /// drawn corners among them) and drawn triangles.
    pub fn held(
        ij: &[(u16, u16)],
        depths: &[f32],
        triangles: &[[u32; 3]],
        cuts: &[CutTriangle],
        raw: Option<RawGrid>,
        complete: bool,
    ) -> Self {
        let mut vertices: Vec<Pt> = ij.iter().map(|&(i, j)| (u32::from(i), u32::from(j))).collect();
        let mut depths = depths.to_vec();
        let mut seen: rustc_hash::FxHashSet<Pt> = vertices.iter().copied().collect();
        for c in cuts {
            let [p0, p1, p2] = c.corners.map(pt);
            let lone = c.lone.map(|z| [(p0, z[0])]);
            let other = c.other.map(|z| [(p1, z[1]), (p2, z[2])]);
            for (p, z) in lone.into_iter().flatten().chain(other.into_iter().flatten()) {
                if seen.insert(p) {
                    vertices.push(p);
                    depths.push(z);
                }
            }
        }
        let lattice = bitplanes::lattice_for(&depths, raw);
        Self {
            shape: Shape {
                vertices,
                triangles: triangles.to_vec(),
                cuts: Vec::new(),
            },
            depths: depths.iter().map(|&z| bitplanes::on(lattice, z)).collect(),
            cuts: cuts.to_vec(),
            max_error: 0.0,
            planes: 0,
            lattice: Some(lattice),
            complete,
        }
    }
}

impl MeshChange {
    /// The new mesh, from `held`: the decoded mesh the request named.
    pub fn apply(&self, held: &DecodedMesh) -> Result<DecodedMesh, CompactError> {
        self.mesh.decode_against(Some((held, self.reuses_depths, &self.fresh)))
    }
}

impl MeshStream {
    /// The forest it is coded on.
    pub fn forest(&self) -> Forest {
        Forest {
            side: self.root_side,
            m: self.roots_x,
            n: self.roots_y,
        }
    }

    /// Decodes the mesh. Vertices must lie inside the reference image.
    pub fn decode(&self) -> Result<DecodedMesh, CompactError> {
        self.decode_against(None)
    }

    /// Decodes the mesh, its bits coded against `held` with the held depths
    /// reused or not ([`MeshChange`]).
    fn decode_against(&self, held: Option<(&DecodedMesh, bool, &Connectivity)>) -> Result<DecodedMesh, CompactError> {
        if self.version != COMPACT_VERSION {
            return Err(CompactError(format!(
                "version {} is not {COMPACT_VERSION}",
                self.version
            )));
        }
        let f = self.forest();
        f.check()?;
        // The forest is the reference image's: the fewest roots of this side
        // covering it (so what a decoder allocates is bounded by the image).
        let (w, h) = (self.camera.width, self.camera.height);
        let covers = |roots: u32, size: u32| {
            size >= 2
                && u64::from(roots - 1) * u64::from(f.side) < u64::from(size - 1)
                && u64::from(roots) * u64::from(f.side) >= u64::from(size - 1)
        };
        if !(covers(f.m, w) && covers(f.n, h)) {
            return Err(CompactError(format!(
                "{} x {} roots of side {} do not cover the {w} x {h} reference image",
                f.m, f.n, f.side
            )));
        }
        if self.planes.len() > usize::from(self.total_planes) {
            return Err("more planes than the mesh has".into());
        }
        if !(self.max_error.is_finite() && self.max_error >= 0.0) {
            return Err("the error bound must be finite and not negative".into());
        }
        let context = held
            .map(|(m, ..)| connectivity::Context::of(&f, &m.shape))
            .transpose()
            .map_err(CompactError)?;
        let empty = Connectivity::default();
        let leaves = connectivity::decode(
            &f,
            &self.connectivity,
            held.map_or(&empty, |h| h.2),
            (self.triangles as usize, self.cut_triangles as usize),
            context.as_ref(),
        )?;
        let (shapes, sides) = cut::decode(&f, &leaves.cut, &self.cuts)?;
        let shape = connectivity::assemble_with(&f, &leaves.drawn, &shapes);
        if shape.vertices.iter().any(|&(i, j)| i >= w || j >= h) {
            return Err("a vertex lies outside the reference image".into());
        }
        let known: Option<Vec<Option<f32>>> = match held {
            Some((m, true, _)) => {
                if !m.complete || m.lattice != self.lattice || self.lattice.is_none() {
                    return Err("the change reuses depths the held mesh does not have".into());
                }
                let mut known = m.depths_at(&shape.vertices);
                known.resize(shape.vertices.len() + sides.len(), None);
                Some(known)
            }
            _ => None,
        };
        let code = DepthCode {
            lattice: self.lattice,
            levels: self.levels.clone(),
            escapes: self.escapes.clone(),
            exact: self.exact.clone(),
            planes: self.planes.clone(),
            total: self.total_planes,
            sent: self.planes.len(),
            max_error: self.max_error,
        };
        let side_vertices = side_vertices(&f, &shape, &sides)?;
        let mut depths = bitplanes::decode(
            &f,
            &shape.vertices,
            &side_vertices,
            &code,
            self.planes.len(),
            known.as_deref(),
        )?;
        let side_depths = depths.split_off(shape.vertices.len());
        // A cut corner's depth through the grid's slot map of the vertices.
        let cuts = super::forest::with_slot_map(f.len(), |slot| {
            let touched: Vec<usize> = shape.vertices.iter().map(|&p| f.index(p)).collect();
            for (k, &i) in touched.iter().enumerate() {
                slot[i] = k as u32;
            }
            let at = |p: Pt| {
                let k = *slot.get(f.index(p))?;
                depths.get(k as usize).copied()
            };
            let cuts = shape
                .cuts
                .iter()
                .map(|c| c.with_depths(at, &side_depths))
                .collect::<Option<Vec<CutTriangle>>>();
            (cuts, touched)
        })
        .ok_or("a cut's depths do not decode")?;
        Ok(DecodedMesh {
            shape,
            depths,
            cuts,
            max_error: self.max_error,
            planes: self.planes.len(),
            lattice: self.lattice,
            complete: self.planes.len() == usize::from(self.total_planes),
        })
    }

    /// Appends the planes of `update`, the answer to a request that named
    /// this mesh as held; `etag` is that answer's.
    pub fn apply(&mut self, update: PlaneUpdate, etag: String) -> Result<(), CompactError> {
        if usize::from(update.first) != self.planes.len() {
            return Err("the planes do not start where the held ones end".into());
        }
        if self.planes.len() + update.planes.len() > usize::from(self.total_planes) {
            return Err("more planes than the mesh has".into());
        }
        self.planes.extend(update.planes);
        self.max_error = update.max_error;
        self.etag = etag;
        Ok(())
    }

    /// The reach's culled spheres in the world frame, `[x, y, z, r]`.
    pub fn culled(&self) -> Vec<[f64; 4]> {
        self.reach.as_ref().map_or_else(Vec::new, |r| {
            r.culled
                .iter()
                .map(|q| {
                    let c = |k: usize| r.lo[k] + f64::from(q[k]) * r.unit;
                    [c(0), c(1), c(2), f64::from(q[3]) * r.unit]
                })
                .collect()
        })
    }
}
