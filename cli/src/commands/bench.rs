//! `farm bench` and the hidden `farm bench-one` it runs per scene.

use crate::EXIT_BAD_INPUT;
use std::path::PathBuf;
use std::process::ExitCode;

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
    /// A pbrt-v3 binary: render each scene with it too, in turn with farm,
    /// and compare against those numbers instead of the reference table's.
    #[arg(long, value_name = "PATH", env = "FARM_PBRT")]
    pub pbrt: Option<PathBuf>,
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

/// `farm bench`: one child process per shared scene; prints the table as
/// rows finish and writes the CSV.
pub fn run(args: &BenchArgs) -> ExitCode {
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
    match &args.pbrt {
        Some(p) => say!("pbrt-v3: {}, run in turn with farm on this machine", p.display()),
        None => say!(
            "pbrt-v3: the reference README's numbers, from another machine and day \
             (--pbrt PATH runs it side by side)"
        ),
    }
    say!(
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
        pbrt: args.pbrt.clone(),
    };
    let rows = bench::run(&exe, &args.shared, &opts, |r| {
        let p = r.pbrt().unwrap_or_default();
        let speedup = r.speedup().map(|v| format!("{v:.2}")).unwrap_or_else(|| "-".into());
        match &r.measured {
            Ok(m) => say!(
                "{:<30} {:>4} {:>7.2} {:>7.2} {:>7.2} {:>7.2} {:>6.2} {:>8.3} {:>8.2} {:>6.0} {:>6.0} {speedup:>8}",
                r.scene.scene,
                m.spp,
                m.wall,
                p.wall,
                m.cpu,
                p.cpu,
                r.cpu_ratio().unwrap_or(f64::NAN),
                m.startup,
                m.rays_per_second / 1e6,
                m.peak_rss_mb,
                p.rss_mb
            ),
            Err(e) => say!("{:<30} {e}", r.scene.scene),
        }
        if let Some(Err(e)) = &r.pbrt_here {
            say!("{:<30} {e}", "");
        }
    });
    if let Some(g) = bench::cpu_ratio_geomean(&rows) {
        say!("geometric mean of CPU s / pbrt-v3 CPU s: {g:.3}");
    }
    if let Err(e) = std::fs::write(&args.csv, bench::csv(&rows)) {
        eprintln!("error: cannot write {}: {e}", args.csv.display());
        return ExitCode::FAILURE;
    }
    say!("wrote {}", args.csv.display());
    if rows.iter().any(|r| r.measured.is_err() || matches!(r.pbrt_here, Some(Err(_)))) {
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}

/// Renders one scene here and prints the line `farm bench` reads.
pub fn run_one(args: &BenchOneArgs) -> ExitCode {
    match crate::bench::measure_here(&args.scene, args.threads) {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => super::submit::fail(&e),
    }
}
