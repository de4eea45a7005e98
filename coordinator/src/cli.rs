//! The `farm` command line: parse arguments, run, print for people.

use crate::submit::{self, SubmitError, SubmitOptions};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// A distributed renderer for pbrt-v3 scenes.
#[derive(Debug, Parser)]
#[command(name = "farm", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a pbrt-v3 scene: on this machine, or on a farm with --coordinator.
    Submit(SubmitArgs),
    /// Run a coordinator that workers and clients connect to.
    Coordinator(CoordinatorArgs),
    /// Render tiles for a coordinator with every core of this machine.
    Worker(WorkerArgs),
    /// List a coordinator's jobs and workers.
    Status(RemoteArgs),
    /// Cancel a job on a coordinator.
    Cancel(CancelArgs),
    /// Exit 0 if the gRPC health service at an address reports SERVING.
    Health(HealthArgs),
    /// Compare an image with a reference (like pbrt-v3's `imgtool diff`).
    Diff(DiffArgs),
    /// Render a scene at increasing sample counts and tabulate and plot its
    /// error against render time.
    Converge(ConvergeArgs),
    /// Render every shared pbrt-v3 scene found and tabulate time, rays and
    /// peak memory next to pbrt-v3's.
    Bench(BenchArgs),
    /// Render one scene and print its measurements (used by `farm bench`).
    #[command(hide = true)]
    BenchOne(BenchOneArgs),
}

/// Arguments of `farm bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// The shared folder (with scenes/ and reference/README.md).
    #[arg(long, env = "FARM_SHARED", default_value = "../shared")]
    pub shared: PathBuf,
    /// Only this scene (a folder name under scenes/).
    #[arg(long)]
    pub scene: Option<String>,
    /// Render threads (default: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Where to write the table as CSV.
    #[arg(long, value_name = "FILE", default_value = "farm-bench.csv")]
    pub csv: PathBuf,
    /// Also render each scene on one thread and report the speed-up.
    #[arg(long)]
    pub scaling: bool,
    /// Renders per measurement; the fastest is reported.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..))]
    pub runs: u32,
}

/// Arguments of `farm bench-one`.
#[derive(Debug, clap::Args)]
pub struct BenchOneArgs {
    /// The scene.
    pub scene: PathBuf,
    /// Render threads (0: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
}

/// Arguments of `farm converge`.
#[derive(Debug, clap::Args)]
pub struct ConvergeArgs {
    /// The pbrt-v3 scene file.
    pub scene: PathBuf,
    /// The image to measure errors against (.exr); default: the render with
    /// the most samples.
    #[arg(long, value_name = "EXR")]
    pub reference: Option<PathBuf>,
    /// Sample counts, e.g. 1,2,4,8,16; default: powers of two up to the
    /// scene's own count.
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Vec<u32>,
    /// Where to write the table; default: <scene>-converge.csv.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Where to write the plot; default: <scene>-converge.svg.
    #[arg(long, value_name = "FILE")]
    pub plot: Option<PathBuf>,
    /// Render threads (default: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Arguments of `farm diff`.
#[derive(Debug, clap::Args)]
pub struct DiffArgs {
    /// The image (.exr).
    pub image: PathBuf,
    /// The reference it is measured against (.exr, same size).
    pub reference: PathBuf,
    /// Write |image − reference| per pixel and channel to this image.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

/// Arguments of `farm coordinator`.
#[derive(Debug, clap::Args)]
pub struct CoordinatorArgs {
    /// Address to listen on.
    #[arg(long, default_value = "0.0.0.0:7878")]
    pub listen: std::net::SocketAddr,
    /// Seconds between worker heartbeats; a worker silent for three is lost.
    #[arg(long, default_value_t = 2.0)]
    pub heartbeat: f64,
}

/// Arguments of `farm worker`.
#[derive(Debug, clap::Args)]
pub struct WorkerArgs {
    /// The coordinator, e.g. http://render-host:7878.
    #[arg(long, env = "FARM_COORDINATOR")]
    pub coordinator: String,
    /// Render threads (default: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Name shown in `farm status` (default: the host name).
    #[arg(long)]
    pub name: Option<String>,
    /// Serve the gRPC health service here, for probes.
    #[arg(long)]
    pub health_listen: Option<std::net::SocketAddr>,
}

/// Arguments naming a coordinator.
#[derive(Debug, clap::Args)]
pub struct RemoteArgs {
    /// The coordinator, e.g. http://render-host:7878.
    #[arg(long, env = "FARM_COORDINATOR")]
    pub coordinator: String,
}

/// Arguments of `farm cancel`.
#[derive(Debug, clap::Args)]
pub struct CancelArgs {
    /// The job id (see `farm status`).
    pub job: u64,
    /// The coordinator.
    #[command(flatten)]
    pub remote: RemoteArgs,
}

/// Arguments of `farm health`.
#[derive(Debug, clap::Args)]
pub struct HealthArgs {
    /// Address of the gRPC health service.
    #[arg(long, default_value = "http://127.0.0.1:7878")]
    pub addr: String,
}

/// Arguments of `farm submit`.
#[derive(Debug, clap::Args)]
pub struct SubmitArgs {
    /// The pbrt-v3 scene file.
    pub scene: PathBuf,
    /// Output image (.exr, .pfm or .png); default: the scene's Film filename.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Samples per pixel, overriding the scene's sampler.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Render threads (default: one per core).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
    /// Also print which features the scene uses and which per-ray work the
    /// render skipped.
    #[arg(short, long)]
    pub verbose: bool,
    /// Render on the farm run by this coordinator (e.g. http://host:7878)
    /// instead of in this process.
    #[arg(long, env = "FARM_COORDINATOR")]
    pub coordinator: Option<String>,
    /// Job priority on the farm: higher runs first.
    #[arg(long, default_value_t = 0, allow_hyphen_values = true)]
    pub priority: i32,
    /// Also write the render's per-pixel estimate of its own relMSE (from
    /// its two half-images) to this image (.exr, .pfm or .png).
    #[arg(long, value_name = "FILE")]
    pub error_map: Option<PathBuf>,
}

/// Exit code for bad input (scene errors, usage errors).
pub const EXIT_BAD_INPUT: u8 = 2;

/// Runs a parsed command line and returns the process exit code.
pub fn run(cli: Cli) -> ExitCode {
    match cli.command {
        Command::Submit(args) if args.coordinator.is_some() => block_on(run_remote_submit(args)),
        Command::Submit(args) => run_submit(args),
        Command::Coordinator(args) => block_on(run_coordinator(args)),
        Command::Worker(args) => block_on_one_thread(run_worker(args)),
        Command::Status(args) => block_on(run_status(args)),
        Command::Cancel(args) => block_on(run_cancel(args)),
        Command::Diff(args) => run_diff(&args),
        Command::Converge(args) => run_converge(&args),
        Command::Bench(args) => run_bench(&args),
        Command::BenchOne(args) => match crate::bench::measure_here(&args.scene, args.threads) {
            Ok(_) => ExitCode::SUCCESS,
            Err(e) => fail(&e),
        },
        Command::Health(args) => block_on(async move {
            match crate::client::healthy(&args.addr).await {
                Ok(true) => ExitCode::SUCCESS,
                Ok(false) => ExitCode::FAILURE,
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::FAILURE
                }
            }
        }),
    }
}

fn block_on(f: impl std::future::Future<Output = ExitCode>) -> ExitCode {
    block_on_with(tokio::runtime::Builder::new_multi_thread(), f)
}

/// Runs `f` on a single-threaded runtime.
fn block_on_one_thread(f: impl std::future::Future<Output = ExitCode>) -> ExitCode {
    block_on_with(tokio::runtime::Builder::new_current_thread(), f)
}

fn block_on_with(
    mut runtime: tokio::runtime::Builder,
    f: impl std::future::Future<Output = ExitCode>,
) -> ExitCode {
    match runtime.enable_all().build() {
        Ok(rt) => rt.block_on(f),
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Completes on SIGINT or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {}
        _ = term => {}
    }
}

async fn run_coordinator(args: CoordinatorArgs) -> ExitCode {
    let listener = match tokio::net::TcpListener::bind(args.listen).await {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: cannot listen on {}: {e}", args.listen);
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let heartbeat = std::time::Duration::from_secs_f64(args.heartbeat.clamp(0.05, 3600.0));
    let addr =
        listener.local_addr().map(|a| a.to_string()).unwrap_or_else(|_| args.listen.to_string());
    eprintln!("coordinator listening on {addr}");
    match crate::server::serve(
        listener,
        crate::server::ServerConfig::with_heartbeat(heartbeat),
        shutdown_signal(),
    )
    .await
    {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

async fn run_worker(args: WorkerArgs) -> ExitCode {
    let name = args.name.clone().unwrap_or_else(|| {
        std::fs::read_to_string("/etc/hostname")
            .ok()
            .map(|h| h.trim().to_string())
            .filter(|h| !h.is_empty())
            .or_else(|| std::env::var("HOSTNAME").ok())
            .unwrap_or_else(|| "worker".into())
    });
    let config = farm_worker::WorkerConfig {
        coordinator: args.coordinator.clone(),
        threads: args.threads,
        name,
        max_in_flight: 0,
        health_listen: args.health_listen,
        reconnect: true,
    };
    eprintln!("worker {} rendering for {}", config.name, config.coordinator);
    match farm_worker::run(config, shutdown_signal()).await {
        Ok(s) => {
            eprintln!("worker stopped after {} tiles", s.tiles_rendered);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

async fn run_status(args: RemoteArgs) -> ExitCode {
    match crate::client::status(&args.coordinator).await {
        Ok(s) => {
            println!(
                "{:>6}  {:<28} {:<10} {:>13} {:>8}",
                "job", "name", "state", "tiles", "priority"
            );
            for j in &s.jobs {
                let tiles = format!("{}/{}", j.tiles_done, j.tiles_total);
                println!(
                    "{:>6}  {:<28} {:<10} {:>13} {:>8}",
                    j.job_id, j.name, j.state, tiles, j.priority
                );
            }
            println!();
            println!(
                "{:>6}  {:<28} {:>7} {:>9} {:>10}",
                "worker", "name", "threads", "in flight", "tiles done"
            );
            for w in &s.workers {
                println!(
                    "{:>6}  {:<28} {:>7} {:>9} {:>10}",
                    w.worker_id, w.name, w.threads, w.in_flight, w.tiles_done
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

async fn run_cancel(args: CancelArgs) -> ExitCode {
    match crate::client::cancel(&args.remote.coordinator, args.job).await {
        Ok(true) => {
            println!("job {} cancelled", args.job);
            ExitCode::SUCCESS
        }
        Ok(false) => {
            eprintln!("error: job {} is not queued or running", args.job);
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

async fn run_remote_submit(args: SubmitArgs) -> ExitCode {
    let url = args.coordinator.clone().unwrap_or_default();
    let opts = crate::client::RemoteOptions {
        output: args.output.clone(),
        spp: args.spp,
        priority: args.priority,
    };
    let bar = progress_bar(args.quiet);
    let started = std::time::Instant::now();
    let result = crate::client::submit(&url, &args.scene, &opts, |job, p| {
        if bar.length().is_none() {
            bar.set_length(p.tiles_total as u64);
        }
        bar.set_position(p.tiles_done as u64);
        let secs = started.elapsed().as_secs_f64().max(1e-3);
        bar.set_message(format!(
            "job {job}, {} workers, {:.2} Mrays/s",
            p.workers,
            p.stats.total_rays() as f64 / secs / 1e6
        ));
    })
    .await;
    bar.finish_and_clear();
    match result {
        Ok(summary) => finish(&args, summary),
        Err(crate::client::ClientError::Scene(e)) => {
            eprintln!("error: {e}");
            ExitCode::from(EXIT_BAD_INPUT)
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn progress_bar(quiet: bool) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    if quiet {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} Rendering [{bar:30}] {pos}/{len} tiles  {msg}  ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    bar
}

fn run_submit(args: SubmitArgs) -> ExitCode {
    let opts = SubmitOptions {
        output: args.output.clone(),
        spp: args.spp,
        threads: args.threads,
        all_paths: false,
    };
    let bar = progress_bar(args.quiet);
    let started = std::time::Instant::now();
    let result = submit::render(&args.scene, &opts, |p| {
        if bar.length().is_none() {
            bar.set_length(p.tiles_total as u64);
        }
        bar.set_position(p.tiles_done as u64);
        let secs = started.elapsed().as_secs_f64().max(1e-3);
        bar.set_message(format!("{:.2} Mrays/s", p.stats.total_rays() as f64 / secs / 1e6));
    });
    bar.finish_and_clear();
    match result {
        Ok(summary) => finish(&args, summary),
        Err(e) => fail(&e),
    }
}

/// `farm diff`: error metrics of an image against a reference.
fn run_diff(args: &DiffArgs) -> ExitCode {
    let read = |p: &Path| crate::output::read_exr(p).map_err(|e| e.to_string());
    let (image, reference) = match (read(&args.image), read(&args.reference)) {
        (Ok(a), Ok(r)) => (a, r),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let Some(e) = crate::metrics::compare(&image, &reference) else {
        eprintln!(
            "error: {} is {}×{} but {} is {}×{}",
            args.image.display(),
            image.width,
            image.height,
            args.reference.display(),
            reference.width,
            reference.height
        );
        return ExitCode::from(EXIT_BAD_INPUT);
    };
    println!(
        "{} against {} ({}×{})",
        args.image.display(),
        args.reference.display(),
        image.width,
        image.height
    );
    println!("  relMSE     {:.6e}", e.rel_mse);
    println!("  MSE        {:.6e}", e.mse);
    println!("  RMSE       {:.6e}", e.mse.sqrt());
    println!("  mean |a-r| {:.6e}", e.mean_abs);
    println!("  max |a-r|  {:.6e} at pixel ({}, {})", e.max_abs.0, e.max_abs.1, e.max_abs.2);
    println!("  mean       {:.6e} (image), {:.6e} (reference)", e.means.0, e.means.1);
    println!("  non-finite {} (image), {} (reference)", e.non_finite, e.non_finite_reference);
    if let Some(out) = &args.output {
        let diff = crate::output::RgbImage {
            width: image.width,
            height: image.height,
            pixels: image
                .pixels
                .iter()
                .zip(&reference.pixels)
                .map(|(a, r)| [0, 1, 2].map(|c| (a[c] - r[c]).abs()))
                .collect(),
        };
        let meta = crate::output::ImageMetadata {
            scene: format!("|{} - {}|", args.image.display(), args.reference.display()),
            spp: 0,
            render_seconds: 0.0,
            rel_mse_estimate: None,
        };
        if let Err(err) = crate::output::write_image(out, &diff, &meta) {
            eprintln!("error: {err}");
            return ExitCode::FAILURE;
        }
    }
    ExitCode::SUCCESS
}

/// `farm converge`: renders the series, prints the table and writes the
/// CSV and the plot.
fn run_converge(args: &ConvergeArgs) -> ExitCode {
    use crate::converge::{self, ConvergeError, ConvergeOptions};
    let opts = ConvergeOptions {
        spp: args.spp.clone(),
        reference: args.reference.clone(),
        threads: args.threads,
    };
    let bar = progress_bar(args.quiet);
    let mut current = None;
    let result = converge::run(&args.scene, &opts, |spp, p| {
        if current != Some(spp) {
            current = Some(spp);
            bar.reset();
            bar.set_length(p.tiles_total as u64);
            bar.set_message(match spp {
                0 => "at the scene's spp".to_string(),
                n => format!("at {n} spp"),
            });
        }
        bar.set_position(p.tiles_done as u64);
    });
    bar.finish_and_clear();
    let series = match result {
        Ok(s) => s,
        Err(ConvergeError::Render(e)) => return fail(&e),
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let (csv, plot) = converge::default_paths(&args.scene);
    let csv = args.csv.clone().unwrap_or(csv);
    let plot = args.plot.clone().unwrap_or(plot);
    for (path, text) in [(&csv, series.csv()), (&plot, series.svg())] {
        if let Err(e) = std::fs::write(path, text) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    if !args.quiet {
        let num = |v: Option<f64>| v.map(|v| format!("{v:.3e}")).unwrap_or_else(|| "-".into());
        println!(
            "{:>6} {:>9} {:>8} {:>9} {:>10} {:>10} {:>6}",
            "spp", "render s", "Mrays", "ns/sample", "relMSE", "estimate", "ratio"
        );
        for r in &series.rows {
            let ratio = r.estimate.zip(r.rel_mse).map(|(e, t)| format!("{:.2}", e / t));
            println!(
                "{:>6} {:>9.3} {:>8.2} {:>9.1} {:>10} {:>10} {:>6}",
                r.spp,
                r.render_seconds,
                r.rays as f64 / 1e6,
                r.ns_per_sample,
                num(r.rel_mse),
                num(r.estimate),
                ratio.unwrap_or_else(|| "-".into())
            );
        }
        println!("wrote {} and {}", csv.display(), plot.display());
    }
    ExitCode::SUCCESS
}

/// `farm bench`: one child process per shared scene; prints the table as
/// rows finish and writes the CSV.
fn run_bench(args: &BenchArgs) -> ExitCode {
    use crate::bench;
    if !args.shared.join("reference/README.md").is_file() {
        eprintln!(
            "error: {} has no reference/README.md (give the shared folder with --shared)",
            args.shared.display()
        );
        return ExitCode::from(EXIT_BAD_INPUT);
    }
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: cannot find the farm binary: {e}");
            return ExitCode::FAILURE;
        }
    };
    println!(
        "{:<30} {:>4} {:>7} {:>7} {:>7} {:>7} {:>6} {:>8} {:>8} {:>6} {:>6} {:>8}",
        "scene",
        "spp",
        "wall s",
        "pbrt",
        "CPU s",
        "pbrt",
        "ratio",
        "start s",
        "Mrays/s",
        "RSS MB",
        "pbrt",
        "speed-up"
    );
    let opts = bench::BenchOptions {
        only: args.scene.clone(),
        threads: args.threads,
        scaling: args.scaling,
        runs: args.runs as usize,
    };
    let rows = bench::run(&exe, &args.shared, &opts, |r| {
        let p = r.scene.pbrt.clone().unwrap_or_default();
        let speedup = r.speedup().map(|v| format!("{v:.2}")).unwrap_or_else(|| "-".into());
        match &r.measured {
            Ok(m) => println!(
                "{:<30} {:>4} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>6.2} {:>8.3} {:>8.2} {:>6.0} {:>6.0} {speedup:>8}",
                r.scene.scene,
                m.spp,
                m.wall,
                p.wall,
                m.cpu,
                p.cpu,
                if p.cpu > 0.0 { m.cpu / p.cpu } else { f64::NAN },
                m.startup,
                m.rays_per_second / 1e6,
                m.peak_rss_mb,
                p.rss_mb
            ),
            Err(e) => println!("{:<30} {e}", r.scene.scene),
        }
    });
    if let Some(g) = bench::cpu_ratio_geomean(&rows) {
        println!("geometric mean of CPU s / pbrt-v3 CPU s: {g:.3}");
    }
    if let Err(e) = std::fs::write(&args.csv, bench::csv(&rows)) {
        eprintln!("error: cannot write {}: {e}", args.csv.display());
        return ExitCode::FAILURE;
    }
    println!("wrote {}", args.csv.display());
    if rows.iter().any(|r| r.measured.is_err()) {
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}

/// Prints warnings, writes the image and prints the summary line.
fn finish(args: &SubmitArgs, summary: submit::RenderSummary) -> ExitCode {
    if !args.quiet {
        for w in &summary.warnings {
            eprintln!("{w}");
        }
    }
    if let Err(e) = submit::write(&summary) {
        return fail(&e);
    }
    if let Some(path) = &args.error_map {
        match &summary.error {
            Some(error) => {
                if let Err(e) = submit::write_error_map(path, &summary, error) {
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
            println!("{line}");
        }
    }
    if !args.quiet {
        let secs = summary.render_seconds.max(1e-9);
        let error = match &summary.error {
            Some(e) => format!(", estimated relMSE {:.3e}", e.rel_mse),
            None => String::new(),
        };
        println!(
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
    }
    ExitCode::SUCCESS
}

fn fail(e: &SubmitError) -> ExitCode {
    eprintln!("error: {e}");
    match e {
        SubmitError::Scene(_) | SubmitError::Build(_) => ExitCode::from(EXIT_BAD_INPUT),
        _ => ExitCode::FAILURE,
    }
}
