//! Synthetic VEM data and the measures the tests and benchmarks judge the decomposer by.

pub mod lag;
pub mod metrics;
pub mod sunny;
pub mod synth;
