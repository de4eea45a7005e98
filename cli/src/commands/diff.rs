//! `farm diff`: error metrics of an image against a reference.

use crate::EXIT_BAD_INPUT;
use farm_common::image;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

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

/// `farm diff`: error metrics of an image against a reference.
pub fn run(args: &DiffArgs) -> ExitCode {
    let read = |p: &Path| image::read_file(p).map_err(|e| e.to_string());
    let (image, reference) = match (read(&args.image), read(&args.reference)) {
        (Ok(a), Ok(r)) => (a, r),
        (Err(e), _) | (_, Err(e)) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let Some(e) = image::compare(&image, &reference) else {
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
    say!(
        "{} against {} ({}×{})",
        args.image.display(),
        args.reference.display(),
        image.width,
        image.height
    );
    say!("  relMSE     {:.6e}", e.rel_mse);
    say!("  MSE        {:.6e}", e.mse);
    say!("  RMSE       {:.6e}", e.mse.sqrt());
    say!("  mean |a-r| {:.6e}", e.mean_abs);
    say!("  max |a-r|  {:.6e} at pixel ({}, {})", e.max_abs.0, e.max_abs.1, e.max_abs.2);
    say!("  mean       {:.6e} (image), {:.6e} (reference)", e.means.0, e.means.1);
    say!("  non-finite {} (image), {} (reference)", e.non_finite, e.non_finite_reference);
    if let Some(out) = &args.output {
        let diff = image::RgbImage {
            width: image.width,
            height: image.height,
            pixels: image
                .pixels
                .iter()
                .zip(&reference.pixels)
                .map(|(a, r)| [0, 1, 2].map(|c| (a[c] - r[c]).abs()))
                .collect(),
        };
        let meta = image::ImageMetadata {
            scene: format!("|{} - {}|", args.image.display(), args.reference.display()),
            spp: 0,
            render_seconds: 0.0,
            rel_mse_estimate: None,
        };
        if let Err(err) = image::write_image(out, &diff, &meta) {
            eprintln!("error: {err}");
            return ExitCode::FAILURE;
        }
    }
    ExitCode::SUCCESS
}
