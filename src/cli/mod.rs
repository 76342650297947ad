//! The command line: `uvpin solve`, `uvpin check`, `uvpin sweep` and `uvpin watch`.

mod check;
mod edit;
mod inspect;
mod photo;
mod progress;

use crate::report::Status;
use clap::{Parser, Subcommand};
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

/// Constrained, fold-free texture mapping.
#[derive(Debug, Parser)]
#[command(name = "uvpin", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Solve a constraint file and write the asset with the new UV set.
    ///
    /// Exit code 0: every constraint reached; 2: partial (written, fold-free,
    /// some constraints short of their targets); 1: error (nothing written).
    Solve {
        /// The constraint file (.uvpin.ron).
        constraints: PathBuf,
        /// Output file: .glb for a .glb asset, .gltf (+ .uvpin-HASH.bin) for .gltf;
        /// .obj, .glb or .gltf for an .obj asset. Without it nothing is written.
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Write the JSON report here ("-" for standard output).
        #[arg(long)]
        report: Option<PathBuf>,
        /// No summary on standard error.
        #[arg(short, long)]
        quiet: bool,
        /// Configuration file (e.g. config/uvpin.ron): solver defaults for
        /// constraint files without a `solver` section.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Print what each phase did (step 1, spline path, completion, polish).
        #[arg(long)]
        explain: bool,
        /// Draw the UV layout here (PNG): the whole written UV set (other
        /// charts grey, each outlined), the solved chart's triangles coloured
        /// by stretch over the base-colour texture, holes shaded, every
        /// landmark, arrows from step 1 on the square.
        #[arg(long)]
        preview: Option<PathBuf>,
        /// Draw a render of the mesh with a checker (or its texture) mapped
        /// through the new UVs here (PNG).
        #[arg(long)]
        render: Option<PathBuf>,
        /// Size of the pictures in pixels.
        #[arg(long, default_value_t = 1024)]
        preview_size: u32,
    },
    /// Measure existing UVs: folds, zero-area triangles and stretch per chart,
    /// and constraint residuals. Works on UVs from any tool.
    Check {
        /// The .glb, .gltf or .obj file.
        asset: PathBuf,
        /// UV set to check (TEXCOORD_N).
        #[arg(long, default_value_t = 0)]
        uv_set: u32,
        /// Mesh index or name (default: the first).
        #[arg(long)]
        mesh: Option<String>,
        /// Also report the residual of each constraint of this file.
        #[arg(long)]
        constraints: Option<PathBuf>,
        /// Print JSON instead of one line per chart.
        #[arg(long)]
        json: bool,
    },
    /// Run a grid of solves (constraint files × settings × target blends ×
    /// jitter) in parallel; write runs.csv, runs.jsonl, summary.md,
    /// thumbnails and a contact sheet. Runs already in runs.jsonl are skipped.
    Sweep {
        /// The sweep file (RON).
        sweep: PathBuf,
        /// Run part I of N (I from 0 to N-1, a job array's task index) into
        /// OUTPUT/shards/I-of-N; `--merge` joins the parts.
        #[arg(long, value_name = "I/N", conflicts_with = "merge")]
        shard: Option<crate::sweep::Shard>,
        /// Join the shards' rows into runs.csv, runs.jsonl, summary.md and
        /// the contact sheet, as one machine writes them.
        #[arg(long)]
        merge: bool,
        /// Re-run every run, even those already done.
        #[arg(long)]
        force: bool,
        /// Worker threads (default: one per core).
        #[arg(long)]
        jobs: Option<usize>,
        /// No progress output.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Watch constraint files and assets; re-solve and write the output a
    /// moment after each save. Runs until SIGINT/SIGTERM (exit 0).
    ///
    /// Without arguments it watches assets/ and writes to out/ (the embedded
    /// defaults, documented in config/uvpin.ron). Flags override the
    /// configuration file.
    Watch(WatchArgs),
    /// The landmark editor: serves a page where you pick vertices on the
    /// mesh and place their targets on the texture, and runs the daemon on
    /// the constraint file (re-solved and written on every change). The
    /// page's address is printed on standard error. Runs until SIGINT or
    /// SIGTERM (exit 0).
    Edit(edit::EditArgs),
    /// Lay a face photo onto a head mesh: landmarks found on the photo and
    /// on a render of the head, paired, solved exactly and fold-free; the
    /// photo becomes the model's base-colour texture. Runs the Python
    /// package's photo step (`pip install 'uvpin[photo]'`; `UVPIN_PYTHON`
    /// names the interpreter). Exit code 0: reached; 2: partial; 1: error
    /// (nothing written).
    Photo(photo::PhotoArgs),
    /// What a constraint file needs to know about an asset: its meshes,
    /// primitives and charts, bounding box and up axis, each chart's outer
    /// loop (for `corners`), and the vertices nearest a point (for `near:`).
    Inspect {
        /// The .glb, .gltf or .obj file.
        asset: PathBuf,
        /// The vertices nearest this point, in the mesh's coordinates: X,Y,Z.
        #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true, value_parser = inspect::parse_point)]
        near: Option<glam::DVec3>,
        /// List each chart's outer boundary loop (vertex ids in order).
        #[arg(long)]
        boundary: bool,
        /// Mesh index or name (default: the first).
        #[arg(long)]
        mesh: Option<String>,
        /// UV set to report (TEXCOORD_N).
        #[arg(long, default_value_t = 0)]
        uv_set: u32,
        /// Where this constraint file's solve would cut the mesh open (its
        /// landmarks, `seams` and boundary; the file's asset is this one).
        #[arg(long, value_name = "FILE.uvpin.ron")]
        seams: Option<PathBuf>,
        /// With --seams: draw the cut, from the front and from behind (PNG).
        #[arg(long, value_name = "PNG", requires = "seams")]
        preview: Option<PathBuf>,
        /// Print JSON.
        #[arg(long)]
        json: bool,
    },
}

/// `uvpin watch`'s arguments; the flags override the configuration file.
#[derive(Debug, clap::Args)]
pub struct WatchArgs {
    /// Folders (recursively) and constraint files to watch.
    paths: Vec<PathBuf>,
    /// Configuration file: its `watch` and `solver` sections.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Write outputs into this folder (mirroring the constraint files' names).
    #[arg(long, conflicts_with = "in_place")]
    out: Option<PathBuf>,
    /// Write the UVs back into the watched assets themselves.
    #[arg(long)]
    in_place: bool,
    /// Status file (JSON).
    #[arg(long)]
    status: Option<PathBuf>,
    /// Debounce window in milliseconds.
    #[arg(long)]
    debounce_ms: Option<u64>,
    /// Log format.
    #[arg(long, value_enum)]
    log: Option<LogArg>,
    /// No pictures beside the outputs.
    #[arg(long)]
    no_previews: bool,
    /// Also read assets, buffers and images inside this folder (repeatable;
    /// by default only the watched folders are read).
    #[arg(long, value_name = "DIR")]
    allow: Vec<PathBuf>,
    /// Solve everything present once, print a summary and exit
    /// (0: all reached, 2: some partial, 1: some errors).
    #[arg(long, conflicts_with = "serve")]
    once: bool,
    /// Also serve the landmark editor for every watched constraint file
    /// (default address 127.0.0.1:7878).
    #[arg(long, value_name = "HOST:PORT", num_args = 0..=1, default_missing_value = crate::edit::server::DEFAULT_ADDR)]
    serve: Option<String>,
}

/// `--log` values (of `uvpin watch`).
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum LogArg {
    Human,
    Json,
}

/// Runs the command line; returns the process exit code.
pub fn main() -> ExitCode {
    // A usage error exits 1 (nothing done), never 2, which means "partial,
    // written"; `--help` and `--version` exit 0.
    let cli = Cli::try_parse().unwrap_or_else(|e| {
        let code = if e.use_stderr() { 1 } else { 0 };
        let _ = e.print();
        std::process::exit(code)
    });
    match cli.command {
        Command::Solve {
            constraints,
            output,
            report,
            quiet,
            config,
            explain,
            preview,
            render,
            preview_size,
        } => {
            let pictures = crate::preview::Pictures {
                layout: preview,
                render,
                size: preview_size,
                background: None,
            };
            let print = Printing { quiet, explain };
            solve(
                &constraints,
                output,
                report.as_deref(),
                config.as_deref(),
                pictures,
                print,
            )
        }
        Command::Check {
            asset,
            uv_set,
            mesh,
            constraints,
            json,
        } => match check::run(&asset, uv_set, mesh.as_deref(), constraints.as_deref(), json) {
            Ok(code) => ExitCode::from(code),
            Err(e) => fail(&e),
        },
        Command::Sweep {
            sweep,
            shard: None,
            merge: true,
            ..
        } => merge_sweep(&sweep),
        Command::Sweep {
            sweep,
            shard,
            force,
            jobs,
            quiet,
            ..
        } => run_sweep(&sweep, shard, force, jobs, quiet),
        Command::Watch(args) => watch(args),
        Command::Edit(args) => edit::run(args),
        Command::Photo(args) => photo::run(&args),
        Command::Inspect {
            seams: Some(constraints),
            preview,
            json,
            ..
        } => match inspect::seams(&constraints, preview.as_deref(), json) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => fail(&e),
        },
        Command::Inspect {
            asset,
            near,
            boundary,
            mesh,
            uv_set,
            json,
            ..
        } => {
            let request = crate::inspect::InspectRequest {
                mesh: mesh.as_deref().map(check::mesh_selector),
                uv_set,
                near,
                boundary,
            };
            match inspect::run(&asset, &request, json) {
                Ok(code) => ExitCode::from(code),
                Err(e) => fail(&e),
            }
        }
    }
}

/// Prints `error: …` and returns exit code 1.
fn fail(e: &dyn std::fmt::Display) -> ExitCode {
    eprintln!("error: {e}");
    ExitCode::from(1)
}

/// `uvpin sweep --merge`: the shards' rows joined.
fn merge_sweep(sweep: &std::path::Path) -> ExitCode {
    match crate::sweep::merge(sweep) {
        Ok(outcome) => {
            print!("{}", outcome.summary);
            eprintln!("{} runs merged -> {}", outcome.rows.len(), outcome.output.display());
            ExitCode::SUCCESS
        }
        Err(e) => fail(&e),
    }
}

fn run_sweep(
    sweep: &std::path::Path,
    shard: Option<crate::sweep::Shard>,
    force: bool,
    jobs: Option<usize>,
    quiet: bool,
) -> ExitCode {
    let options = crate::sweep::SweepOptions {
        force,
        jobs,
        shard,
        progress: if quiet {
            crate::sweep::Progress::Quiet
        } else {
            crate::sweep::Progress::Auto
        },
    };
    match crate::sweep::run_sweep(sweep, &options) {
        Ok(outcome) => {
            print!("{}", outcome.summary);
            if !quiet {
                eprintln!(
                    "{} runs ({} solved now, {} already done) -> {}",
                    outcome.rows.len(),
                    outcome.ran,
                    outcome.rows.len() - outcome.ran,
                    outcome.output.display()
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => fail(&e),
    }
}

impl WatchArgs {
    /// The `watch` section with these flags applied.
    fn apply(self, mut watch: crate::config::WatchConfig) -> crate::config::WatchConfig {
        if !self.paths.is_empty() {
            watch.paths = self.paths;
        }
        if let Some(out) = self.out {
            watch.output = crate::config::OutputMode::Folder(out);
        }
        if self.in_place {
            watch.output = crate::config::OutputMode::InPlace;
        }
        if self.status.is_some() {
            watch.status_file = self.status;
        }
        if self.no_previews {
            watch.previews = false;
        }
        watch.allow_paths.extend(self.allow);
        if let Some(ms) = self.debounce_ms {
            watch.debounce_ms = ms;
        }
        match self.log {
            Some(LogArg::Human) => watch.log = crate::config::LogFormat::Human,
            Some(LogArg::Json) => watch.log = crate::config::LogFormat::Json,
            None => {}
        }
        watch
    }
}

fn watch(args: WatchArgs) -> ExitCode {
    let config = match args.config.as_deref().map(crate::config::Config::load).transpose() {
        Ok(c) => c.unwrap_or_default(),
        Err(e) => return fail(&e),
    };
    let (once, serve) = (args.once, args.serve.clone());
    let options = crate::daemon::run::WatchOptions {
        config: args.apply(config.watch),
        solver: config.solver,
        limits: config.limits,
        once,
    };
    // `--once` solves what is there and exits: nothing to serve.
    let editor = serve
        .filter(|_| !once)
        .map(|addr| crate::edit::publish::EditorAttachment::new(addr, false));
    let attachments = editor
        .into_iter()
        .map(|e| Box::new(e) as Box<dyn crate::daemon::run::Attachment>);
    match crate::daemon::run::run(options, attachments.collect()) {
        Ok(outcome) => ExitCode::from(outcome.exit_code()),
        Err(e) => fail(&format!("{e:#}")),
    }
}

/// Prints `text` and a newline on standard output; a closed pipe (`| head`)
/// ends the output quietly.
pub(crate) fn print_out(text: &str) {
    let mut out = std::io::stdout().lock();
    let _ = out
        .write_all(text.as_bytes())
        .and_then(|()| out.write_all(b"\n"))
        .and_then(|()| out.flush());
}

/// What `uvpin solve` prints on standard error.
#[derive(Debug, Clone, Copy)]
struct Printing {
    quiet: bool,
    explain: bool,
}

/// `--preview-size` must be a size a picture can be drawn at.
fn check_picture_size(size: u32) -> Result<(), PictureSizeError> {
    if (16..=crate::preview::MAX_SIZE).contains(&size) {
        Ok(())
    } else {
        Err(PictureSizeError { size })
    }
}

/// A `--preview-size` no picture is drawn at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("--preview-size {size}: must be between 16 and {} pixels", crate::preview::MAX_SIZE)]
struct PictureSizeError {
    size: u32,
}

fn solve(
    constraints: &std::path::Path,
    output: Option<PathBuf>,
    report_path: Option<&std::path::Path>,
    config: Option<&std::path::Path>,
    pictures: crate::preview::Pictures,
    print: Printing,
) -> ExitCode {
    if pictures.any()
        && let Err(e) = check_picture_size(pictures.size)
    {
        return fail(&e);
    }
    let to_stdout = report_path.is_some_and(|p| p.as_os_str() == "-");
    let bar = progress::solve_bar(print.quiet);
    let result = config
        .map(crate::config::Config::load)
        .transpose()
        .map_err(crate::error::Error::from)
        .and_then(|c| {
            let config = c.unwrap_or_default();
            let options = crate::api::Options {
                solver: config.solver,
                output,
                report: report_path.filter(|_| !to_stdout).map(std::path::Path::to_path_buf),
                pictures,
                input: crate::io::InputRules {
                    limits: config.limits,
                    scope: crate::io::ReadScope::Anywhere,
                },
                on_error: crate::api::OnError::WriteNothing,
                progress: bar.as_ref().map(|(_, sink)| sink.clone()),
            };
            crate::api::solve_file(constraints, &options)
        });
    if let Some((bar, _)) = bar {
        bar.finish_and_clear();
    }
    match result {
        Ok(report) => {
            if !print.quiet {
                eprint!("{}", report.summary());
            } else if report.status == Status::Error {
                // Quiet keeps errors: exit 1 always says why.
                eprintln!(
                    "error: {}",
                    report.message.as_deref().unwrap_or("nothing could be laid out")
                );
            }
            if print.explain {
                for line in &report.explain {
                    eprintln!("{line}");
                }
            }
            if to_stdout {
                print_out(&serde_json::to_string_pretty(&report).expect("report serialises"));
            }
            ExitCode::from(report.status.exit_code() as u8)
        }
        Err(e) => {
            eprintln!("error: {e}");
            if to_stdout {
                let json = serde_json::json!({
                    "status": Status::Error,
                    "message": e.to_string(),
                    "constraint_file": constraints.display().to_string(),
                });
                print_out(&serde_json::to_string_pretty(&json).expect("json"));
            }
            ExitCode::from(1)
        }
    }
}
