//! The admission limits: slots for reads (renders, strips, summaries:
//! CPU-bound) and for uploads, and the read slot an upload's build takes
//! ahead of the reads waiting for one.
//!
//! A read waits for its slot in arrival order (tokio's semaphore is fair),
//! at most the pipeline's `queue_wait`. A build that queued behind them
//! would wait for every read ahead of it to run: with eight clients
//! rendering on two cores, several renders (going ahead took 3-4 ms off a
//! 640 x 480 live frame's median time to visible, and more off its tail:
//! docs/live-journal.md). So while a build waits,
//! a read that gets a slot hands it on at once and waits until the build
//! has one: the build runs as soon as one running read ends.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use tokio::sync::{Notify, Semaphore, SemaphorePermit};

/// Slots for reads and uploads.
pub struct Slots {
    reads: Semaphore,
    uploads: Semaphore,
    /// Longest a request waits for a slot before it is shed.
    pub(super) wait: Duration,
    /// Builds waiting for a read slot.
    builds_waiting: AtomicUsize,
    /// Told when a waiting build got its slot.
    build_started: Notify,
}

impl Slots {
    /// `reads` and `uploads` slots (at least one each), waits of at most
    /// `wait`.
    pub fn new(reads: usize, uploads: usize, wait: Duration) -> Self {
        Self {
            reads: Semaphore::new(reads.max(1)),
            uploads: Semaphore::new(uploads.max(1)),
            wait,
            builds_waiting: AtomicUsize::new(0),
            build_started: Notify::new(),
        }
    }

    /// An upload slot now, if one is free.
    pub fn try_upload(&self) -> Option<SemaphorePermit<'_>> {
        self.uploads.try_acquire().ok()
    }

    /// An upload slot, in arrival order.
    pub async fn upload(&self) -> Option<SemaphorePermit<'_>> {
        self.uploads.acquire().await.ok()
    }

    /// A read slot now, if one is free and no build waits for it.
    pub fn try_read(&self) -> Option<SemaphorePermit<'_>> {
        if self.builds_waiting.load(Ordering::Acquire) > 0 {
            return None;
        }
        self.reads.try_acquire().ok()
    }

    /// A read slot, in arrival order among reads, after any build waiting.
    pub async fn read(&self) -> Option<SemaphorePermit<'_>> {
        loop {
            self.builds_gone().await;
            let permit = self.reads.acquire().await.ok()?;
            if self.builds_waiting.load(Ordering::Acquire) == 0 {
                return Some(permit);
            }
            // A build started waiting meanwhile: the slot is its.
            drop(permit);
        }
    }

    /// A read slot for a build, ahead of the reads waiting.
    pub async fn build(&self) -> Option<SemaphorePermit<'_>> {
        self.builds_waiting.fetch_add(1, Ordering::AcqRel);
        let permit = self.reads.acquire().await;
        self.builds_waiting.fetch_sub(1, Ordering::AcqRel);
        self.build_started.notify_waiters();
        permit.ok()
    }

    /// Returns once no build waits for a read slot.
    async fn builds_gone(&self) {
        loop {
            let started = self.build_started.notified();
            tokio::pin!(started);
            // Registered before the check, so a build that gets its slot
            // in between still wakes this.
            started.as_mut().enable();
            if self.builds_waiting.load(Ordering::Acquire) == 0 {
                return;
            }
            started.await;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// With every read slot taken and reads queued, a build gets the next
    /// slot that frees; the queued reads follow.
    #[tokio::test]
    async fn a_build_goes_ahead_of_the_queued_reads() {
        let slots = Arc::new(Slots::new(1, 1, Duration::from_secs(1)));
        let running = slots.try_read().expect("a free slot");
        let order = Arc::new(std::sync::Mutex::new(Vec::new()));
        let mut tasks = Vec::new();
        for i in 0..3 {
            let (slots, order) = (slots.clone(), order.clone());
            tasks.push(tokio::spawn(async move {
                let _slot = slots.read().await.expect("a slot");
                order.lock().unwrap().push(format!("read {i}"));
                tokio::time::sleep(Duration::from_millis(5)).await;
            }));
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        let build = {
            let (slots, order) = (slots.clone(), order.clone());
            tokio::spawn(async move {
                let _slot = slots.build().await.expect("a slot");
                order.lock().unwrap().push("build".to_string());
                tokio::time::sleep(Duration::from_millis(5)).await;
            })
        };
        tokio::time::sleep(Duration::from_millis(10)).await;
        assert!(
            slots.try_read().is_none(),
            "a read never takes a slot a build waits for"
        );
        drop(running);
        build.await.unwrap();
        for t in tasks {
            t.await.unwrap();
        }
        let order = order.lock().unwrap().clone();
        assert_eq!(order.len(), 4);
        assert_eq!(order[0], "build", "{order:?}");
        assert!(slots.try_read().is_some(), "every slot is free again");
    }
}
