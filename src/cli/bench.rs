//! `tactus bench`: run time against error for fixed scenes and levers.

use std::path::PathBuf;

/// The arguments of `tactus bench`.
#[derive(clap::Args)]
pub struct Args {
    /// Short run (< 60 s) for CI smoke tests.
    #[arg(long)]
    pub quick: bool,
    /// Output folder for results.md and time_vs_error.svg.
    #[arg(long, default_value = tactus::bench::DEFAULT_OUT, conflicts_with = "update_docs")]
    pub out: PathBuf,
    /// Write to docs/bench/ (the committed results the README quotes) instead of --out.
    #[arg(long)]
    pub update_docs: bool,
    /// Only rows whose scene name contains this text (case-insensitive); prints them and
    /// writes nothing (for profiling one scene).
    #[arg(long)]
    pub only: Option<String>,
    /// Run at most this SIMD variant of the kernels (default: the CPU's best), to measure on
    /// one machine what a CPU without AVX-512 (or without AVX2) runs.
    #[arg(long, value_enum)]
    pub kernel: Option<KernelArg>,
}

/// The SIMD variants `--kernel` takes.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum KernelArg {
    Portable,
    Avx2,
    Avx512,
}

/// `tactus bench`.
pub fn run(a: Args) -> anyhow::Result<()> {
    use tactus::engine::modal::Kernel;
    if let Some(k) = a.kernel {
        let kernel = match k {
            KernelArg::Portable => Kernel::Portable,
            KernelArg::Avx2 => Kernel::Avx2,
            KernelArg::Avx512 => Kernel::Avx512,
        };
        if !kernel.is_supported() {
            anyhow::bail!(
                "--kernel {kernel:?}: this CPU does not support it (its best is {:?})",
                Kernel::best()
            );
        }
        Kernel::limit(kernel);
    }
    let out = if a.update_docs {
        PathBuf::from(tactus::bench::DOCS_OUT)
    } else {
        a.out
    };
    tactus::bench::run(a.quick, &out, a.only.as_deref())
}
