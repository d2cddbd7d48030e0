//! `cargo xtask bundle tactus --release`: builds the CLAP and VST3 bundles in `target/bundled/`.
//!
//! nice-plug-xtask also bundles any binary named like the package as a "standalone" application.
//! Tactus's binary of that name is the `tactus` command-line renderer, not a standalone plugin
//! host, so `bundle` hides it from the bundler (renamed for the bundling step only, restored
//! afterwards even on error): no `target/bundled/Tactus` copy of the CLI and no "Created a
//! standalone bundle" message.
//!
//! `cargo xtask dist [--target <triple>]`: the bundles and the CLI built in release, then one zip
//! per platform in `target/dist/`, `tactus-<version>-<platform>.zip`, holding the CLAP and VST3
//! bundles, the `tactus` CLI, README.md, LICENSE and the licence notices of everything compiled
//! into them (docs/licenses/: the crates', generated from Cargo.lock by cargo-about, and the
//! measured data's). The archive's contents are listed as they are written.
//!
//! Every other command goes to nice-plug-xtask unchanged.

use std::path::{Path, PathBuf};

mod dist;

fn main() -> nice_plug_xtask::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dist = match args.first().map(String::as_str) {
        Some("bundle") => false,
        Some("dist") => true,
        _ => return nice_plug_xtask::main(),
    };
    nice_plug_xtask::chdir_workspace_root()?;
    let metadata = cargo_metadata::MetadataCommand::new()
        .manifest_path("./Cargo.toml")
        .no_deps()
        .exec()?;
    let target_dir = metadata.target_directory.clone().into_std_path_buf();
    if dist {
        let version = metadata
            .packages
            .iter()
            .find(|p| p.name.as_str() == "tactus")
            .map(|p| p.version.to_string())
            .ok_or_else(|| anyhow::anyhow!("no package `tactus` in the workspace"))?;
        // Always a release build, whether or not `--release` was given.
        let mut other = vec!["--release".to_string()];
        other.extend(args[1..].iter().filter(|a| *a != "--release").cloned());
        build_and_bundle(&target_dir, &["tactus".to_string()], &other)?;
        let zip = dist::package(&target_dir, &profile_dir(&target_dir, &other), &version, &other)?;
        println!("wrote {}", zip.display());
        return Ok(());
    }
    let (packages, other) = split_bundle_args(&args[1..])?;
    build_and_bundle(&target_dir, &packages, &other)
}

/// `cargo build` of `packages` with `other`, then their bundles, the CLI hidden from the bundler.
fn build_and_bundle(target_dir: &Path, packages: &[String], other: &[String]) -> nice_plug_xtask::Result<()> {
    nice_plug_xtask::build(packages, other)?;
    let profile_dir = profile_dir(target_dir, other);
    for package in packages {
        let bin = profile_dir.join(format!("{}{}", package.replace('-', "_"), exe_suffix(other)));
        let _hidden = Hidden::new(&bin)?;
        nice_plug_xtask::bundle(target_dir, package, other, false)?;
    }
    Ok(())
}

/// `bundle <package> [args]` or `bundle -p a -p b [args]`, as nice-plug-xtask reads them.
fn split_bundle_args(args: &[String]) -> nice_plug_xtask::Result<(Vec<String>, Vec<String>)> {
    let mut packages = Vec::new();
    let mut rest = args;
    if rest.first().map(String::as_str) == Some("-p") {
        while let [p, name, tail @ ..] = rest {
            if p != "-p" {
                break;
            }
            packages.push(name.clone());
            rest = tail;
        }
    } else if let [name, tail @ ..] = rest {
        packages.push(name.clone());
        rest = tail;
    }
    if packages.is_empty() {
        anyhow::bail!("usage: cargo xtask bundle <package> [--release]");
    }
    Ok((packages, rest.to_vec()))
}

/// The folder cargo built into: `target[/<triple>]/<debug|release|profile>`, read from the
/// arguments the way nice-plug-xtask reads them.
fn profile_dir(target_dir: &Path, args: &[String]) -> PathBuf {
    let mut profile = "debug".to_string();
    let mut triple = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--release" => profile = "release".into(),
            "--profile" => profile = it.next().cloned().unwrap_or(profile),
            "--target" => triple = it.next().cloned(),
            _ => {
                if let Some(p) = a.strip_prefix("--profile=") {
                    profile = p.into();
                } else if let Some(t) = a.strip_prefix("--target=") {
                    triple = Some(t.into());
                }
            }
        }
    }
    let base = match triple {
        Some(t) => target_dir.join(t),
        None => target_dir.to_path_buf(),
    };
    base.join(profile)
}

/// The executable suffix of the target being built (`--target`), else of this machine: a
/// Windows build from Linux makes `tactus.exe`, which must be hidden as well.
fn exe_suffix(args: &[String]) -> &'static str {
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let triple = match a.strip_prefix("--target=") {
            Some(t) => Some(t),
            None if a == "--target" => it.next().map(String::as_str),
            None => None,
        };
        if let Some(t) = triple {
            return if t.contains("windows") { ".exe" } else { "" };
        }
    }
    std::env::consts::EXE_SUFFIX
}

/// A binary renamed out of the bundler's sight until dropped.
struct Hidden {
    path: PathBuf,
    aside: PathBuf,
}

impl Hidden {
    fn new(path: &Path) -> nice_plug_xtask::Result<Option<Hidden>> {
        if !path.exists() {
            return Ok(None);
        }
        let aside = path.with_extension("xtask-hidden");
        std::fs::rename(path, &aside)?;
        Ok(Some(Hidden {
            path: path.to_path_buf(),
            aside,
        }))
    }
}

impl Drop for Hidden {
    fn drop(&mut self) {
        if let Err(e) = std::fs::rename(&self.aside, &self.path) {
            eprintln!(
                "error: could not move {} back to {}: {e}",
                self.aside.display(),
                self.path.display()
            );
        }
    }
}
