//! The `farm` command line: parse arguments, run, print for people.

use crate::submit::{self, SubmitError, SubmitOptions};
use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::PathBuf;
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
    /// Render a pbrt-v3 scene (in this process, on every core).
    Submit(SubmitArgs),
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
}

/// Exit code for bad input (scene errors, usage errors).
pub const EXIT_BAD_INPUT: u8 = 2;

/// Runs a parsed command line and returns the process exit code.
pub fn run(cli: Cli) -> ExitCode {
    match cli.command {
        Command::Submit(args) => run_submit(args),
    }
}

fn run_submit(args: SubmitArgs) -> ExitCode {
    let opts = SubmitOptions { output: args.output.clone(), spp: args.spp, threads: args.threads };
    let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
    if args.quiet {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} Rendering [{bar:30}] {pos}/{len} tiles  {msg}  ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
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
    let summary = match result {
        Ok(s) => s,
        Err(e) => return fail(&e),
    };
    if !args.quiet {
        for w in &summary.warnings {
            eprintln!("{w}");
        }
    }
    if let Err(e) = submit::write(&summary) {
        return fail(&e);
    }
    let s = &summary.stats;
    let bad = s.nan_samples + s.inf_samples + s.negative_samples;
    if bad > 0 {
        eprintln!(
            "warning: {bad} samples had bad radiance and were set to black ({} NaN, {} infinite, {} negative)",
            s.nan_samples, s.inf_samples, s.negative_samples
        );
    }
    if !args.quiet {
        let secs = summary.render_seconds.max(1e-9);
        println!(
            "{}: {}×{}, {} spp, {:.2} s ({:.2} s start-up), {:.1}M rays ({:.2} Mrays/s)",
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
