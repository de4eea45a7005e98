//! Connecting to a coordinator, as a worker or a client.
//!
//! The URL's scheme means exactly what it says: `https://` is TLS,
//! verified against the CA whose fingerprint the token carries, with the
//! token sent on every call; `http://` is plaintext, for a coordinator
//! started with `--insecure` on a loopback address, and no token is ever
//! sent over it. A mismatch between the scheme and what the coordinator
//! speaks is a clear error, never a silent downgrade.

use crate::auth::{fingerprint, fingerprint_hex, Fingerprint, Token};
use crate::v1::coordinator_client::CoordinatorClient;
use crate::MAX_MESSAGE_SIZE;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;
use tokio_rustls::rustls::client::danger::{
    HandshakeSignatureValid, ServerCertVerified, ServerCertVerifier,
};
use tokio_rustls::rustls::client::WebPkiServerVerifier;
use tokio_rustls::rustls::crypto::{self, CryptoProvider};
use tokio_rustls::rustls::pki_types::{CertificateDer, ServerName, UnixTime};
use tokio_rustls::rustls::{self, CertificateError, DigitallySignedStruct, RootCertStore};
use tonic::metadata::{Ascii, MetadataValue};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Channel, ClientTlsConfig, Endpoint};

/// A coordinator client that sends its token with every call.
pub type Client = CoordinatorClient<InterceptedService<Channel, Bearer>>;

/// Adds `authorization: Bearer <token>` to every request (or nothing).
#[derive(Clone)]
pub struct Bearer(Option<MetadataValue<Ascii>>);

impl tonic::service::Interceptor for Bearer {
    fn call(&mut self, mut req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        if let Some(v) = &self.0 {
            req.metadata_mut().insert("authorization", v.clone());
        }
        Ok(req)
    }
}

/// Why a connection could not be made. None of these repeat the token.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// Not an http:// or https:// URL.
    #[error("{0} is not a coordinator URL (expected http://HOST:PORT or https://HOST:PORT)")]
    BadUrl(String),
    /// https:// without a token to pin the CA.
    #[error("{0} is https: give a token (--token-file FILE or FARM_TOKEN) so the coordinator's certificate can be checked")]
    NeedToken(String),
    /// The server's certificate is not from the token's CA.
    #[error("the coordinator at {url} has a certificate that does not come from the CA this token trusts (fingerprint {ca}…): a token of another coordinator, or not the coordinator you meant")]
    WrongCa {
        /// The URL.
        url: String,
        /// The start of the pinned fingerprint.
        ca: String,
    },
    /// The connection failed.
    #[error("cannot reach the coordinator at {url}: {message}{hint}")]
    Failed {
        /// The URL.
        url: String,
        /// What failed, with its causes.
        message: String,
        /// What the user may have meant.
        hint: &'static str,
    },
}

/// The causes of an error, joined.
fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut parts = vec![e.to_string()];
    let mut cur = e.source();
    while let Some(s) = cur {
        let m = s.to_string();
        if !parts.iter().any(|p| p.contains(&m)) {
            parts.push(m);
        }
        cur = s.source();
    }
    parts.join(": ")
}

/// Connects to the coordinator at `url`. With `https://`, `token` is
/// required: its fingerprint names the CA the coordinator's certificate
/// must come from, and it is sent with every call.
pub async fn connect(url: &str, token: Option<&Token>) -> Result<Client, ConnectError> {
    let (channel, bearer) = channel(url, token).await?;
    Ok(CoordinatorClient::with_interceptor(channel, bearer)
        .max_decoding_message_size(MAX_MESSAGE_SIZE)
        .max_encoding_message_size(MAX_MESSAGE_SIZE))
}

/// The connection [`connect`] makes, and the interceptor that sends the
/// token on it (for other services on the same port, such as health).
pub async fn channel(url: &str, token: Option<&Token>) -> Result<(Channel, Bearer), ConnectError> {
    let uri: tonic::codegen::http::Uri =
        url.parse().map_err(|_| ConnectError::BadUrl(url.to_string()))?;
    let host = uri.host().ok_or_else(|| ConnectError::BadUrl(url.to_string()))?;
    let host = host.trim_start_matches('[').trim_end_matches(']').to_string();
    let endpoint = Endpoint::from_shared(url.to_string())
        .map_err(|_| ConnectError::BadUrl(url.to_string()))?
        .connect_timeout(Duration::from_secs(5))
        // Images, previews and blobs come in megabytes: HTTP/2's 64 KiB
        // default windows would have the coordinator send them in 64 KiB
        // rounds, each waiting for this side's window update; and in
        // frames of up to 1 MiB rather than HTTP/2's 16 KiB, each frame
        // costing the coordinator the same whatever its size.
        .initial_stream_window_size(Some(4 << 20))
        .initial_connection_window_size(Some(8 << 20))
        .max_frame_size(1 << 20);
    let mut pinned = None;
    let (endpoint, bearer, hint) = match uri.scheme_str() {
        Some("http") => (
            endpoint,
            Bearer(None),
            " (if the coordinator uses TLS, the default, its URL starts with https://)",
        ),
        Some("https") => {
            let token = token.ok_or_else(|| ConnectError::NeedToken(url.to_string()))?;
            let tls = ClientTlsConfig::new().domain_name(host);
            let verifier = Arc::new(PinnedCa::new(token.ca));
            pinned = Some(verifier.clone());
            let endpoint = endpoint.tls_config_with_verifier(tls, verifier).map_err(|e| {
                ConnectError::Failed { url: url.to_string(), message: chain(&e), hint: "" }
            })?;
            let value = format!("Bearer {}", token.expose())
                .parse()
                .map_err(|_| ConnectError::NeedToken(url.to_string()))?;
            (
                endpoint,
                Bearer(Some(value)),
                " (if the coordinator was started with --insecure, its URL starts with http://)",
            )
        }
        _ => return Err(ConnectError::BadUrl(url.to_string())),
    };
    let channel = endpoint.connect().await.map_err(|e| match &pinned {
        Some(p) if p.refused.load(Ordering::Relaxed) => {
            ConnectError::WrongCa { url: url.to_string(), ca: fingerprint_hex(&p.pin)[..16].into() }
        }
        _ => ConnectError::Failed { url: url.to_string(), message: chain(&e), hint },
    })?;
    // A plaintext connection to a TLS port "connects" and fails at the
    // first call: ask the health service (which needs no token) once, so
    // a wrong scheme is reported here, with the hint, not as a puzzling
    // HTTP/2 error later.
    let mut health = tonic_health::pb::health_client::HealthClient::new(channel.clone());
    let probe = health.check(tonic_health::pb::HealthCheckRequest { service: String::new() });
    match tokio::time::timeout(Duration::from_secs(10), probe).await {
        Ok(Ok(_)) => {}
        Ok(Err(status)) if status.code() == tonic::Code::Unimplemented => {}
        Ok(Err(status)) => {
            let message = status.message().to_string();
            return Err(ConnectError::Failed { url: url.to_string(), message, hint });
        }
        Err(_) => {
            let message = "no answer in 10 s".to_string();
            return Err(ConnectError::Failed { url: url.to_string(), message, hint });
        }
    }
    Ok((channel, bearer))
}

fn provider() -> Arc<CryptoProvider> {
    CryptoProvider::get_default()
        .cloned()
        .unwrap_or_else(|| Arc::new(crypto::ring::default_provider()))
}

/// Trusts a server whose chain holds the certificate with fingerprint
/// `pin`: the leaf itself (a pinned certificate), or a CA the leaf is then
/// verified against as usual (signature, validity, host name).
#[derive(Debug)]
pub struct PinnedCa {
    pin: Fingerprint,
    provider: Arc<CryptoProvider>,
    /// Set when a server's chain did not hold the pinned certificate.
    refused: AtomicBool,
}

impl PinnedCa {
    /// A verifier trusting the CA with this fingerprint.
    pub fn new(pin: Fingerprint) -> Self {
        PinnedCa { pin, provider: provider(), refused: AtomicBool::new(false) }
    }
}

impl ServerCertVerifier for PinnedCa {
    fn verify_server_cert(
        &self,
        end_entity: &CertificateDer<'_>,
        intermediates: &[CertificateDer<'_>],
        server_name: &ServerName<'_>,
        ocsp_response: &[u8],
        now: UnixTime,
    ) -> Result<ServerCertVerified, rustls::Error> {
        if fingerprint(end_entity) == self.pin {
            return Ok(ServerCertVerified::assertion());
        }
        let Some(ca) = intermediates.iter().find(|c| fingerprint(c) == self.pin) else {
            self.refused.store(true, Ordering::Relaxed);
            return Err(rustls::Error::InvalidCertificate(CertificateError::UnknownIssuer));
        };
        let mut roots = RootCertStore::empty();
        roots.add(ca.clone().into_owned())?;
        let inner =
            WebPkiServerVerifier::builder_with_provider(Arc::new(roots), self.provider.clone())
                .build()
                .map_err(|e| rustls::Error::General(e.to_string()))?;
        inner.verify_server_cert(end_entity, intermediates, server_name, ocsp_response, now)
    }

    fn verify_tls12_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> Result<HandshakeSignatureValid, rustls::Error> {
        let algs = &self.provider.signature_verification_algorithms;
        crypto::verify_tls12_signature(message, cert, dss, algs)
    }

    fn verify_tls13_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> Result<HandshakeSignatureValid, rustls::Error> {
        let algs = &self.provider.signature_verification_algorithms;
        crypto::verify_tls13_signature(message, cert, dss, algs)
    }

    fn supported_verify_schemes(&self) -> Vec<rustls::SignatureScheme> {
        self.provider.signature_verification_algorithms.supported_schemes()
    }
}
