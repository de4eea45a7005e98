//! One module per `farm` subcommand: its arguments and what it runs.

pub mod bench;
pub mod cancel;
pub mod converge;
pub mod coordinator;
pub mod diff;
pub mod health;
pub mod status;
pub mod submit;
pub mod worker;

use farm_common::film::Limits;

/// Arguments naming a coordinator.
#[derive(Debug, clap::Args)]
pub struct RemoteArgs {
    /// The coordinator, e.g. http://render-host:7878.
    #[arg(long, env = "FARM_COORDINATOR")]
    pub coordinator: String,
}

/// The largest job to accept, checked before anything is allocated.
#[derive(Debug, clap::Args)]
pub struct LimitArgs {
    /// Most film pixels (xresolution × yresolution).
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_pixels)]
    pub max_pixels: u64,
    /// Most samples per pixel.
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_spp)]
    pub max_spp: u64,
    /// Most samples in all (film pixels with the filter's margin × samples per pixel).
    #[arg(long, value_name = "N", default_value_t = Limits::default().max_samples)]
    pub max_samples: u64,
}

impl From<&LimitArgs> for Limits {
    fn from(a: &LimitArgs) -> Limits {
        Limits { max_pixels: a.max_pixels, max_spp: a.max_spp, max_samples: a.max_samples }
    }
}
