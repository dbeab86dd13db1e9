//! Equirectangular environment maps: the offline bake ([`bake`], Jensen §4.1) and the runtime
//! relighting ([`relight`], Jensen §4.2).
//!
//! The direction ↔ texel mapping is the crate-wide convention (crate docs, "Equirectangular
//! maps"), implemented once in [`crate::geometry::equirect`].

pub mod bake;
pub mod relight;
