//! The `farm` command line: one module per subcommand, the embedded render
//! engine (the coordinator's scheduler with an in-process worker), the
//! client of a remote coordinator, and the bench and converge tools. The
//! binary's `main` only parses arguments and sets up logging.
#![warn(missing_docs)]

/// Prints a line on standard output; a closed pipe (`farm diff … | head`)
/// ends the output quietly instead of panicking as `println!` does.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// `farm bench`: shared scenes against pbrt-v3's time and memory.
pub mod bench;
/// Talking to a coordinator.
pub mod client;
/// The subcommands.
pub mod commands;
/// `farm converge`: error against time over increasing sample counts.
pub mod converge;
/// Streaming the image to tev as it renders.
pub mod display;
/// Rendering a scene file in this process with the farm's scheduler.
pub mod embedded;
/// The CLI's errors and their exit codes.
pub mod error;
/// A shot's frames: their inputs, numbers and output names.
pub mod frames;
/// What a render in passes prints.
pub mod passes;
/// The terminal progress bar.
pub mod progress;
/// The async runtime and shutdown signals.
pub mod runtime;
/// A shot's frames rendered on a farm.
pub mod shot;

pub use error::{Error, Result};

use clap::{Parser, Subcommand};
use runtime::{block_on, block_on_one_thread};
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
    Submit(commands::submit::SubmitArgs),
    /// Run a coordinator that workers and clients connect to.
    Coordinator(commands::coordinator::CoordinatorArgs),
    /// Render tiles for a coordinator with every core of this machine.
    Worker(commands::worker::WorkerArgs),
    /// List a coordinator's jobs and workers.
    Status(commands::status::StatusArgs),
    /// Cancel a job on a coordinator.
    Cancel(commands::cancel::CancelArgs),
    /// Attach to a job on a coordinator and write its image when it is done.
    Watch(commands::watch::WatchArgs),
    /// Make, list and revoke a coordinator's tokens (on its host).
    Token(commands::token::TokenArgs),
    /// Exit 0 if the gRPC health service at an address reports SERVING.
    Health(commands::health::HealthArgs),
    /// Compare an image with a reference (like pbrt-v3's `imgtool diff`).
    Diff(commands::diff::DiffArgs),
    /// Render a scene at increasing sample counts and tabulate and plot its
    /// error against render time.
    Converge(commands::converge::ConvergeArgs),
    /// Render every shared pbrt-v3 scene found and tabulate time, rays and
    /// peak memory next to pbrt-v3's.
    Bench(commands::bench::BenchArgs),
    /// Render one scene and print its measurements (used by `farm bench`).
    #[command(hide = true)]
    BenchOne(commands::bench::BenchOneArgs),
}

/// Exit code for bad input (scene errors, usage errors).
pub const EXIT_BAD_INPUT: u8 = 2;

/// Runs a parsed command line and returns the process exit code.
pub fn run(cli: Cli) -> ExitCode {
    match cli.command {
        Command::Submit(args) => commands::submit::run(args),
        Command::Coordinator(args) => block_on(commands::coordinator::run(args)),
        Command::Worker(args) => block_on_one_thread(commands::worker::run(args)),
        Command::Status(args) => block_on(commands::status::run(args)),
        Command::Cancel(args) => block_on(commands::cancel::run(args)),
        Command::Watch(args) => block_on(commands::watch::run(args)),
        Command::Token(args) => commands::token::run(args),
        Command::Diff(args) => commands::diff::run(&args),
        Command::Converge(args) => commands::converge::run(&args),
        Command::Bench(args) => commands::bench::run(&args),
        Command::BenchOne(args) => commands::bench::run_one(&args),
        Command::Health(args) => block_on(commands::health::run(args)),
    }
}
