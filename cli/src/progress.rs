//! The progress bar long work draws on the terminal.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A tile progress bar on stderr (hidden with `quiet`); its length is set
/// by the first progress report.
pub fn progress_bar(quiet: bool) -> ProgressBar {
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
