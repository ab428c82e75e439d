//! Extracted meshes as protocol 7, the compact stream (`dmesh_proto::compact`),
//! and back: a decoded stream as the strip response a client draws, with
//! normals and rho derived from the mesh ([`crate::mesh::derived_normals`]).

use dmesh_proto::compact::{self, CompactError, DecodedMesh, Forest, MeshChange, MeshInput, MeshStream, RenderStream};
use dmesh_proto::{Depths, Indices, Reach as WireReach, RenderResponse, RenderedView, StripResponse, WireVertex};

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::mesh::{derived_normals, Grid, Mesh};

/// The forest of a hierarchy's grid.
pub fn forest(grid: &Grid) -> Forest {
    Forest {
        side: grid.side(),
        m: grid.m,
        n: grid.n,
    }
}

/// `mesh` of the view `scene/view` (reference `camera`, hierarchy `grid`,
/// stored on `raw_grid`) in the compact stream.
#[allow(clippy::too_many_arguments)]
pub fn mesh_stream(
    mesh: &Mesh,
    grid: &Grid,
    scene: &str,
    view: &str,
    camera: &Camera,
    raw_grid: Option<dmesh_proto::RawGrid>,
    planes: Option<u8>,
    etag: String,
) -> std::result::Result<MeshStream, CompactError> {
    with_input(mesh, grid, scene, view, camera, raw_grid, planes, etag, compact::encode)
}

/// `mesh` as a client holding it with `planes` planes decoded it, as far as
/// a change against it needs ([`DecodedMesh::held`]).
pub fn held(mesh: &Mesh, raw_grid: Option<dmesh_proto::RawGrid>, planes: Option<u8>) -> DecodedMesh {
    let (ij, depths) = vertex_arrays(mesh);
    DecodedMesh::held(&ij, &depths, &mesh.triangles, &mesh.cuts, raw_grid, planes.is_none())
}

/// The grid coordinates and depths of `mesh`'s vertices, as the coder takes them.
fn vertex_arrays(mesh: &Mesh) -> (Vec<(u16, u16)>, Vec<f32>) {
    mesh.vertices.iter().map(|v| ((v.i, v.j), v.depth)).unzip()
}

/// [`mesh_stream`] as its difference from `held`, another mesh of the same
/// view as a client decoded it.
#[allow(clippy::too_many_arguments)]
pub fn mesh_change(
    mesh: &Mesh,
    grid: &Grid,
    scene: &str,
    view: &str,
    camera: &Camera,
    raw_grid: Option<dmesh_proto::RawGrid>,
    planes: Option<u8>,
    etag: String,
    held: &DecodedMesh,
) -> std::result::Result<MeshChange, CompactError> {
    with_input(mesh, grid, scene, view, camera, raw_grid, planes, etag, |input| {
        compact::encode_change(input, held)
    })
}

#[allow(clippy::too_many_arguments)]
fn with_input<T>(
    mesh: &Mesh,
    grid: &Grid,
    scene: &str,
    view: &str,
    camera: &Camera,
    raw_grid: Option<dmesh_proto::RawGrid>,
    planes: Option<u8>,
    etag: String,
    encode: impl FnOnce(MeshInput<'_>) -> std::result::Result<T, CompactError>,
) -> std::result::Result<T, CompactError> {
    let (ij, depths) = vertex_arrays(mesh);
    let spheres: Option<Vec<[f64; 4]>> = mesh.reach.as_ref().map(|r| r.culled.clone());
    encode(MeshInput {
        scene,
        view,
        lod: mesh.lod,
        camera: camera.into(),
        extract_ms: mesh.extract_ms,
        forest: forest(grid),
        ij: &ij,
        depths: &depths,
        triangles: &mesh.triangles,
        cuts: &mesh.cuts,
        raw_grid,
        reach: mesh
            .reach
            .as_ref()
            .zip(spheres.as_deref())
            .map(|(r, s)| (s, r.clearance)),
        planes,
        etag,
    })
}

/// A compact mesh as the strip response a client blends: depths decoded
/// (within the stream's stated error), normals and rho derived, the
/// triangles as strips of one triangle each. `requesting` is the camera of
/// the request, which a view-dependent mesh's reach refers to.
pub fn strip_response(stream: &MeshStream, requesting: Option<&Camera>) -> Result<StripResponse> {
    let decoded = stream.decode().map_err(|e| Error::invalid(e.to_string()))?;
    decoded_response(stream, decoded, requesting)
}

/// [`strip_response`] of a mesh already decoded (from `stream`, or from a
/// change whose `mesh` it is).
pub fn decoded_response(
    stream: &MeshStream,
    decoded: DecodedMesh,
    requesting: Option<&Camera>,
) -> Result<StripResponse> {
    let camera = Camera::try_from(&stream.camera)?;
    let ij: Vec<(u16, u16)> = decoded
        .shape
        .vertices
        .iter()
        .map(|&(i, j)| (i as u16, j as u16))
        .collect();
    let (normals, rho) = derived_normals::derive(&camera, &ij, &decoded.depths, &decoded.shape.triangles);
    let vertices = ij
        .iter()
        .zip(normals.iter().zip(&rho))
        .map(|(&(i, j), (&normal, &rho))| WireVertex { i, j, normal, rho })
        .collect::<Vec<_>>();
    let short = vertices.len() < usize::from(u16::MAX);
    let indices = if short {
        let mut v = Vec::with_capacity(4 * decoded.shape.triangles.len());
        for t in &decoded.shape.triangles {
            if !v.is_empty() {
                v.push(u16::MAX);
            }
            v.extend(t.iter().map(|&k| k as u16));
        }
        Indices::U16(v)
    } else {
        let mut v = Vec::with_capacity(4 * decoded.shape.triangles.len());
        for t in &decoded.shape.triangles {
            if !v.is_empty() {
                v.push(u32::MAX);
            }
            v.extend_from_slice(t);
        }
        Indices::U32(v)
    };
    let reach = match (&stream.reach, requesting) {
        (None, _) => None,
        (Some(r), Some(view)) => Some(WireReach {
            view: view.into(),
            clearance: r.clearance,
            culled: stream
                .culled()
                .iter()
                .map(|s| {
                    // Rounded outwards: the f32 sphere still holds the f64 one.
                    let c = s.map(|v| v as f32);
                    let slack: f64 = (0..3).map(|k| (s[k] - f64::from(c[k])).abs()).sum();
                    [c[0], c[1], c[2], ((s[3] + slack) as f32).next_up()]
                })
                .collect(),
        }),
        (Some(_), None) => {
            return Err(Error::invalid(
                "a view-dependent compact mesh needs the camera it was requested for",
            ))
        }
    };
    Ok(StripResponse {
        version: dmesh_proto::PROTOCOL_VERSION,
        scene: stream.scene.clone(),
        view: stream.view.clone(),
        lod: stream.lod,
        camera: stream.camera.clone(),
        vertices,
        depths: Depths::Exact(decoded.depths),
        indices,
        triangles: stream.triangles,
        extract_ms: stream.extract_ms,
        reach,
        cuts: decoded.cuts,
    })
}

/// A compact render response as the render response a client blends.
pub fn render_response(r: &RenderStream, novel: &Camera) -> Result<RenderResponse> {
    let views = r
        .views
        .iter()
        .map(|v| {
            let requesting = v.mesh.reach.is_some().then_some(novel);
            Ok(RenderedView {
                weight: v.weight,
                strips: strip_response(&v.mesh, requesting)?,
                color_url: v.color_url.clone(),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(RenderResponse {
        version: dmesh_proto::PROTOCOL_VERSION,
        views,
        timings: r.timings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Hierarchy, Lod, Segmentation};

    #[test]
    fn a_compact_mesh_decodes_to_the_extracted_one() {
        let (cam, depth) = crate::wire::tests::stepped();
        let h = Hierarchy::build(&depth, &cam, &Segmentation::default()).unwrap();
        let novel = Camera::perspective(65, 40, 60.0, 60.0, 32.0, 20.0).unwrap();
        for lod in [
            Lod::Epsilon(0.0005),
            Lod::Epsilon(0.05),
            Lod::Tau { tau: 1.0, view: &novel },
        ] {
            let mesh = h.extract(lod).unwrap();
            assert!(mesh.dropped_triangles > 0);
            let s = mesh_stream(&mesh, h.grid(), "s", "v", &cam, None, None, "\"e\"".into()).unwrap();
            let back = strip_response(&s, Some(&novel)).unwrap();
            let ij: Vec<(u16, u16)> = back.vertices.iter().map(|v| (v.i, v.j)).collect();
            let want: Vec<(u16, u16)> = mesh.vertices.iter().map(|v| (v.i, v.j)).collect();
            assert_eq!(ij, want);
            let tris = crate::mesh::decode_strips(&back.indices.to_u32());
            assert_eq!(tris, mesh.triangles);
            let Depths::Exact(z) = &back.depths else { panic!() };
            for (a, b) in z.iter().zip(&mesh.vertices) {
                assert!((a - b.depth).abs() <= s.max_error);
            }
            assert_eq!(back.reach.is_some(), mesh.reach.is_some());
        }
    }
}
