//! The installable archive of `cargo xtask dist`.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use zip::write::SimpleFileOptions;

/// The files every archive holds beside the bundles and the CLI: (path in the repository, name in
/// the archive).
const DOCUMENTS: [(&str, &str); 4] = [
    ("README.md", "README.md"),
    ("LICENSE", "LICENSE"),
    ("docs/licenses/third-party.md", "licenses/third-party.md"),
    ("docs/licenses/measured-data.txt", "licenses/measured-data.txt"),
];

/// Writes `target/dist/tactus-<version>-<platform>.zip` from the bundles in `target/bundled/` and
/// the CLI in `profile_dir`, and returns its path.
pub fn package(
    target_dir: &Path,
    profile_dir: &Path,
    version: &str,
    args: &[String],
) -> anyhow::Result<PathBuf> {
    let (platform, exe) = platform(args);
    let bundled = target_dir.join("bundled");
    let cli = profile_dir.join(format!("tactus{exe}"));
    let mut inputs: Vec<(PathBuf, String)> = vec![
        (bundled.join("Tactus.clap"), "Tactus.clap".into()),
        (cli, format!("tactus{exe}")),
    ];
    for (from, to) in DOCUMENTS {
        inputs.push((PathBuf::from(from), to.into()));
    }
    for (path, _) in &inputs {
        anyhow::ensure!(path.is_file(), "{}: missing, cannot package it", path.display());
    }
    let vst3 = bundled.join("Tactus.vst3");
    anyhow::ensure!(vst3.is_dir(), "{}: missing, cannot package it", vst3.display());

    let root = format!("tactus-{version}-{platform}");
    let dir = target_dir.join("dist");
    std::fs::create_dir_all(&dir)?;
    let path = dir.join(format!("{root}.zip"));
    let mut zip =
        zip::ZipWriter::new(File::create(&path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?);
    let options = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    for (from, to) in &inputs {
        add_file(&mut zip, from, &format!("{root}/{to}"), options)?;
    }
    // target/bundled/Tactus.vst3 keeps the binaries of every platform bundled into it (a Linux
    // and a Windows build in one checkout); the archive takes only this platform's.
    let arch_dir = vst3_arch_dir(&platform);
    zip.add_directory(format!("{root}/Tactus.vst3/"), options)?;
    zip.add_directory(format!("{root}/Tactus.vst3/Contents/"), options)?;
    let ours = vst3.join("Contents").join(&arch_dir);
    anyhow::ensure!(ours.is_dir(), "{}: missing, cannot package it", ours.display());
    add_tree(
        &mut zip,
        &ours,
        &format!("{root}/Tactus.vst3/Contents/{arch_dir}"),
        options,
    )?;
    zip.finish()?;
    Ok(path)
}

/// The VST3 bundle's folder for `platform` (`<os>-<arch>`), as the VST3 SDK names them.
fn vst3_arch_dir(platform: &str) -> String {
    let (os, arch) = platform.split_once('-').unwrap_or((platform, ""));
    match os {
        "windows" => format!("{arch}-win"),
        "macos" => "MacOS".into(),
        _ => format!("{arch}-{os}"),
    }
}

/// `(platform name, executable suffix)` of the `--target` in `args`, else of this machine.
fn platform(args: &[String]) -> (String, &'static str) {
    let mut it = args.iter();
    let mut triple = None;
    while let Some(a) = it.next() {
        if let Some(t) = a.strip_prefix("--target=") {
            triple = Some(t.to_string());
        } else if a == "--target" {
            triple = it.next().cloned();
        }
    }
    match triple {
        Some(t) => {
            let arch = t.split('-').next().unwrap_or("unknown").to_string();
            let os = ["windows", "linux", "darwin"]
                .into_iter()
                .find(|os| t.contains(os))
                .map(|os| if os == "darwin" { "macos" } else { os })
                .unwrap_or("unknown");
            (format!("{os}-{arch}"), if os == "windows" { ".exe" } else { "" })
        }
        None => (
            format!("{}-{}", std::env::consts::OS, std::env::consts::ARCH),
            std::env::consts::EXE_SUFFIX,
        ),
    }
}

fn add_file(
    zip: &mut zip::ZipWriter<File>,
    from: &Path,
    to: &str,
    options: SimpleFileOptions,
) -> anyhow::Result<()> {
    let data = std::fs::read(from).map_err(|e| anyhow::anyhow!("{}: {e}", from.display()))?;
    let mode = permissions(from);
    zip.start_file(to, options.unix_permissions(mode))?;
    zip.write_all(&data)?;
    println!("  {to}");
    Ok(())
}

fn add_tree(
    zip: &mut zip::ZipWriter<File>,
    from: &Path,
    to: &str,
    options: SimpleFileOptions,
) -> anyhow::Result<()> {
    zip.add_directory(format!("{to}/"), options)?;
    let mut entries: Vec<_> = std::fs::read_dir(from)?.collect::<Result<_, _>>()?;
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let name = format!("{to}/{}", e.file_name().to_string_lossy());
        if e.file_type()?.is_dir() {
            add_tree(zip, &e.path(), &name, options)?;
        } else {
            add_file(zip, &e.path(), &name, options)?;
        }
    }
    Ok(())
}

/// The file's Unix mode (executables stay executable when unpacked on Linux and macOS).
#[cfg(unix)]
fn permissions(path: &Path) -> u32 {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path)
        .map(|m| m.permissions().mode() & 0o777)
        .unwrap_or(0o644)
}

#[cfg(not(unix))]
fn permissions(_: &Path) -> u32 {
    0o644
}
