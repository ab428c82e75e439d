//! A novel view end to end: ask `/render`, fetch the selected views' colour
//! textures (through the ETag cache), blend.

use anyhow::{bail, Context};
use dmesh_engine::camera::Camera;
use dmesh_proto::RenderRequest;

use crate::blend::{blend, BlendOptions, Blended, Texture, ViewInput};
use crate::http::Server;

/// Renders `request.camera` of `scene` from the server's strips.
pub async fn render_novel(
    server: &Server,
    scene: &str,
    request: &RenderRequest,
    options: &BlendOptions,
) -> anyhow::Result<Blended> {
    let novel = Camera::try_from(&request.camera)?;
    let response = server.render(scene, request).await?;
    if response.views.is_empty() {
        bail!("the server selected no view for this camera");
    }
    let mut textures = Vec::with_capacity(response.views.len());
    for v in &response.views {
        let bytes = server.color(&v.color_url).await?;
        let img = image::load_from_memory(&bytes).context("colour texture")?.to_rgb8();
        textures.push(Texture {
            width: img.width(),
            height: img.height(),
            rgb: img.into_raw(),
        });
    }
    let inputs: Vec<ViewInput<'_>> = response
        .views
        .iter()
        .zip(&textures)
        .map(|(v, t)| ViewInput {
            weight: v.weight,
            strips: &v.strips,
            texture: t,
        })
        .collect();
    blend(&novel, &inputs, options)
}
