//! The coordinator's own certificate authority, made on first start in its
//! state directory, and the server certificate it signs at every start for
//! the names the coordinator is reached by.
//!
//! ```text
//! DIR/ca.pem   the CA certificate (its SHA-256 is in every token)
//! DIR/ca.key   its private key (mode 0600)
//! ```

use super::SecurityError;
use farm_proto::auth::{fingerprint, Fingerprint};
use rcgen::{
    BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair,
    KeyUsagePurpose,
};
use std::path::Path;

/// What the TLS server presents, and the fingerprint tokens pin.
pub struct ServerIdentity {
    /// PEM: the server certificate, then the CA's.
    pub chain_pem: String,
    /// PEM: the server certificate's key.
    pub key_pem: String,
    /// SHA-256 of the pinned certificate (the CA's, or the last of a
    /// chain given with `--tls-cert`).
    pub ca: Fingerprint,
}

impl std::fmt::Debug for ServerIdentity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ServerIdentity").field("key_pem", &"<redacted>").finish_non_exhaustive()
    }
}

fn ca_params() -> Result<CertificateParams, SecurityError> {
    let mut p = CertificateParams::new(Vec::<String>::new()).map_err(SecurityError::cert)?;
    p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    p.distinguished_name.push(DnType::CommonName, "farm coordinator CA");
    p.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign];
    Ok(p)
}

/// Writes `data` to `path` readable by its owner only.
pub fn write_private(path: &Path, data: &[u8]) -> Result<(), SecurityError> {
    use std::io::Write;
    let mut o = std::fs::OpenOptions::new();
    o.write(true).create(true).truncate(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut o, 0o600);
    let mut f = o.open(path).map_err(|e| SecurityError::io(path, e))?;
    f.write_all(data).map_err(|e| SecurityError::io(path, e))
}

fn read(path: &Path) -> Result<String, SecurityError> {
    std::fs::read_to_string(path).map_err(|e| SecurityError::io(path, e))
}

/// The DER bytes of every certificate in a PEM text.
fn pem_certs(text: &str) -> Vec<Vec<u8>> {
    pem::parse_many(text)
        .unwrap_or_default()
        .into_iter()
        .filter(|p| p.tag() == "CERTIFICATE")
        .map(|p| p.into_contents())
        .collect()
}

/// The state directory's CA, made if absent; returns its PEM, key and fingerprint.
fn load_or_create_ca(dir: &Path) -> Result<(String, KeyPair, Fingerprint), SecurityError> {
    let (cert_path, key_path) = (dir.join("ca.pem"), dir.join("ca.key"));
    if !cert_path.exists() {
        let key = KeyPair::generate().map_err(SecurityError::cert)?;
        let cert = ca_params()?.self_signed(&key).map_err(SecurityError::cert)?;
        write_private(&key_path, key.serialize_pem().as_bytes())?;
        std::fs::write(&cert_path, cert.pem()).map_err(|e| SecurityError::io(&cert_path, e))?;
        tracing::info!(path = %cert_path.display(), "created the coordinator's CA");
    }
    let pem = read(&cert_path)?;
    let key = KeyPair::from_pem(&read(&key_path)?).map_err(SecurityError::cert)?;
    let der = pem_certs(&pem).into_iter().next().ok_or_else(|| {
        SecurityError::Cert(format!("{} holds no certificate", cert_path.display()))
    })?;
    Ok((pem, key, fingerprint(&der)))
}

/// The fingerprint tokens of the state directory carry, if its CA exists.
pub fn ca_fingerprint(dir: &Path) -> Result<Fingerprint, SecurityError> {
    let path = dir.join("ca.pem");
    let der = pem_certs(&read(&path)?)
        .into_iter()
        .next()
        .ok_or_else(|| SecurityError::Cert(format!("{} holds no certificate", path.display())))?;
    Ok(fingerprint(&der))
}

/// The server identity: signed now by the state directory's CA (made on
/// first start) for `hosts` (names or IP addresses).
pub fn own_identity(dir: &Path, hosts: &[String]) -> Result<ServerIdentity, SecurityError> {
    let (ca_pem, ca_key, ca) = load_or_create_ca(dir)?;
    let issuer = Issuer::new(ca_params()?, ca_key);
    let mut p = CertificateParams::new(hosts.to_vec()).map_err(SecurityError::cert)?;
    p.distinguished_name.push(DnType::CommonName, "farm coordinator");
    p.use_authority_key_identifier_extension = true;
    p.key_usages = vec![KeyUsagePurpose::DigitalSignature];
    p.extended_key_usages = vec![ExtendedKeyUsagePurpose::ServerAuth];
    let key = KeyPair::generate().map_err(SecurityError::cert)?;
    let cert = p.signed_by(&key, &issuer).map_err(SecurityError::cert)?;
    Ok(ServerIdentity { chain_pem: cert.pem() + &ca_pem, key_pem: key.serialize_pem(), ca })
}

/// A server identity from `--tls-cert` and `--tls-key`: tokens pin the
/// last certificate of the chain (the CA when the file holds it).
pub fn given_identity(cert: &Path, key: &Path) -> Result<ServerIdentity, SecurityError> {
    let chain_pem = read(cert)?;
    let certs = pem_certs(&chain_pem);
    let last = certs.last().ok_or_else(|| {
        SecurityError::Cert(format!("{} holds no PEM certificate", cert.display()))
    })?;
    Ok(ServerIdentity { ca: fingerprint(last), chain_pem, key_pem: read(key)? })
}
