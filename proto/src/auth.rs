//! Tokens: what a worker or client presents to a coordinator, and what
//! tells it which coordinator to trust.
//!
//! ```text
//! farm1:3b0c…e9a1:4f2a9c1e07d2.8c1f…
//!       │         │            └ secret (never stored by the coordinator, only its hash)
//!       │         └ token id (names the token in listings and revocations)
//!       └ SHA-256 of the coordinator's CA certificate (DER), as
//!         kubeadm's --discovery-token-ca-cert-hash
//! ```
//!
//! A token alone is enough to connect: its fingerprint pins the CA, so the
//! client needs no certificate file. The secret never appears in `Debug`
//! output, logs or error messages.

use std::fmt;
use std::str::FromStr;

/// What a token may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Role {
    /// Register, work and fetch blobs.
    Worker,
    /// Submit, upload, and watch, list and cancel its own jobs.
    Client,
    /// Everything.
    Admin,
}

impl Role {
    /// The lower-case name used on the command line and in listings.
    pub fn name(self) -> &'static str {
        match self {
            Role::Worker => "worker",
            Role::Client => "client",
            Role::Admin => "admin",
        }
    }
}

impl FromStr for Role {
    type Err = String;
    fn from_str(s: &str) -> Result<Role, String> {
        match s {
            "worker" => Ok(Role::Worker),
            "client" => Ok(Role::Client),
            "admin" => Ok(Role::Admin),
            _ => Err(format!("unknown role \"{s}\" (expected worker, client or admin)")),
        }
    }
}

impl fmt::Display for Role {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// SHA-256 of a certificate's DER bytes.
pub type Fingerprint = [u8; 32];

/// The SHA-256 fingerprint of DER bytes.
pub fn fingerprint(der: &[u8]) -> Fingerprint {
    let d = ring::digest::digest(&ring::digest::SHA256, der);
    let mut f = [0u8; 32];
    f.copy_from_slice(d.as_ref());
    f
}

/// A parsed token.
#[derive(Clone, PartialEq, Eq)]
pub struct Token {
    /// The CA it trusts.
    pub ca: Fingerprint,
    /// Its id.
    pub id: String,
    /// Its secret.
    pub secret: String,
}

const PREFIX: &str = "farm1";

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Lower-case hex of a fingerprint, for messages.
pub fn fingerprint_hex(f: &Fingerprint) -> String {
    hex(f)
}

fn is_word(s: &str) -> bool {
    !s.is_empty() && s.len() <= 64 && s.bytes().all(|b| b.is_ascii_alphanumeric())
}

impl Token {
    /// The token's text, as written to token files.
    pub fn expose(&self) -> String {
        format!("{PREFIX}:{}:{}.{}", hex(&self.ca), self.id, self.secret)
    }
}

impl fmt::Debug for Token {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Token").field("id", &self.id).field("secret", &"<redacted>").finish()
    }
}

/// Why a token's text was refused (the text itself is never repeated).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("malformed token: {0} (expected farm1:<CA fingerprint>:<id>.<secret>, as `farm token create` prints)")]
pub struct BadToken(&'static str);

impl FromStr for Token {
    type Err = BadToken;
    fn from_str(s: &str) -> Result<Token, BadToken> {
        let mut parts = s.trim().splitn(3, ':');
        if parts.next() != Some(PREFIX) {
            return Err(BadToken("it does not start with farm1:"));
        }
        let fp = parts.next().ok_or(BadToken("no CA fingerprint"))?;
        let rest = parts.next().ok_or(BadToken("no id and secret"))?;
        if fp.len() != 64 {
            return Err(BadToken("the CA fingerprint is not 64 hex digits"));
        }
        let mut ca = [0u8; 32];
        for (i, b) in ca.iter_mut().enumerate() {
            *b = u8::from_str_radix(&fp[2 * i..2 * i + 2], 16)
                .map_err(|_| BadToken("the CA fingerprint is not 64 hex digits"))?;
        }
        let (id, secret) = rest.split_once('.').ok_or(BadToken("no '.' between id and secret"))?;
        if !is_word(id) || !is_word(secret) {
            return Err(BadToken("the id or secret is not 1 to 64 letters and digits"));
        }
        Ok(Token { ca, id: id.to_string(), secret: secret.to_string() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_round_trip_and_never_show_their_secret() {
        let t = Token { ca: [0xab; 32], id: "4f2a".into(), secret: "s3cr3t".into() };
        let text = t.expose();
        assert!(text.starts_with("farm1:abab") && text.ends_with(":4f2a.s3cr3t"), "{text}");
        assert_eq!(text.parse::<Token>().unwrap(), t);
        assert!(!format!("{t:?}").contains("s3cr3t"));
        for bad in ["", "farm2:ab:c.d", "farm1:abab:c.d", &text.replace('.', "-")] {
            let e = bad.parse::<Token>().unwrap_err().to_string();
            assert!(!e.contains("s3cr3t"), "{e}");
        }
        assert!(format!("farm1:{}:a.b c", "0".repeat(64)).parse::<Token>().is_err());
        assert_eq!("client".parse::<Role>(), Ok(Role::Client));
        assert!("root".parse::<Role>().is_err());
    }

    #[test]
    fn fingerprints_are_sha256() {
        let f = fingerprint(b"abc");
        assert_eq!(
            fingerprint_hex(&f),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
