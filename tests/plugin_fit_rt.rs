//! Fitting ten recordings in the plugin under nice-plug's own real-time check
//! (`assert_process_allocs`, feature `rt-checks`): the editor's fit path ([`FitJob`]) runs on
//! its worker while every `process` call runs inside nice-plug's `assert_no_alloc`, as its VST3
//! and CLAP wrappers run it. Any allocation or free inside `process` aborts the test binary
//! ("memory allocation of N bytes failed"), which fails the run.
//!
//! Only built with `--features rt-checks` (`Cargo.toml` `required-features`): the feature makes
//! nice-plug's checking allocator the global allocator, and the other plugin tests install a
//! counting allocator of their own.
//!
//! [`FitJob`]: tactus::plugin::fit_job::FitJob

#[path = "integration/common/mod.rs"]
mod common;
#[path = "integration/common/fit_harness.rs"]
mod fit_harness;

/// One `process` call inside nice-plug's checker; it aborts on an allocation, so a call that
/// returns made none.
fn checked(f: &mut dyn FnMut()) -> u64 {
    nice_assert_no_alloc::assert_no_alloc(f);
    0
}

// nice-plug installs its checker only in builds with debug assertions (its own `cfg`), and
// `nice-assert-no-alloc` is a no-op without them: a release run would check nothing.
#[test]
#[cfg_attr(
    not(debug_assertions),
    ignore = "SKIPPED: nice-plug checks allocations only with debug assertions (dev profile)"
)]
fn fitting_ten_recordings_under_assert_process_allocs() {
    fit_harness::fit_ten_while_processing(&checked);
}
