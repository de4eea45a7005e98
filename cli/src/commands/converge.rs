//! `farm converge`: error against render time over increasing sample counts.

use std::path::PathBuf;
use std::process::ExitCode;

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
    /// Render with this sampler instead of the scene's (see `farm submit
    /// --sampler`).
    #[arg(long, value_name = "NAME", value_parser = clap::builder::PossibleValuesParser::new(farm_scene::SAMPLER_NAMES))]
    pub sampler: Option<String>,
    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `farm converge`: renders the series, prints the table and writes the
/// CSV and the plot.
pub fn run(args: &ConvergeArgs) -> ExitCode {
    use crate::converge::{self, ConvergeOptions};
    let opts = ConvergeOptions {
        spp: args.spp.clone(),
        reference: args.reference.clone(),
        threads: args.threads,
        sampler: args.sampler.clone(),
    };
    let bar = crate::progress::progress_bar(args.quiet);
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
        Err(e) => return super::submit::fail(&e),
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
        say!(
            "{:>6} {:>9} {:>8} {:>9} {:>10} {:>10} {:>6}",
            "spp",
            "render s",
            "Mrays",
            "ns/sample",
            "relMSE",
            "estimate",
            "ratio"
        );
        for r in &series.rows {
            let ratio = r.estimate.zip(r.rel_mse).map(|(e, t)| format!("{:.2}", e / t));
            say!(
                "{:>6} {:>9.3} {:>8.2} {:>9.1} {:>10} {:>10} {:>6}",
                r.spp,
                r.render_seconds,
                r.rays as f64 / 1e6,
                r.ns_per_sample,
                num(r.rel_mse),
                match r.upper {
                    // A lower bound (the render has fireflies or light edges).
                    Some(_) => format!(">={}", num(r.estimate)),
                    None => num(r.estimate),
                },
                ratio.unwrap_or_else(|| "-".into())
            );
        }
        say!("wrote {} and {}", csv.display(), plot.display());
    }
    ExitCode::SUCCESS
}
