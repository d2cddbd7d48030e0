//! The integration tests, one binary.
//!
//! Each file is a module named after it (`cargo test --test integration stereo::`). One binary
//! links the crate and its dependencies once, not once per file: the test build is the largest
//! part of CI's time.
//!
//! The counting allocator (`common/counting_alloc.rs`) is installed for every module: it counts
//! per thread, so the modules that assert a path allocates nothing are not disturbed by tests
//! running on other threads, and the others pay one thread-local increment per allocation.

mod architecture;
mod common;
#[path = "common/counting_alloc.rs"]
mod counting_alloc;
#[path = "common/fit_harness.rs"]
mod fit_harness;

#[global_allocator]
static A: counting_alloc::Counting = counting_alloc::Counting;

mod bank_accuracy;
mod batch;
mod build_up;
mod censoring;
mod cli;
mod dense;
mod derived_presets;
mod eval;
mod fit_damping;
mod fit_extract;
mod fit_formats;
mod fit_inputs;
mod fit_plot;
mod fit_presets;
mod fit_recordings;
mod gestures;
mod impacts;
mod impacts_engine;
mod licences;
mod measured;
mod plugin_fit;
mod plugin_gestures;
mod plugin_limiter;
mod plugin_midi;
mod plugin_pad;
mod plugin_process;
mod ring;
mod scene_objects;
mod scrape_roll;
mod stereo;
mod stress;
mod surfaces;
mod sustained_engine;
mod sustained_timbre;
mod velocity;
