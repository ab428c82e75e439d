//! What the build's stored errors cost in triangles: the triangle count of
//! the static extraction at object-space tolerances from 0.01 % to 1 % of
//! each scene's median depth, and of the view-dependent one at 1 and 4 px
//! from the reference camera, for the synthetic scenes and the Middlebury
//! scenes in `../shared/data` (those present). Run it before and after a
//! change to the errors (DMesh Sec. 4.2) to see what the change costs.
//! Usage: `cargo run --release -p dmesh-engine --example triangles_at_epsilon`.
#[path = "../benches/scenes.rs"]
mod scenes;

use dmesh_engine::mesh::{Hierarchy, Lod, Threads};

fn main() {
    let mut all = Vec::new();
    for (w, h) in [(513, 513), (1920, 1080)] {
        all.push((format!("synthetic-{w}x{h}"), scenes::synthetic(w, h)));
    }
    for name in ["cones", "teddy", "art", "books"] {
        if let Some(scene) = scenes::middlebury(name) {
            all.push((name.to_string(), scene));
        }
    }
    let fractions = [1e-4, 3e-4, 1e-3, 3e-3, 1e-2];
    print!("scene");
    for f in fractions {
        print!("\teps {}%", f * 100.0);
    }
    println!("\ttau 1px\ttau 4px");
    for (name, (d, c)) in all {
        let mesh = Hierarchy::build_with(&d, &c, &Default::default(), Threads::Single).expect("the scene builds");
        let mut z: Vec<f32> = d.z.iter().copied().filter(|&z| z > 0.0).collect();
        z.sort_unstable_by(f32::total_cmp);
        let median = f64::from(z[z.len() / 2]);
        let count = |lod| mesh.extract(lod).expect("extracts").triangles.len();
        print!("{name}");
        for f in fractions {
            print!("\t{}", count(Lod::Epsilon(f * median)));
        }
        for tau in [1.0, 4.0] {
            print!("\t{}", count(Lod::Tau { tau, view: &c }));
        }
        println!();
    }
}
