//! Builds the synthetic scene (or a Middlebury scene of `../shared/data`)
//! repeatedly and prints the minimum and median time and the median of
//! each stage, for profiling. Usage:
//! `profile_build [SIZE | WxH | SCENE] [ITERATIONS] [THREADS] [TIER | alternate]`
//! (threads 1 or 2, default as `Hierarchy::build`; `portable`, `avx2` or
//! `avx512`: no better code than that tier, to measure what each brings;
//! `alternate`: every tier this CPU has above the portable one, build by
//! build, so that the machine's moods fall on each alike).

#[path = "../benches/scenes.rs"]
mod scenes;
/// The server's allocator (see the root `Cargo.toml`), so the figures are
/// the binary's.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    let mut args = std::env::args().skip(1);
    let size = args.next().unwrap_or_else(|| "513".into());
    let Some((d, c)) = scenes::from_arg(&size) else {
        std::process::exit(2);
    };
    let (w, h) = (d.width, d.height);
    let iterations: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(20);
    let threads = match args.next().as_deref() {
        Some("1") => dmesh_engine::mesh::Threads::Single,
        Some("2") => dmesh_engine::mesh::Threads::Parallel,
        _ => dmesh_engine::mesh::Threads::available(),
    };
    use dmesh_engine::simd::Tier;
    let tiers: Vec<Tier> = match args.next().as_deref() {
        Some("alternate") => Tier::ALL[1..].iter().copied().filter(|t| t.available()).collect(),
        Some(name) => match Tier::ALL.into_iter().find(|t| t.name() == name) {
            Some(t) => vec![t],
            None => {
                eprintln!("no tier {name:?}: give portable, avx2, avx512 or alternate");
                std::process::exit(2);
            }
        },
        None => vec![Tier::Avx512],
    };
    let mut times = vec![Vec::new(); tiers.len()];
    let mut stages = vec![Vec::new(); tiers.len()];
    for _ in 0..iterations.max(1) {
        for (k, &tier) in tiers.iter().enumerate() {
            dmesh_engine::simd::limit(tier);
            let t = std::time::Instant::now();
            let mesh = std::hint::black_box(
                dmesh_engine::mesh::Hierarchy::build_with(&d, &c, &Default::default(), threads).unwrap(),
            );
            times[k].push(t.elapsed());
            stages[k].push(mesh.stats().stages);
        }
    }
    for (k, _) in tiers.iter().enumerate() {
        dmesh_engine::simd::limit(tiers[k]);
        report(w, h, threads, &mut times[k], &stages[k]);
    }
}

/// Prints the minimum and median build and the median of each stage.
fn report(
    w: u32,
    h: u32,
    threads: dmesh_engine::mesh::Threads,
    times: &mut [std::time::Duration],
    stages: &[dmesh_engine::mesh::Stages],
) {
    times.sort();
    println!(
        "{w}x{h} {threads:?} {}: min {:?} median {:?}",
        dmesh_engine::simd::tier_in_use().name(),
        times[0],
        times[times.len() / 2]
    );
    let median = |f: fn(&dmesh_engine::mesh::Stages) -> f64| {
        let mut v: Vec<f64> = stages.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "stage medians ms: depths {:.2} normals {:.2} flags {:.2} finest {:.2} coarse {:.2} border {:.2}",
        median(|s| s.depths_ms),
        median(|s| s.normals_ms),
        median(|s| s.flags_ms),
        median(|s| s.finest_ms),
        median(|s| s.coarse_ms),
        median(|s| s.border_ms),
    );
}
