//! `farm submit`: render a scene here (the embedded engine) or on a farm
//! (`--coordinator`), then write the image and print the summary.

use crate::embedded::{self, SubmitOptions};
use crate::error::Error;
use farm_common::film::DEFAULT_PASS_CAP;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `farm submit`.
#[derive(Debug, clap::Args)]
pub struct SubmitArgs {
    /// The pbrt-v3 scene files, read as pbrt-v3 reads them: one stream,
    /// each WorldEnd rendering a scene (`-` is standard input; `.pbrt.gz`
    /// is read compressed; a folder gives its .pbrt files in name order).
    /// Several scenes are a shot: each is a frame with its own image.
    #[arg(required = true, num_args = 1..)]
    pub scenes: Vec<PathBuf>,
    /// Output image (.exr, .pfm or .png); default: the scene's Film
    /// filename. For a shot, a name with the frame number in it, as
    /// printf writes it: out/frame-%04d.exr.
    #[arg(short, long, visible_alias = "outfile")]
    pub output: Option<PathBuf>,
    /// The number of a shot's first frame (the rest follow in order).
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub first_frame: u32,
    /// How many of a shot's frames may be on the farm unfinished at once:
    /// the next frames' tiles wait in the queue, so no worker idles
    /// between frames (with --coordinator).
    #[arg(long, default_value_t = 3, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=crate::shot::MAX_IN_FLIGHT as i64))]
    pub frames_in_flight: u32,
    /// Render again only the frames of this shot (its id, as `farm status`
    /// lists it) that have no image and are not rendering: those that
    /// failed or were cancelled, or never reached the farm. Give the same
    /// files and -o as the first time.
    #[arg(long, value_name = "SHOT", requires = "coordinator")]
    pub retry_failed: Option<u64>,
    /// Samples per pixel, overriding the scene's sampler.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Render in passes (4 samples per pixel, then twice as many each
    /// pass, up to --spp or else 1024) and stop after the first pass whose
    /// estimated relMSE is at most E. The passes depend only on the scene
    /// and E, never on the farm.
    #[arg(long, value_name = "E", value_parser = parse_target_error)]
    pub target_error: Option<f64>,
    /// Render in passes, as --target-error does, and stop after the first
    /// pass that ends S or more after the render started (90s, 10m, 2h).
    #[arg(long, value_name = "S", value_parser = super::coordinator::parse_duration)]
    pub time_limit: Option<std::time::Duration>,
    /// Render threads (default: one per core).
    #[arg(long, default_value_t = 0, visible_alias = "nthreads")]
    pub threads: usize,
    /// Render only this part of the film, as fractions of its width and
    /// height (pbrt-v3's flag; a Film "cropwindow" in the scene wins). The
    /// pixels are bit-identical to the same pixels of the whole render.
    #[arg(long, num_args = 4, value_names = ["X0", "X1", "Y0", "Y1"])]
    pub cropwindow: Option<Vec<f32>>,
    /// Print the scene as pbrt-v3 text (Includes inlined, every transform
    /// as the matrix it composed to) instead of rendering it (pbrt-v3's --cat).
    #[arg(long)]
    pub cat: bool,
    /// As --cat, with every triangle mesh written to mesh_NNNNN.ply in the
    /// current directory (pbrt-v3's --toply).
    #[arg(long, conflicts_with = "cat")]
    pub toply: bool,
    /// A quick look: a quarter of the resolution each way and one sample
    /// per pixel (pbrt-v3's --quick; the random sampler keeps its count).
    #[arg(long)]
    pub quick: bool,
    /// Render with this sampler instead of the scene's, at the scene's
    /// sample count (or --spp's).
    #[arg(long, value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(farm_scene::SAMPLER_NAMES))]
    pub sampler: Option<String>,
    /// Stream the image to this display server as it renders (tev, which
    /// listens on port 14158; pbrt-v4's flag), embedded or on the farm.
    #[arg(long, value_name = "HOST:PORT")]
    pub display_server: Option<String>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
    /// Also print which features the scene uses and which per-ray work the
    /// render skipped.
    #[arg(short, long)]
    pub verbose: bool,
    /// Render on the farm run by this coordinator (e.g. https://host:7878)
    /// instead of in this process.
    #[arg(long, env = "FARM_COORDINATOR")]
    pub coordinator: Option<String>,
    /// The client token (with --coordinator).
    #[command(flatten)]
    pub token: super::TokenArgs,
    /// Job priority on the farm: higher runs first.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub priority: i32,
    /// Also write the render's per-pixel estimate of its own relMSE (from
    /// its two half-images) to this image (.exr, .pfm or .png).
    #[arg(long, value_name = "FILE")]
    pub error_map: Option<PathBuf>,
    /// Upload files the scene names outside its own folder too (with
    /// --coordinator; by default such a scene is refused, so a scene cannot
    /// send your other files to a farm).
    #[arg(long)]
    pub allow_assets_outside: bool,
    /// Submit the job and exit, printing its id: it renders on with no
    /// client attached, and `farm watch ID` fetches its image (with
    /// --coordinator). Without it, a job whose client has been gone longer
    /// than the coordinator's grace period is cancelled.
    #[arg(long, requires = "coordinator")]
    pub detach: bool,
    /// Seconds to keep reconnecting to a coordinator that went away (it
    /// restarted, or the network failed) before giving up.
    #[arg(long, value_name = "SECONDS", default_value_t = 600.0)]
    pub reconnect_for: f64,
    /// The largest render to start (embedded; a coordinator has its own).
    #[command(flatten)]
    pub limits: super::LimitArgs,
}

/// Renders where the arguments say: one scene, or each scene the files
/// describe as a shot's frames.
pub fn run(mut args: SubmitArgs) -> ExitCode {
    let start = std::time::Instant::now();
    let inputs = match crate::frames::expand_inputs(&args.scenes) {
        Ok(i) => i,
        Err(e) => return fail(&e),
    };
    if args.cat || args.toply {
        return match farm_scene::parse_files(&inputs) {
            Ok(scenes) => print_scenes(&args, &scenes),
            Err(e) => fail(&e.into()),
        };
    }
    let mut stream = farm_scene::SceneStream::new(&inputs).peekable();
    let first = match stream.next() {
        Some(Ok(s)) => s,
        Some(Err(e)) => return fail(&e.into()),
        None => return fail(&crate::error::Error::Usage("no scene to render".into())),
    };
    // Several scenes are a shot (several files may also make one scene, as
    // options in one and the world in another).
    let first_parsed = start.elapsed();
    if args.retry_failed.is_some() || stream.peek().is_some() {
        return super::shot::run(&args, &inputs, first, stream, first_parsed);
    }
    // One scene: an output name with a frame number is frame --first-frame;
    // any other `%` in it is only a character.
    let numbered = |p: Option<PathBuf>| {
        p.map(|p| match crate::frames::OutputPattern::parse(&p) {
            Ok(Some(pattern)) => pattern.frame(args.first_frame),
            _ => p,
        })
    };
    (args.output, args.error_map) = (numbered(args.output.take()), numbered(args.error_map.take()));
    let scene =
        Parsed { file: inputs[0].clone(), desc: first.desc, warnings: first.warnings, start };
    if args.coordinator.is_some() {
        crate::runtime::block_on(run_remote(&args, scene))
    } else {
        run_embedded(&args, scene)
    }
}

/// `--cat` and `--toply`: the scenes as text on standard output.
fn print_scenes(
    args: &SubmitArgs,
    scenes: &[(farm_common::scene::SceneDescription, Vec<farm_common::scene::Warning>)],
) -> ExitCode {
    let here = std::path::Path::new(".");
    for (i, (desc, warnings)) in scenes.iter().enumerate() {
        if !args.quiet {
            for w in warnings {
                eprintln!("{w}");
            }
        }
        let prefix = if i == 0 { "mesh".to_string() } else { format!("scene{}_mesh", i + 1) };
        let meshes = if args.toply {
            farm_scene::Meshes::Ply { dir: here, prefix: &prefix }
        } else {
            farm_scene::Meshes::Inline
        };
        match farm_scene::write_scene(desc, meshes) {
            Ok(text) => say!("{text}"),
            Err(e) => {
                eprintln!("error: writing meshes: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    ExitCode::SUCCESS
}

/// One scene the command line's files describe.
pub(super) struct Parsed {
    /// The first file (the job's name; its folder bounds the assets sent).
    pub file: PathBuf,
    pub desc: farm_common::scene::SceneDescription,
    pub warnings: Vec<farm_common::scene::Warning>,
    /// When parsing began.
    pub start: std::time::Instant,
}

/// The coordinator `--coordinator` names, with the token given.
pub(super) fn remote(args: &SubmitArgs) -> Result<crate::client::Remote, crate::error::Error> {
    let token = args.token.token()?;
    Ok(crate::client::Remote { url: args.coordinator.clone().unwrap_or_default(), token })
}

async fn run_remote(args: &SubmitArgs, scene: Parsed) -> ExitCode {
    let remote = match remote(args) {
        Ok(r) => r,
        Err(e) => return fail(&e),
    };
    let opts = remote_options(args);
    if args.detach {
        let Parsed { file, desc, warnings, start } = scene;
        return match crate::client::start_parsed(&remote, &file, desc, warnings, start, &opts).await
        {
            Ok(s) => {
                if !args.quiet {
                    for w in &s.warnings {
                        eprintln!("{w}");
                    }
                }
                say!("{}", s.job);
                if !args.quiet {
                    eprintln!(
                        "job {} submitted; `farm watch {} -o FILE --coordinator {}` writes its image",
                        s.job, s.job, remote.url
                    );
                }
                ExitCode::SUCCESS
            }
            Err(e) => fail(&e),
        };
    }
    let bar = crate::progress::progress_bar(args.quiet);
    let Parsed { file, desc, warnings, start } = scene;
    let result =
        crate::client::submit_parsed(&remote, &file, desc, warnings, start, &opts, |job, p| {
            show_progress(&bar, job, p)
        })
        .await;
    bar.finish_and_clear();
    match result {
        Ok(summary) => finish(args, summary, args.error_map.as_deref()),
        Err(e) => fail(&e),
    }
}

/// A relative error to stop at: a finite number ≥ 0.
fn parse_target_error(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(e) if e.is_finite() && e >= 0.0 => Ok(e),
        _ => Err(format!("{s:?} is not a relative error such as 1e-3")),
    }
}

/// Samples per pixel to render: --spp, or for a render in passes without
/// it, [`DEFAULT_PASS_CAP`] (the most its passes may reach).
pub(super) fn spp(args: &SubmitArgs) -> Option<u32> {
    let passes = args.target_error.is_some() || args.time_limit.is_some();
    args.spp.or(passes.then_some(DEFAULT_PASS_CAP))
}

/// How the command line asks for a render on the farm.
pub(super) fn remote_options(args: &SubmitArgs) -> crate::client::RemoteOptions {
    crate::client::RemoteOptions {
        output: args.output.clone(),
        spp: spp(args),
        priority: args.priority,
        allow_assets_outside: args.allow_assets_outside,
        detach: args.detach,
        reconnect_for: reconnect_for(args.reconnect_for),
        overrides: overrides(args),
        display_server: args.display_server.clone(),
        quiet: args.quiet,
        target_error: args.target_error,
        time_limit: args.time_limit.map(|d| d.as_secs_f64()),
    }
}

/// What the command line changes in the scene.
pub(super) fn overrides(args: &SubmitArgs) -> farm_scene::Overrides {
    farm_scene::Overrides {
        crop_window: args.cropwindow.as_deref().map(|c| [c[0], c[1], c[2], c[3]]),
        quick: args.quick,
        sampler: args.sampler.clone(),
    }
}

/// Renders one scene here, writes its image to `output` (default: its
/// Film filename) and `error_map`, and prints its summary.
pub(super) fn run_embedded_to(
    args: &SubmitArgs,
    scene: Parsed,
    output: Option<PathBuf>,
    error_map: Option<&std::path::Path>,
) -> ExitCode {
    let opts = SubmitOptions {
        output,
        spp: spp(args),
        threads: args.threads,
        all_paths: false,
        limits: (&args.limits).into(),
        overrides: overrides(args),
        display_server: args.display_server.clone(),
        target_error: args.target_error,
        time_limit: args.time_limit.map(|d| d.as_secs_f64()),
        pass_totals: Vec::new(),
    };
    let bar = crate::progress::progress_bar(args.quiet);
    let started = std::time::Instant::now();
    let result = embedded::render_parsed(scene.desc, scene.warnings, scene.start, &opts, |p| {
        if bar.length().is_none() {
            bar.set_length(p.tiles_total as u64);
        }
        bar.set_position(p.tiles_done as u64);
        let secs = started.elapsed().as_secs_f64().max(1e-3);
        bar.set_message(format!("{:.2} Mrays/s", p.stats.total_rays() as f64 / secs / 1e6));
    });
    bar.finish_and_clear();
    match result {
        Ok(summary) => finish(args, summary, error_map),
        Err(e) => fail(&e),
    }
}

fn run_embedded(args: &SubmitArgs, scene: Parsed) -> ExitCode {
    run_embedded_to(args, scene, args.output.clone(), args.error_map.as_deref())
}

/// Prints warnings, writes the image (and the error map to `error_map`)
/// and prints the summary line.
pub fn finish(
    args: &SubmitArgs,
    summary: embedded::RenderSummary,
    error_map: Option<&std::path::Path>,
) -> ExitCode {
    if !args.quiet {
        for w in &summary.warnings {
            eprintln!("{w}");
        }
    }
    if let Err(e) = embedded::write(&summary) {
        return fail(&e);
    }
    if let Some(path) = error_map {
        match &summary.error {
            Some(error) => {
                if let Err(e) = embedded::write_error_map(path, &summary, error) {
                    return fail(&e);
                }
            }
            None => eprintln!(
                "warning: no error map written to {}: one sample per pixel cannot be split in two halves",
                path.display()
            ),
        }
    }
    let s = &summary.stats;
    let bad = s.nan_samples + s.inf_samples + s.negative_samples;
    if bad > 0 {
        eprintln!(
            "warning: {bad} samples had bad radiance and were set to black ({} NaN, {} infinite, {} negative)",
            s.nan_samples, s.inf_samples, s.negative_samples
        );
    }
    if args.verbose && !args.quiet {
        for line in summary.features.describe() {
            say!("{line}");
        }
    }
    if !args.quiet {
        let secs = summary.render_seconds.max(1e-9);
        let error = match &summary.error {
            Some(e) if e.fireflies.is_some() => {
                format!(", estimated relMSE at least {:.3e}", e.rel_mse)
            }
            Some(e) => format!(", estimated relMSE {:.3e}", e.rel_mse),
            None => String::new(),
        };
        say!(
            "{}: {}×{}, {} spp, {:.2} s ({:.2} s start-up), {:.1}M rays ({:.2} Mrays/s){error}",
            summary.output.display(),
            summary.image.width,
            summary.image.height,
            summary.spp,
            summary.render_seconds + summary.startup_seconds,
            summary.startup_seconds,
            s.total_rays() as f64 / 1e6,
            s.total_rays() as f64 / secs / 1e6,
        );
        if let Some(f) = summary.error.as_ref().and_then(|e| e.fireflies.as_ref()) {
            say!("{}", crate::passes::fireflies(f));
        }
        let in_passes = !summary.passes.is_empty();
        let caveat = summary.sampler.and_then(|k| crate::passes::caveat(k, in_passes));
        if let Some(why) = caveat.filter(|_| summary.error.is_some()) {
            say!("{why}");
        }
        for line in crate::passes::describe(&summary.passes, summary.stopped, args.target_error) {
            say!("{line}");
        }
    }
    ExitCode::SUCCESS
}

/// A `--reconnect-for` in seconds as a duration.
pub fn reconnect_for(seconds: f64) -> std::time::Duration {
    std::time::Duration::from_secs_f64(if seconds.is_finite() {
        seconds.clamp(0.0, 1e9)
    } else {
        0.0
    })
}

/// Shows a remote job's progress on `bar`.
pub fn show_progress(bar: &indicatif::ProgressBar, job: u64, p: &crate::client::RemoteProgress) {
    if bar.length() != Some(p.tiles_total as u64) {
        bar.set_length(p.tiles_total as u64);
    }
    bar.set_position(p.tiles_done as u64);
    bar.set_message(format!(
        "job {job}, {} workers, {}M rays",
        p.workers,
        p.stats.total_rays() / 1_000_000
    ));
}

/// Prints a render error and returns its exit code.
pub fn fail(e: &Error) -> ExitCode {
    eprintln!("error: {e}");
    e.exit_code()
}
