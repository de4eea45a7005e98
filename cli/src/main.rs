//! The `farm` binary: parse the command line, set up logging, run.

use clap::Parser;
use std::io::IsTerminal;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = farm_cli::Cli::parse();
    if matches!(cli.command, farm_cli::Command::Coordinator(_)) {
        kept_heap();
    } else {
        fixed_mmap_threshold();
    }
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("FARM_LOG")
                .unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        // A closed stderr must not turn a log line into a panic.
        .log_internal_errors(false)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
    farm_cli::run(cli)
}

/// Large blocks (1 MiB and up) get pages of their own, given back when
/// freed. glibc otherwise raises its threshold to the size of each large
/// block freed (up to 32 MiB) and serves later ones that size from its
/// heap, where freeing them keeps the memory: a mesh's BVH build records
/// (28 bytes a triangle, freed once the tree is built) stayed resident,
/// 19 MB of a 1M-triangle render's 107 MB peak.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn fixed_mmap_threshold() {
    // SAFETY: mallopt only sets an allocator parameter; it is called
    // before any other thread exists (clap's parsing starts none).
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn fixed_mmap_threshold() {}

/// A coordinator never builds a scene, but its large buffers (tiles in
/// and out of the journal, previews, image chunks) come and go all the
/// time. They are served from the heap, and up to 32 MiB freed at its top
/// is kept for the next ones rather than given back and faulted in again:
/// 1,050 page faults for a 480×320 render instead of 4,000. Only blocks
/// over 32 MiB (glibc's largest threshold; a film's sums over 2M pixels)
/// get pages of their own.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn kept_heap() {
    // SAFETY: as in `fixed_mmap_threshold`.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 32 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn kept_heap() {}
