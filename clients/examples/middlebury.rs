//! Warps the Middlebury cones and teddy left views to their right views with
//! a real (in-process) server and prints PSNR on the valid mask, inverse-depth
//! RMSE and triangle counts at tau = 0, 0.5, 1 and 2.
//!
//! Usage, from the repository root: `cargo run --release -p dmesh-client --example middlebury`
//! (reads `../shared/data`). The 2003 scenes have no published focal length or
//! baseline; depth is `f B / d` with `f = 450 px` and `B = 1`, and the right
//! camera sits at `B` along x, which is exactly the rectified geometry.

use std::sync::Arc;

use dmesh_client::blend::{blend, BlendOptions, Texture, ViewInput};
use dmesh_client::compare::compare;
use dmesh_client::http::Server;

const F: f64 = 450.0;

fn camera(x: f64) -> dmesh_proto::Camera {
    dmesh_proto::Camera {
        width: 450,
        height: 375,
        projection: dmesh_proto::Projection::Perspective {
            fx: F,
            fy: F,
            cx: 224.5,
            cy: 187.0,
        },
        pose: dmesh_proto::Pose {
            rotation: [0.0, 0.0, 0.0, 1.0],
            translation: [x, 0.0, 0.0],
        },
    }
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let dir = tempfile::tempdir()?;
    let store = dmesh::store::FileStore::open(dir.path())?;
    let state = Arc::new(dmesh::http::AppState::new(
        Arc::new(store),
        dmesh::http::Settings::default(),
    ));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let base = format!("http://{}", listener.local_addr()?);
    tokio::spawn(dmesh::http::serve_on(listener, state, dmesh::http::Pipeline::default()));
    let server = Server::new(&base, None);
    println!("| scene | tau (px) | triangles | PSNR (dB) | valid | inverse-depth RMSE |");
    println!("|---|---|---|---|---|---|");
    for scene in ["cones", "teddy"] {
        let read = |f: &str| std::fs::read(data.join(scene).join(f));
        let (disp2, im2, disp6, im6) = (
            read("disp2.png")?,
            read("im2.png")?,
            read("disp6.png")?,
            read("im6.png")?,
        );
        let fields = [
            ("depth_kind", "disparity".to_string()),
            ("scale", "0.25".to_string()),
            ("focal_baseline", F.to_string()),
        ];
        server
            .put_view_with(
                scene,
                "left",
                &serde_json::to_string(&camera(0.0))?,
                &disp2,
                &im2,
                &fields,
            )
            .await?;
        let right = camera(1.0);
        let novel = dmesh_engine::camera::Camera::try_from(&right)?;
        let truth = image::load_from_memory(&im6)?.to_rgb8();
        let truth_depth: Vec<f32> = image::load_from_memory(&disp6)?
            .to_luma8()
            .into_raw()
            .into_iter()
            .map(|v| if v > 0 { (F / (f64::from(v) / 4.0)) as f32 } else { 0.0 })
            .collect();
        let texture = {
            let img = image::load_from_memory(&im2)?.to_rgb8();
            Texture {
                width: img.width(),
                height: img.height(),
                rgb: img.into_raw(),
            }
        };
        for tau in [0.0, 0.5, 1.0, 2.0] {
            let request = dmesh_client::loadtest::Detail {
                lod: dmesh_proto::Lod::Tau(tau),
                max_views: Some(1),
                ..Default::default()
            }
            .request(right.clone());
            let response = server.render(scene, &request).await?;
            let v = &response.views[0];
            let b = blend(
                &novel,
                &[ViewInput {
                    weight: v.weight,
                    strips: &v.strips,
                    texture: &texture,
                }],
                &BlendOptions::default(),
            )?;
            let c = compare(&b.rgb, truth.as_raw(), Some((&b.depth, &truth_depth)))?;
            println!(
                "| {scene} | {tau} | {} | {:.2} | {:.1} % | {:.5} |",
                v.strips.triangles,
                c.psnr,
                100.0 * c.valid_fraction,
                c.inverse_depth_rmse.unwrap_or(f64::NAN)
            );
        }
    }
    Ok(())
}
