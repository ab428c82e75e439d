//! Reference-view selection and blending weights for a novel camera (DMesh Sec. 6.2).

pub mod selection;

pub use selection::{select_views, selection_spread, SelectionRule, Weighted, MIN_SHARE};
