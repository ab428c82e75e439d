//! A `tracing` subscriber that keeps when each of the engine's spans ran
//! and on which thread: `build_timeline` prints it, and
//! `tests/build_timeline.rs` checks a build's spans with it.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::thread::ThreadId;
use std::time::Instant;

use tracing::field::{Field, Visit};
use tracing::span::{Attributes, Id, Record};
use tracing::{Event, Metadata, Subscriber};

/// One span as it ran.
pub struct Span {
    pub thread: &'static str,
    pub from: f64,
    pub to: f64,
    pub name: String,
}

/// A subscriber that keeps, for the engine's spans since [`Self::restart`],
/// when each was entered and exited and on which thread (the thread that
/// called `restart` is the calling one, any other a helper).
pub struct Timeline {
    next: AtomicU64,
    state: Mutex<State>,
}

struct State {
    start: Instant,
    calling: ThreadId,
    names: HashMap<u64, String>,
    entered: HashMap<u64, Instant>,
    done: Vec<Span>,
}

impl Timeline {
    pub fn new() -> Self {
        Self {
            next: AtomicU64::new(1),
            state: Mutex::new(State {
                start: Instant::now(),
                calling: std::thread::current().id(),
                names: HashMap::new(),
                entered: HashMap::new(),
                done: Vec::new(),
            }),
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Forgets what was kept and counts from now.
    pub fn restart(&self) {
        let mut s = self.state();
        s.start = Instant::now();
        s.calling = std::thread::current().id();
        s.done.clear();
    }

    /// The spans kept, by start.
    pub fn spans(&self) -> Vec<Span> {
        let mut done = std::mem::take(&mut self.state().done);
        done.sort_by(|a, b| a.from.total_cmp(&b.from));
        done
    }
}

/// A span's name with its level, if it has one (`level 3`).
struct Name(String);

impl Visit for Name {
    fn record_u64(&mut self, field: &Field, value: u64) {
        self.0 = format!("{} {}={value}", self.0, field.name());
    }

    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        self.0 = format!("{} {}={value:?}", self.0, field.name());
    }
}

impl Subscriber for Timeline {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        metadata.is_span() && metadata.target().starts_with("dmesh_engine")
    }

    fn new_span(&self, span: &Attributes<'_>) -> Id {
        let id = self.next.fetch_add(1, Ordering::Relaxed);
        let mut name = Name(span.metadata().name().to_string());
        span.record(&mut name);
        self.state().names.insert(id, name.0);
        Id::from_u64(id)
    }

    fn record(&self, _: &Id, _: &Record<'_>) {}

    fn record_follows_from(&self, _: &Id, _: &Id) {}

    fn event(&self, _: &Event<'_>) {}

    fn enter(&self, span: &Id) {
        let now = Instant::now();
        self.state().entered.insert(span.into_u64(), now);
    }

    fn exit(&self, span: &Id) {
        let now = Instant::now();
        let mut s = self.state();
        let id = span.into_u64();
        let (Some(entered), Some(name)) = (s.entered.remove(&id), s.names.remove(&id)) else {
            return;
        };
        let ms = |t: Instant| t.saturating_duration_since(s.start).as_secs_f64() * 1e3;
        let thread = if std::thread::current().id() == s.calling {
            "calling"
        } else {
            "helper"
        };
        let span = Span {
            thread,
            from: ms(entered),
            to: ms(now),
            name,
        };
        s.done.push(span);
    }
}
