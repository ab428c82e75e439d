//! Change counters per scene and per view, so that what was read from the
//! store before a change is not cached after it.

/// Change counters, so that what was read from the store before a change
/// is not cached after it. Counted per scene and per view, in 64 buckets
/// each: a change to one view does not stop another from being cached (with
/// one global counter, an uploader busy on one scene left every other view
/// it fetched uncached, rebuilt on each request), and two keys sharing a
/// bucket only cost a skipped cache insert.
pub(super) struct Changes {
    scenes: [std::sync::atomic::AtomicU64; 64],
    views: [std::sync::atomic::AtomicU64; 64],
}

impl Default for Changes {
    fn default() -> Self {
        Self {
            scenes: std::array::from_fn(|_| Default::default()),
            views: std::array::from_fn(|_| Default::default()),
        }
    }
}

impl Changes {
    pub(super) fn bucket(parts: &[&str]) -> usize {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        parts.hash(&mut h);
        (h.finish() % 64) as usize
    }

    pub(super) fn scene(&self, scene: &str) -> u64 {
        self.scenes[Self::bucket(&[scene])].load(std::sync::atomic::Ordering::SeqCst)
    }

    pub(super) fn view(&self, scene: &str, view: &str) -> u64 {
        self.views[Self::bucket(&[scene, view])].load(std::sync::atomic::Ordering::SeqCst)
    }

    /// A change to `view` of `scene`, or to all its views when `None`.
    pub(super) fn bump(&self, scene: &str, view: Option<&str>) {
        use std::sync::atomic::Ordering::SeqCst;
        self.scenes[Self::bucket(&[scene])].fetch_add(1, SeqCst);
        match view {
            Some(v) => {
                self.views[Self::bucket(&[scene, v])].fetch_add(1, SeqCst);
            }
            None => {
                for c in &self.views {
                    c.fetch_add(1, SeqCst);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Changes;

    #[test]
    fn a_change_counts_against_its_own_view_and_scene_only() {
        let c = Changes::default();
        // Two keys in different buckets (the buckets are deterministic).
        let other = (0..64)
            .map(|k| format!("b{k}"))
            .find(|s| {
                Changes::bucket(&[s]) != Changes::bucket(&["a"])
                    && Changes::bucket(&[s, "w"]) != Changes::bucket(&["a", "v"])
            })
            .unwrap();
        let (scene, view) = (c.scene(&other), c.view(&other, "w"));
        let (own_scene, own_view) = (c.scene("a"), c.view("a", "v"));
        c.bump("a", Some("v"));
        assert_eq!((c.scene(&other), c.view(&other, "w")), (scene, view));
        assert!(c.scene("a") > own_scene && c.view("a", "v") > own_view);
        // A whole scene's change reaches every view.
        c.bump("a", None);
        assert!(c.view(&other, "w") > view);
    }
}
