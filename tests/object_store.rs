//! The object-store backend against real S3 API servers: the same contract
//! as the file store (put, replace, versions, listing, deletes), replaces
//! that readers never see torn, and the server killed and restarted during
//! uploads (s3s-fs keeps its files): no acknowledged view lost, no torn
//! view, `Unavailable` (the server's 503) while it is down.

// The engine's mesh checks (conforming triangulations), shared with its tests.
#[path = "../engine/tests/common/mod.rs"]
mod common;
mod server_support;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use dmesh::store::{FileStore, StoreError, StoredView, ViewStore};
use dmesh_engine::mesh::SegmentationSpec;
use server_support::s3::{Kind, S3Server};

/// A view whose depth, colour and camera all carry `seed`, so a mix of two
/// versions is detectable.
fn view(seed: u32) -> StoredView {
    let n = 64 * 48;
    StoredView {
        camera: dmesh_proto::Camera {
            width: 64,
            height: 48,
            projection: dmesh_proto::Projection::Perspective {
                fx: 50.0 + f64::from(seed),
                fy: 50.0,
                cx: 31.5,
                cy: 23.5,
            },
            pose: dmesh_proto::Pose::default(),
        },
        segmentation: SegmentationSpec::default(),
        z: vec![1.0 + seed as f32; n],
        raw_grid: None,
        color: seed.to_le_bytes().repeat(1000).into(),
    }
}

/// The seed of a view, checking all three parts agree.
fn seed_of(v: &StoredView) -> u32 {
    let from_depth = (v.z[0] - 1.0) as u32;
    let from_color = u32::from_le_bytes(v.color[..4].try_into().unwrap());
    let dmesh_proto::Projection::Perspective { fx, .. } = v.camera.projection else {
        panic!("projection changed")
    };
    assert!(v.z.iter().all(|&z| z == v.z[0]), "depth mixes versions");
    assert!(v.color.chunks(4).all(|c| c == &v.color[..4]), "colour mixes versions");
    assert_eq!(from_depth, from_color, "depth and colour of different versions");
    assert_eq!(fx as u32 - 50, from_depth, "camera and depth of different versions");
    from_depth
}

fn contract(store: &dyn ViewStore) {
    assert!(store.scenes().unwrap().is_empty());
    assert!(store.listing("s").unwrap().is_none());
    assert_eq!(store.scene_version("s").unwrap(), None);
    // Every put and delete changes the scene's version by the time it returns.
    let mut scene_versions = Vec::new();
    let mut scene_changed = |store: &dyn ViewStore| {
        let v = store.scene_version("s").unwrap().expect("the scene exists");
        assert!(!scene_versions.contains(&v), "the scene's version {v} came back");
        scene_versions.push(v);
    };
    let a1 = store.put("s", "a", &view(1)).unwrap();
    scene_changed(store);
    let b = store.put("s", "b", &view(2)).unwrap();
    scene_changed(store);
    assert_eq!(store.version("s", "a").unwrap().as_ref(), Some(&a1));
    let a2 = store.put("s", "a", &view(3)).unwrap();
    assert_ne!(a1, a2, "a replace changes the version");
    scene_changed(store);
    // Reads change nothing.
    let now = store.scene_version("s").unwrap();
    assert_eq!(now, store.scene_version("s").unwrap());
    assert_eq!(store.get("s", "a").unwrap().unwrap(), (view(3), a2.clone()));
    assert_eq!(store.camera("s", "a").unwrap(), Some((view(3).camera, a2.clone())));
    assert_eq!(store.camera("s", "nope").unwrap(), None);
    assert_eq!(store.get("s", "nope").unwrap(), None);
    assert_eq!(store.version("s", "nope").unwrap(), None);
    assert_eq!(
        store.listing("s").unwrap().unwrap(),
        vec![("a".to_string(), a2), ("b".to_string(), b)]
    );
    assert_eq!(store.scenes().unwrap(), vec!["s"]);
    assert!(store.bytes_stored().unwrap() > 2 * 64 * 48 * 4);
    assert!(matches!(store.put("..", "a", &view(1)), Err(StoreError::BadId(_))));
    assert!(matches!(store.get("s", "a/b"), Err(StoreError::BadId(_))));
    assert!(store.delete_view("s", "a").unwrap());
    scene_changed(store);
    assert!(!store.delete_view("s", "a").unwrap());
    assert!(store.get("s", "a").unwrap().is_none());
    // A scene with no views left still exists, as a directory does.
    store.delete_view("s", "b").unwrap();
    assert_eq!(store.views("s").unwrap(), Some(vec![]));
    store.put("t", "x", &view(4)).unwrap();
    assert!(store.delete_scene("s").unwrap());
    assert!(!store.delete_scene("s").unwrap());
    assert_eq!(store.scene_version("s").unwrap(), None);
    assert_eq!(store.scenes().unwrap(), vec!["t"]);
}

#[test]
fn the_file_store_keeps_the_contract() {
    let dir = tempfile::tempdir().unwrap();
    contract(&FileStore::open(dir.path()).unwrap());
}

#[test]
fn the_object_store_keeps_the_contract_on_moto_and_s3s_fs() {
    for kind in [Kind::Moto, Kind::S3sFs] {
        let server = S3Server::start(kind);
        contract(&server.store("p"));
        // A store under another prefix of the same bucket sees none of it.
        assert!(server.store("other").scenes().unwrap().is_empty(), "{kind:?}");
        // A replica's note: kept, replaced, and never taken for a scene.
        let store = server.store("p");
        assert_eq!(store.get_note("r1").unwrap(), None);
        store.put_note("r1", b"[1]").unwrap();
        store.put_note("r1", b"[2]").unwrap();
        assert_eq!(store.get_note("r1").unwrap().as_deref(), Some(&b"[2]"[..]), "{kind:?}");
        assert!(matches!(store.put_note("../x", b""), Err(StoreError::BadId(_))));
        assert_eq!(store.scenes().unwrap(), vec!["t"], "{kind:?}");
    }
}

#[test]
fn only_the_current_version_of_a_view_is_kept() {
    let server = S3Server::start(Kind::S3sFs);
    let store = server.store("p");
    for seed in 0..5 {
        store.put("s", "a", &view(seed)).unwrap();
    }
    let bytes = store.bytes_stored().unwrap();
    // Data of the current version, its manifest and the scene marker.
    let data = dmesh::store::dmv::encode(view(4).parts()).unwrap().len() as u64;
    assert!(
        bytes >= data && bytes < data + 4096,
        "{bytes} bytes held for one view of {data}"
    );
}

#[test]
fn readers_never_see_a_torn_replace() {
    let server = S3Server::start(Kind::Moto);
    let store = Arc::new(server.store("p"));
    store.put("s", "a", &view(0)).unwrap();
    let done = Arc::new(AtomicBool::new(false));
    let readers: Vec<_> = (0..2)
        .map(|_| {
            let (store, done) = (store.clone(), done.clone());
            std::thread::spawn(move || {
                let mut seen = Vec::new();
                while !done.load(Ordering::Relaxed) {
                    let (v, _) = store.get("s", "a").unwrap().expect("the view never disappears");
                    seen.push(seed_of(&v));
                }
                seen
            })
        })
        .collect();
    for seed in 1..=20 {
        store.put("s", "a", &view(seed)).unwrap();
    }
    done.store(true, Ordering::Relaxed);
    for r in readers {
        let seen = r.join().unwrap();
        assert!(!seen.is_empty());
        // Each reader sees versions in the order they were written.
        assert!(seen.windows(2).all(|w| w[0] <= w[1]), "{seen:?}");
    }
    assert_eq!(seed_of(&store.get("s", "a").unwrap().unwrap().0), 20);
}

#[test]
fn a_store_killed_during_uploads_loses_no_acknowledged_view_and_tears_none() {
    let mut server = S3Server::start(Kind::S3sFs);
    let store = Arc::new(server.store("p"));
    let writer = {
        let store = store.clone();
        std::thread::spawn(move || {
            // (view, seed) of every acknowledged put, and the failures.
            let mut acked = std::collections::HashMap::new();
            let mut failures = Vec::new();
            let started = std::time::Instant::now();
            let mut seed = 0;
            while started.elapsed() < std::time::Duration::from_secs(6) {
                seed += 1;
                let name = format!("v{}", seed % 7);
                match store.put("s", &name, &view(seed)) {
                    Ok(_) => {
                        acked.insert(name, seed);
                    }
                    Err(e) => failures.push(e),
                }
            }
            (acked, failures)
        })
    };
    std::thread::sleep(std::time::Duration::from_millis(1500));
    server.kill();
    // While it is down the store says so, quickly, and no read panics.
    let started = std::time::Instant::now();
    let down = store.get("s", "v1");
    assert!(matches!(down, Err(StoreError::Unavailable(_))), "{down:?}");
    assert!(
        started.elapsed() < std::time::Duration::from_secs(8),
        "{:?}",
        started.elapsed()
    );
    std::thread::sleep(std::time::Duration::from_millis(1000));
    server.restart();
    let (acked, failures) = writer.join().unwrap();
    assert!(
        !failures.is_empty(),
        "the outage failed no upload: the test did not test"
    );
    assert!(
        failures.iter().all(|e| matches!(e, StoreError::Unavailable(_))),
        "{failures:?}"
    );
    assert!(acked.len() == 7, "{acked:?}");
    // A store opened afresh (a new replica) holds every acknowledged view,
    // whole, at its last acknowledged version or a later attempted one.
    let fresh = server.store("p");
    for (name, seed) in &acked {
        let (v, _) = fresh.get("s", name).unwrap().unwrap_or_else(|| panic!("{name} lost"));
        let got = seed_of(&v);
        assert!(got >= *seed, "{name}: acknowledged {seed}, read {got}");
    }
}

/// What each server does with a create-only PUT (`If-None-Match: *`). The
/// backend relies on none of it; this records what was seen, so a change in
/// a server shows up here.
#[test]
fn create_only_puts_as_each_server_honours_them() {
    use object_store::{ObjectStore, ObjectStoreExt, PutMode, PutOptions};
    for (kind, honoured) in [(Kind::Moto, true), (Kind::S3sFs, true)] {
        let server = S3Server::start(kind);
        let mut builder = object_store::aws::AmazonS3Builder::new().with_bucket_name(&server.bucket);
        for (k, v) in server.vars() {
            builder = builder.with_config(k.to_ascii_lowercase().parse().unwrap(), v);
        }
        let s3 = builder.build().unwrap();
        let rt = tokio::runtime::Runtime::new().unwrap();
        let path = object_store::path::Path::from("probe");
        let create = || PutOptions {
            mode: PutMode::Create,
            ..Default::default()
        };
        rt.block_on(s3.put_opts(&path, b"one".to_vec().into(), create()))
            .unwrap();
        let second = rt.block_on(s3.put_opts(&path, b"two".to_vec().into(), create()));
        let kept = rt.block_on(async { s3.get(&path).await.unwrap().bytes().await.unwrap() });
        assert_eq!(
            (second.is_err(), kept.as_ref() == b"one"),
            (honoured, honoured),
            "{kind:?}: second create-only PUT {second:?}, object now {kept:?}"
        );
    }
}
