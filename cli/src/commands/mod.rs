//! One module per `farm` subcommand: its arguments and what it runs.

pub mod bench;
pub mod cancel;
pub mod converge;
pub mod coordinator;
pub mod diff;
pub mod health;
pub mod shot;
pub mod status;
pub mod submit;
pub mod token;
pub mod watch;
pub mod worker;

use crate::client::Remote;
use crate::error::Error;
use farm_common::film::Limits;
use farm_proto::auth::Token;
use std::path::PathBuf;

/// Arguments naming a coordinator.
#[derive(Debug, clap::Args)]
pub struct RemoteArgs {
    /// The coordinator, e.g. https://render-host:7878 (http:// only for one
    /// started with --insecure).
    #[arg(long, env = "FARM_COORDINATOR")]
    pub coordinator: String,
    /// The token.
    #[command(flatten)]
    pub token: TokenArgs,
}

impl RemoteArgs {
    /// The coordinator and the token to present.
    pub fn remote(&self) -> Result<Remote, Error> {
        Ok(Remote { url: self.coordinator.clone(), token: self.token.token()? })
    }
}

/// Where the token comes from.
#[derive(Debug, Default, clap::Args)]
pub struct TokenArgs {
    /// A file holding the token (`farm coordinator` writes DIR/worker.token,
    /// DIR/client.token and DIR/admin.token; `farm token create` prints more).
    #[arg(long, value_name = "FILE", env = "FARM_TOKEN_FILE")]
    pub token_file: Option<PathBuf>,
}

impl TokenArgs {
    /// The token from --token-file, else from $FARM_TOKEN, if either is set.
    pub fn token(&self) -> Result<Option<Token>, Error> {
        let (text, from) = match &self.token_file {
            Some(f) => {
                let text = std::fs::read_to_string(f).map_err(|e| {
                    Error::Token(format!("cannot read the token file {}: {e}", f.display()))
                })?;
                (text, f.display().to_string())
            }
            None => match std::env::var("FARM_TOKEN") {
                Ok(t) if !t.trim().is_empty() => (t, "FARM_TOKEN".to_string()),
                _ => return Ok(None),
            },
        };
        text.trim().parse().map(Some).map_err(|e| Error::Token(format!("{from}: {e}")))
    }
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
