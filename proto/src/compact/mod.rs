//! Protocol 7, the compact mesh stream (`application/vnd.dmesh.mesh`):
//! only the information a restricted-quadtree mesh holds (DESIGN.md "The
//! compact stream"; PROTOCOL.md lays it out bit by bit).
//!
//! - [`connectivity`]: split, leaf and cut bits of the one canonical walk
//!   of the forest ([`forest`]); the rules' implications cost nothing;
//! - [`cut`]: the cut triangles' cases and crossings, and the side depths
//!   their crossings carry;
//! - [`bitplanes`]: depths as nested bit planes of parent-edge residuals,
//!   anchors exact;
//! - `reach`: the culled spheres of a view-dependent mesh, merged and quantised;
//! - the rest (ids, tolerance, camera, reach) in a small bincode header.
//!
//! Positions, texture coordinates, normals and rho are not sent: a client
//! derives them from `(i, j)`, depth and the reference camera. Fields are
//! byte-aligned and grouped so HTTP content coding (zstd, br, gzip) does the
//! entropy coding.

pub mod bitplanes;
pub mod connectivity;
pub mod cut;
mod decode;
pub mod forest;
mod reach;

use serde::{Deserialize, Serialize};

pub use bitplanes::{DepthCode, LevelCode};
pub use connectivity::{Connectivity, Shape};
pub use cut::{CutCode, CutTriangle};
pub use forest::Forest;

use forest::Pt;

use crate::camera::Camera;
use crate::render::Timings;
use crate::residual::RawGrid;
use crate::strips::Lod;

/// Media type of the compact stream.
pub const MESH_MEDIA_TYPE: &str = "application/vnd.dmesh.mesh";

/// Version of the compact stream, in every body.
pub const COMPACT_VERSION: u16 = 7;

/// Largest number of culled spheres a compact reach carries (the engine's
/// are merged down to this, staying conservative): 8 bytes each.
pub const MAX_COMPACT_CULLED: usize = 1024;

/// A body of the compact stream on the strip routes: a whole mesh, or the
/// planes a client holding the same mesh lacks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MeshBody {
    /// A whole mesh.
    Mesh(Box<MeshStream>),
    /// Further depth planes of a mesh the client holds.
    Planes(PlaneUpdate),
    /// Another mesh of the same view, as its difference from one the client holds.
    Change(Box<MeshChange>),
}

/// Another mesh of a view (a finer or coarser tolerance, a moved camera),
/// sent as its difference from a mesh of the same view the client holds
/// (PROTOCOL.md, "Protocol 7", "Changes"). Applied to the held mesh it gives
/// exactly what the whole mesh decodes to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshChange {
    /// The new mesh, its connectivity bits coded against the held mesh
    /// ([`connectivity::Context`]), its depths all of them or, with
    /// [`Self::reuses_depths`], only those of the vertices the held mesh lacks.
    pub mesh: MeshStream,
    /// True when the held mesh's depths are the new mesh's: both carry all
    /// planes on one lattice, so a depth's value is the depth's alone.
    pub reuses_depths: bool,
    /// The split and leaf bits of the triangles the held mesh never reached,
    /// plain (the mesh's own fields carry the others, as differences).
    pub fresh: Connectivity,
}

/// One view's mesh in the compact stream.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeshStream {
    /// [`COMPACT_VERSION`].
    pub version: u16,
    /// Scene id.
    pub scene: String,
    /// View id.
    pub view: String,
    /// The tolerance the mesh meets (`epsilon` or `tau`).
    pub lod: Lod,
    /// The reference camera.
    pub camera: Camera,
    /// Server-side extraction time in milliseconds.
    pub extract_ms: f64,
    /// Root quad side of the view's grid (a power of two).
    pub root_side: u32,
    /// Root quads across.
    pub roots_x: u32,
    /// Root quads down.
    pub roots_y: u32,
    /// Triangles the mesh draws whole.
    pub triangles: u32,
    /// Triangles the mesh draws as cuts.
    pub cut_triangles: u32,
    /// How the connectivity is coded.
    pub connectivity: Connectivity,
    /// The cut triangles' cases and crossings.
    pub cuts: CutCode,
    /// The integer lattice depths are coded on, if any.
    pub lattice: Option<RawGrid>,
    /// Per level of the forest, coarse to fine: step and planes.
    pub levels: Vec<LevelCode>,
    /// Escape bits: one per predicted vertex, 1 when its depth is exact.
    pub escapes: Vec<u8>,
    /// Exact depths of anchors and escaped vertices, byte-shuffled `f32`.
    pub exact: Vec<u8>,
    /// Depth planes `1..=planes.len()` (of [`Self::total_planes`]).
    pub planes: Vec<Vec<u8>>,
    /// The planes the mesh has in all, sent or not.
    pub total_planes: u8,
    /// Largest depth error in metres of the planes sent.
    pub max_error: f32,
    /// For a view-dependent mesh, how far its camera may move.
    pub reach: Option<CompactReach>,
    /// The response's ETag, which names this mesh and its planes for a
    /// later request that holds it. It travels in the `ETag` header, not in
    /// the body; a client keeps it here.
    #[serde(skip)]
    pub etag: String,
}

/// Planes a client lacks of the mesh it named as held (the answer's `ETag`
/// header names the extended mesh).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaneUpdate {
    /// [`COMPACT_VERSION`].
    pub version: u16,
    /// Index (0-based) of the first plane sent: the number already held.
    pub first: u8,
    /// The planes.
    pub planes: Vec<Vec<u8>>,
    /// Largest depth error in metres holding all planes up to these.
    pub max_error: f32,
}

/// [`crate::Reach`] in a few bytes: the requesting camera is the request's,
/// and the culled spheres are quantised inside a box, radii rounded up.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompactReach {
    /// As [`crate::Reach::clearance`].
    pub clearance: Option<f64>,
    /// Box corner of the quantised centres (world frame).
    pub lo: [f64; 3],
    /// Metres per unit of a quantised centre coordinate or radius.
    pub unit: f64,
    /// Spheres `[x, y, z, r]` in units from `lo`.
    pub culled: Vec<[u16; 4]>,
}

/// One selected view of a compact render response.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompactView {
    /// Angular x positional weight.
    pub weight: f64,
    /// Its mesh.
    pub mesh: MeshStream,
    /// Where its colour texture is served.
    pub color_url: String,
}

/// A render response in the compact stream.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderStream {
    /// [`COMPACT_VERSION`].
    pub version: u16,
    /// Selected views, heaviest first.
    pub views: Vec<CompactView>,
    /// Server timings.
    pub timings: Timings,
}

/// Why a compact body does not decode.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("compact mesh stream: {0}")]
pub struct CompactError(pub String);

impl From<&'static str> for CompactError {
    fn from(s: &'static str) -> Self {
        Self(s.to_string())
    }
}

/// A mesh to encode: what the engine extracted.
pub struct MeshInput<'a> {
    /// Scene id.
    pub scene: &'a str,
    /// View id.
    pub view: &'a str,
    /// The tolerance it meets.
    pub lod: Lod,
    /// The reference camera.
    pub camera: Camera,
    /// Extraction time.
    pub extract_ms: f64,
    /// The forest of the view's grid.
    pub forest: Forest,
    /// Vertex grid coordinates.
    pub ij: &'a [(u16, u16)],
    /// Vertex depths.
    pub depths: &'a [f32],
    /// Triangles indexing the vertices.
    pub triangles: &'a [[u32; 3]],
    /// Triangles drawn as cuts.
    pub cuts: &'a [CutTriangle],
    /// The lattice the stored depths came from, if any.
    pub raw_grid: Option<RawGrid>,
    /// The reach, `([x, y, z, r] world spheres, clearance)`.
    pub reach: Option<(&'a [[f64; 4]], Option<f64>)>,
    /// Planes to send: `None` for all.
    pub planes: Option<u8>,
    /// The ETag to state.
    pub etag: String,
}

/// A decoded compact mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedMesh {
    /// Vertex grid coordinates and triangles.
    pub shape: Shape,
    /// Vertex depths in metres.
    pub depths: Vec<f32>,
    /// The cut triangles with their decoded depths, in walk order.
    pub cuts: Vec<CutTriangle>,
    /// Largest depth error of these depths and the cuts', metres.
    pub max_error: f32,
    /// Planes decoded.
    pub planes: usize,
    /// The lattice the depths were coded on.
    pub lattice: Option<RawGrid>,
    /// True when every plane was decoded: each depth is then its value on
    /// the lattice, whatever mesh it came in.
    pub complete: bool,
}

/// Encodes a mesh.
pub fn encode(input: MeshInput<'_>) -> Result<MeshStream, CompactError> {
    Ok(encode_against(input, None)?.0)
}

/// Encodes the mesh of `input` as its difference from `held`, a mesh of
/// the same view the client decoded. Its depths are reused when `held` is
/// complete, all planes are asked for, and both lie on one lattice.
pub fn encode_change(input: MeshInput<'_>, held: &DecodedMesh) -> Result<MeshChange, CompactError> {
    let (mesh, fresh, reuses_depths) = encode_against(input, Some(held))?;
    Ok(MeshChange {
        mesh,
        reuses_depths,
        fresh,
    })
}

/// The mesh of `input`, whole or (with `held`) as a change: the stream, the
/// fresh connectivity bits, and whether the held depths are reused.
fn encode_against(
    input: MeshInput<'_>,
    held: Option<&DecodedMesh>,
) -> Result<(MeshStream, Connectivity, bool), CompactError> {
    let f = input.forest;
    if input.ij.len() != input.depths.len() {
        return Err(CompactError(format!(
            "{} depths for {} vertices",
            input.depths.len(),
            input.ij.len()
        )));
    }
    let context = held
        .map(|h| connectivity::Context::of(&f, &h.shape))
        .transpose()
        .map_err(CompactError)?;
    let corners = corners_of(&input)?;
    let cut_corners: Vec<[Pt; 3]> = input.cuts.iter().map(|c| c.corners.map(pt)).collect();
    let (connectivity, fresh, leaves) =
        connectivity::encode(&f, &corners, &cut_corners, context.as_ref()).map_err(CompactError)?;
    let cut::Coded {
        code: cut_code,
        shapes,
        sides,
        depths: side_depths,
    } = cut::encode(&f, &leaves.cut, input.cuts).map_err(CompactError)?;
    let shape = connectivity::assemble_with(&f, &leaves.drawn, &shapes);
    let mut depths = depths_in(&input, &shape)?;
    let lattice = bitplanes::lattice_for(&depths, input.raw_grid);
    let known = held.filter(|h| h.complete && input.planes.is_none()).and_then(|h| {
        let at = h.depths_at(&shape.vertices);
        // The reuse holds only if the held depths are these depths' values.
        let agree = h.lattice == Some(lattice)
            && at
                .iter()
                .zip(&depths)
                .all(|(h, &z)| h.is_none_or(|h| h == bitplanes::on(lattice, z)));
        agree.then(|| {
            // Side depths are always sent.
            let sides = std::iter::repeat_n(false, sides.len());
            at.iter().map(Option::is_some).chain(sides).collect::<Vec<bool>>()
        })
    });
    let side_vertices = side_vertices(&f, &shape, &sides)?;
    depths.extend_from_slice(&side_depths);
    let code = bitplanes::encode(
        &f,
        &shape.vertices,
        &side_vertices,
        &depths,
        input.raw_grid,
        input.planes,
        known.as_deref(),
    )
    .map_err(CompactError)?;
    let stream = assemble_stream(input, (connectivity, cut_code), code, (corners.len(), shapes.len()))?;
    Ok((stream, fresh, known.is_some()))
}

/// A grid corner as a forest point.
fn pt([x, y]: [u16; 2]) -> Pt {
    (u32::from(x), u32::from(y))
}

/// The vertex number of each side's end in `shape`.
fn side_vertices(f: &Forest, shape: &Shape, sides: &[cut::Side]) -> Result<Vec<u32>, CompactError> {
    forest::with_slot_map(f.len(), |slot| {
        // Mark the ends, then number the marked vertices.
        const END: u32 = u32::MAX - 1;
        let touched: Vec<usize> = sides.iter().map(|s| f.index(s.end)).collect();
        for &i in &touched {
            slot[i] = END;
        }
        for (k, &p) in shape.vertices.iter().enumerate() {
            let i = f.index(p);
            if slot[i] == END {
                slot[i] = k as u32;
            }
        }
        let out = touched
            .iter()
            .map(|&i| match slot[i] {
                END => Err("a crossing side ends on no vertex".into()),
                k => Ok(k),
            })
            .collect();
        (out, touched)
    })
}

/// The triangles of `input` as grid points.
fn corners_of(input: &MeshInput<'_>) -> Result<Vec<[Pt; 3]>, CompactError> {
    let at = |v: u32| -> Result<(u32, u32), CompactError> {
        let (i, j) = *input
            .ij
            .get(v as usize)
            .ok_or_else(|| CompactError(format!("triangle index {v} has no vertex")))?;
        Ok((u32::from(i), u32::from(j)))
    };
    input
        .triangles
        .iter()
        .map(|t| Ok([at(t[0])?, at(t[1])?, at(t[2])?]))
        .collect()
}

/// The depths of `input` in the order of the `shape` the connectivity
/// coder numbered.
fn depths_in(input: &MeshInput<'_>, shape: &Shape) -> Result<Vec<f32>, CompactError> {
    // The engine's own numbering, unless the mesh came numbered otherwise.
    let same = shape.vertices.len() == input.ij.len()
        && shape
            .vertices
            .iter()
            .zip(input.ij)
            .all(|(&(x, y), &(i, j))| x == u32::from(i) && y == u32::from(j));
    if same {
        return Ok(input.depths.to_vec());
    }
    let mut depth_at = rustc_hash::FxHashMap::default();
    depth_at.reserve(input.ij.len());
    for (&(i, j), &z) in input.ij.iter().zip(input.depths) {
        depth_at.insert((u32::from(i), u32::from(j)), z);
    }
    for c in input.cuts {
        let [p0, p1, p2] = c.corners.map(pt);
        if let Some(z) = c.lone {
            depth_at.insert(p0, z[0]);
        }
        if let Some(z) = c.other {
            depth_at.insert(p1, z[1]);
            depth_at.insert(p2, z[2]);
        }
    }
    Ok(shape
        .vertices
        .iter()
        .map(|p| depth_at.get(p).copied().ok_or("a drawn vertex has no depth"))
        .collect::<Result<Vec<f32>, _>>()?)
}

fn assemble_stream(
    input: MeshInput<'_>,
    (connectivity, cuts): (Connectivity, CutCode),
    code: DepthCode,
    (triangles, cut_triangles): (usize, usize),
) -> Result<MeshStream, CompactError> {
    let f = input.forest;
    let total_planes = code.total;
    Ok(MeshStream {
        version: COMPACT_VERSION,
        scene: input.scene.to_string(),
        view: input.view.to_string(),
        lod: input.lod,
        camera: input.camera,
        extract_ms: input.extract_ms,
        root_side: f.side,
        roots_x: f.m,
        roots_y: f.n,
        triangles: u32::try_from(triangles).map_err(|_| "too many triangles")?,
        cut_triangles: u32::try_from(cut_triangles).map_err(|_| "too many cut triangles")?,
        connectivity,
        cuts,
        lattice: code.lattice,
        levels: code.levels,
        escapes: code.escapes,
        exact: code.exact,
        planes: code.planes,
        total_planes,
        max_error: code.max_error,
        reach: input.reach.map(|(s, c)| reach::compact_reach(s, c)),
        etag: input.etag,
    })
}

#[cfg(test)]
mod tests;
