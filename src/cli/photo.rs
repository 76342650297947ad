//! `uvpin photo`: the photo step lives in the Python package (MediaPipe's
//! face models ship in a Python wheel), so this runs `python -m uvpin.photo`
//! with the same arguments, or says how to install it.

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::{Command, ExitCode};

/// Lay a face photo onto a head mesh: landmarks found on the photo and on a
/// render of the head, paired, solved exactly and fold-free; the photo
/// becomes the model's base-colour texture.
///
/// Needs the Python package with its photo extra (`pip install
/// 'uvpin[photo]'`, CPython 3.11 or 3.12); `UVPIN_PYTHON` names the
/// interpreter (default `python3`). Exit code 0: every landmark reached; 2:
/// partial; 1: error (nothing written).
#[derive(Debug, clap::Args)]
pub struct PhotoArgs {
    /// The head mesh (.glb, .gltf, .obj, .ply, .stl, .off).
    head: PathBuf,
    /// The face photo (PNG or JPEG); optional with --template.
    photo: Option<PathBuf>,
    /// The textured model to write (.glb).
    #[arg(short, long)]
    output: PathBuf,
    /// The constraint file to write (default: OUTPUT's stem + .uvpin.ron).
    #[arg(long)]
    constraints: Option<PathBuf>,
    /// The before/after picture (default: OUTPUT's stem + .photo.png).
    #[arg(long)]
    picture: Option<PathBuf>,
    /// Write the JSON report here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Direction looked along into the face, e.g. 0,0,-1 (default: found).
    #[arg(long, allow_hyphen_values = true)]
    view: Option<String>,
    /// The head's up, e.g. 0,1,0 (default: found).
    #[arg(long, allow_hyphen_values = true)]
    up: Option<String>,
    /// A constraint file whose labelled targets are used by name.
    #[arg(long)]
    template: Option<PathBuf>,
    /// The UV set written (default: 1 beside a glTF's atlas, else 0).
    #[arg(long)]
    uv_set: Option<u32>,
    /// Run again whenever the head, the photo or the template changes
    /// (until Ctrl-C or SIGTERM).
    #[arg(long)]
    watch: bool,
    /// No summary on standard error.
    #[arg(short, long)]
    quiet: bool,
}

impl PhotoArgs {
    /// The arguments of `python -m uvpin.photo`.
    fn argv(&self) -> Vec<OsString> {
        let mut argv: Vec<OsString> = vec!["-m".into(), "uvpin.photo".into(), self.head.clone().into()];
        argv.extend(self.photo.iter().map(|p| p.clone().into()));
        argv.extend(["-o".into(), self.output.clone().into()]);
        let paths = [
            ("--constraints", &self.constraints),
            ("--picture", &self.picture),
            ("--report", &self.report),
            ("--template", &self.template),
        ];
        for (flag, value) in paths {
            if let Some(v) = value {
                argv.extend([flag.into(), v.clone().into()]);
            }
        }
        for (flag, value) in [("--view", &self.view), ("--up", &self.up)] {
            if let Some(v) = value {
                argv.push(format!("{flag}={v}").into());
            }
        }
        if let Some(k) = self.uv_set {
            argv.extend(["--uv-set".into(), k.to_string().into()]);
        }
        for (flag, on) in [("--watch", self.watch), ("-q", self.quiet)] {
            if on {
                argv.push(flag.into());
            }
        }
        argv
    }
}

/// The hint printed when the Python side is missing.
const INSTALL: &str = "uvpin photo needs the Python package with its photo extra: \
pip install 'uvpin[photo]' (CPython 3.11 or 3.12), then set UVPIN_PYTHON to that python";

/// Runs the photo step in Python; its exit code is ours.
pub fn run(args: &PhotoArgs) -> ExitCode {
    let python = std::env::var_os("UVPIN_PYTHON").unwrap_or_else(|| "python3".into());
    let probe = Command::new(&python)
        .args(["-c", "import uvpin.photo as p; p._mediapipe()"])
        .output();
    match probe {
        Err(e) => {
            eprintln!("error: cannot run {}: {e}; {INSTALL}", python.to_string_lossy());
            return ExitCode::from(1);
        }
        Ok(out) if !out.status.success() => {
            let why = String::from_utf8_lossy(&out.stderr);
            let last = why.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("");
            eprintln!("error: {INSTALL} ({} says: {last})", python.to_string_lossy());
            return ExitCode::from(1);
        }
        Ok(_) => {}
    }
    match Command::new(&python).args(args.argv()).status() {
        Ok(status) => ExitCode::from(status.code().map_or(1, |c| u8::try_from(c).unwrap_or(1))),
        Err(e) => {
            eprintln!("error: cannot run {}: {e}", python.to_string_lossy());
            ExitCode::from(1)
        }
    }
}
