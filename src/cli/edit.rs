//! `uvpin edit`: the daemon on one constraint file, with the editor served.

use super::{LogArg, fail};
use crate::config::{LogFormat, OutputMode};
use std::path::{Component, Path, PathBuf};
use std::process::ExitCode;

/// `uvpin edit`'s arguments.
#[derive(Debug, clap::Args)]
pub struct EditArgs {
    /// The constraint file (`*.uvpin.ron`); created with --asset if it does
    /// not exist.
    constraints: PathBuf,
    /// The mesh a new constraint file names (.glb, .gltf or .obj).
    #[arg(long, value_name = "MESH")]
    asset: Option<PathBuf>,
    /// Where the editor is served (port 0: any free port).
    #[arg(long, value_name = "HOST:PORT", default_value = crate::edit::server::DEFAULT_ADDR)]
    addr: String,
    /// Write the output into this folder (default `out`, as `uvpin watch`).
    #[arg(long, conflicts_with = "in_place")]
    out: Option<PathBuf>,
    /// Write the UVs back into the asset itself.
    #[arg(long)]
    in_place: bool,
    /// Open the page in the default browser.
    #[arg(long)]
    open: bool,
    /// Configuration file: its `watch` and `solver` sections.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Also read assets, buffers and images inside this folder (repeatable).
    #[arg(long, value_name = "DIR")]
    allow: Vec<PathBuf>,
    /// Log format.
    #[arg(long, value_enum)]
    log: Option<LogArg>,
    /// While a target is dragged, a chart of more vertices than this is
    /// shown on its coarse level (about a thousand vertices, the landmarks
    /// exact), and solved in full on release.
    #[arg(long, value_name = "N", default_value_t = crate::edit::preview::COARSE_ABOVE)]
    coarse_above: usize,
}

/// `target` relative to the folder `base` (both absolute), with `..` where
/// needed; `target` itself when they share no root.
fn relative_to(target: &Path, base: &Path) -> PathBuf {
    let t: Vec<Component> = target.components().collect();
    let b: Vec<Component> = base.components().collect();
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return target.to_path_buf();
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    out
}

/// Why `uvpin edit` cannot set up its constraint file.
#[derive(Debug, thiserror::Error)]
enum SetupError {
    #[error("{}: a constraint file's name must end with {suffix}", file.display())]
    Suffix { file: PathBuf, suffix: String },
    #[error("{} does not exist: give --asset MESH to create it", file.display())]
    NoAsset { file: PathBuf },
    #[error("--asset {}: not a file", asset.display())]
    NotAFile { asset: PathBuf },
    #[error("{}: {source}", path.display())]
    Path { path: PathBuf, source: std::io::Error },
    #[error("{}", .0.message)]
    Write(crate::io::atomic::WriteError),
}

/// Creates the constraint file for `asset` if it does not exist; the
/// folders of the asset and the image it names (read by the daemon besides
/// its own: the file names them).
fn prepare_file(constraints: &Path, asset: Option<&Path>, suffix: &str) -> Result<Vec<PathBuf>, SetupError> {
    let name = constraints
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if !name.ends_with(suffix) {
        return Err(SetupError::Suffix {
            file: constraints.to_path_buf(),
            suffix: suffix.to_string(),
        });
    }
    let at = |path: &Path| {
        let path = path.to_path_buf();
        move |source| SetupError::Path { path, source }
    };
    let file = std::path::absolute(constraints).map_err(at(constraints))?;
    let folder = file.parent().unwrap_or(Path::new("/")).to_path_buf();
    if file.exists() {
        if asset.is_some() {
            eprintln!(
                "note: {} exists; it names its own asset (--asset is for new files)",
                constraints.display()
            );
        }
        let named = crate::constraints::LoadedConstraints::load(&file)
            .map(|l| [Some(l.asset_path()), l.image_path()])
            .unwrap_or_default();
        let folders = named
            .into_iter()
            .flatten()
            .filter_map(|p| p.parent().map(Path::to_path_buf));
        return Ok(folders.collect());
    }
    let Some(asset) = asset else {
        return Err(SetupError::NoAsset {
            file: constraints.to_path_buf(),
        });
    };
    if !asset.is_file() {
        return Err(SetupError::NotAFile {
            asset: asset.to_path_buf(),
        });
    }
    // Both without `..` or links, so the relative path climbs out right.
    let asset = asset.canonicalize().map_err(at(asset))?;
    let folder = folder.canonicalize().map_err(at(&folder))?;
    let named = relative_to(&asset, &folder);
    let text = crate::edit::text::new_file(&named.to_string_lossy());
    crate::io::atomic::write_atomically(&file, text.as_bytes()).map_err(SetupError::Write)?;
    eprintln!("created {} for {}", constraints.display(), named.display());
    Ok(asset.parent().map(Path::to_path_buf).into_iter().collect())
}

pub fn run(args: EditArgs) -> ExitCode {
    let config = match args.config.as_deref().map(crate::config::Config::load).transpose() {
        Ok(c) => c.unwrap_or_default(),
        Err(e) => return fail(&e),
    };
    let mut watch = config.watch;
    let named_folders = match prepare_file(&args.constraints, args.asset.as_deref(), &watch.constraint_suffix) {
        Ok(f) => f,
        Err(e) => return fail(&e),
    };
    watch.paths = vec![args.constraints];
    watch.allow_paths.extend(named_folders);
    watch.allow_paths.extend(args.allow);
    if let Some(out) = args.out {
        watch.output = OutputMode::Folder(out);
    }
    if args.in_place {
        watch.output = OutputMode::InPlace;
    }
    match args.log {
        Some(LogArg::Human) => watch.log = LogFormat::Human,
        Some(LogArg::Json) => watch.log = LogFormat::Json,
        None => {}
    }
    let options = crate::daemon::run::WatchOptions {
        config: watch,
        solver: config.solver,
        limits: config.limits,
        once: false,
    };
    let mut editor = crate::edit::publish::EditorAttachment::new(args.addr, args.open);
    editor.coarse_above = args.coarse_above;
    match crate::daemon::run::run(options, vec![Box::new(editor)]) {
        Ok(outcome) => ExitCode::from(outcome.exit_code()),
        Err(e) => fail(&format!("{e:#}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_climb_where_needed() {
        assert_eq!(
            relative_to(Path::new("/a/b/m.glb"), Path::new("/a/b")),
            PathBuf::from("m.glb")
        );
        assert_eq!(
            relative_to(Path::new("/a/m/x.glb"), Path::new("/a/b/c")),
            PathBuf::from("../../m/x.glb")
        );
    }
}
