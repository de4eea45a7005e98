//! TLS and tokens on a real (in-process) coordinator: each role does only
//! its part, a token of another coordinator's CA is refused, a scheme that
//! does not match the coordinator is a clear error, and clients see and
//! cancel only their own jobs. The image over TLS is bit-identical to the
//! embedded render.

use farm_cli::client::{self, Remote, RemoteOptions};
use farm_coordinator::security::{bootstrap, Security};
use farm_proto::connect::connect;
use farm_proto::v1;
use farm_proto::PROTOCOL_VERSION;
use farm_tests::cluster::{token_in, TestCluster};
use farm_tests::{bits, example_scene as scene};
use std::path::PathBuf;
use std::time::Duration;

const SPP: u32 = 2;

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("farm-sec-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn code<T: std::fmt::Debug>(r: Result<T, farm_cli::Error>) -> tonic::Code {
    match r {
        Err(farm_cli::Error::Rpc(s)) => s.code(),
        other => panic!("expected a refused call, got {other:?}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn over_tls_with_tokens_the_image_is_the_embedded_one() {
    let dir = temp("render");
    let cluster = TestCluster::start_secure(2, Duration::from_millis(300), &dir).await;
    assert!(cluster.url.starts_with("https://"));
    let opts = RemoteOptions { spp: Some(SPP), ..Default::default() };
    let farm = client::submit(&cluster.remote(), &scene(), &opts, |_, _| {}).await.expect("farm");
    let embedded = farm_tests::embedded_example(SPP);
    assert!(bits(&farm.image) == bits(&embedded), "TLS changed the image");
    // farm status names the owner and counts hand-outs.
    let s = client::status(&cluster.remote()).await.expect("status");
    assert_eq!(s.jobs[0].owner, "first client");
    assert!(s.jobs[0].attempts >= s.jobs[0].tiles_total, "{:?}", s.jobs[0]);
    cluster.stop().await;
    std::fs::remove_dir_all(dir).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn each_token_does_only_its_part() {
    let dir = temp("roles");
    let cluster = TestCluster::start_secure(0, Duration::from_millis(300), &dir).await;
    let url = cluster.url.clone();
    let as_role = |role: &str| Remote { url: url.clone(), token: Some(token_in(&dir, role)) };
    // No token at all: https needs one even to know which CA to trust.
    let anonymous = Remote { url: url.clone(), token: None };
    let e = client::status(&anonymous).await.unwrap_err();
    assert!(e.to_string().contains("give a token"), "{e}");
    // A well-formed token with a wrong secret is refused as unauthenticated.
    let mut forged = token_in(&dir, "client");
    forged.secret = "0".repeat(40);
    let forged = Remote { url: url.clone(), token: Some(forged) };
    assert_eq!(code(client::status(&forged).await), tonic::Code::Unauthenticated);
    // A call over a verified TLS connection but with no authorization
    // header is refused too.
    let (channel, _) =
        farm_proto::connect::channel(&url, Some(&token_in(&dir, "client"))).await.expect("tls");
    let mut raw = v1::coordinator_client::CoordinatorClient::new(channel);
    let e = raw.get_status(v1::GetStatusRequest {}).await.unwrap_err();
    assert_eq!(e.code(), tonic::Code::Unauthenticated, "{e}");
    // A worker token cannot submit, list or cancel.
    let worker = as_role("worker");
    let opts = RemoteOptions { spp: Some(SPP), ..Default::default() };
    let r = client::submit(&worker, &scene(), &opts, |_, _| {}).await;
    assert_eq!(code(r), tonic::Code::PermissionDenied);
    assert_eq!(code(client::status(&worker).await), tonic::Code::PermissionDenied);
    assert_eq!(code(client::cancel(&worker, 1).await), tonic::Code::PermissionDenied);
    // A client token cannot register, work or fetch blobs.
    let mut c = connect(&url, Some(&token_in(&dir, "client"))).await.expect("connect");
    let reg = v1::RegisterWorkerRequest {
        protocol_version: PROTOCOL_VERSION,
        name: "x".into(),
        threads: 1,
    };
    assert_eq!(c.register_worker(reg).await.unwrap_err().code(), tonic::Code::PermissionDenied);
    let fetch = c.fetch_blob(v1::FetchBlobRequest { hash: vec![0; 32] }).await;
    assert_eq!(fetch.map(|_| ()).unwrap_err().code(), tonic::Code::PermissionDenied);
    // A revoked token is refused from its next call on.
    let client = as_role("client");
    assert!(client::status(&client).await.is_ok());
    let store = farm_coordinator::security::TokenStore::open(&dir).expect("db");
    assert!(store.revoke(&client.token.as_ref().unwrap().id).expect("revoke"));
    assert_eq!(code(client::status(&client).await), tonic::Code::Unauthenticated);
    cluster.stop().await;
    std::fs::remove_dir_all(dir).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn another_coordinators_token_and_a_wrong_scheme_are_clear_errors() {
    let (dir, other) = (temp("ca"), temp("other-ca"));
    let cluster = TestCluster::start_secure(0, Duration::from_millis(300), &dir).await;
    let hosts = ["127.0.0.1".to_string()];
    let Security::Tls { .. } = bootstrap(&other, &hosts, None).expect("other CA") else {
        panic!("not TLS")
    };
    // The other coordinator's client token pins another CA: the connection
    // is refused before any token is sent.
    let wrong = Remote { url: cluster.url.clone(), token: Some(token_in(&other, "client")) };
    let e = client::status(&wrong).await.unwrap_err().to_string();
    assert!(e.contains("does not come from the CA this token trusts"), "{e}");
    // http:// to a TLS coordinator is not silently downgraded.
    let plain = Remote::insecure(&cluster.url.replace("https://", "http://"));
    let e = client::status(&plain).await.unwrap_err().to_string();
    assert!(e.contains("https://"), "{e}");
    cluster.stop().await;
    // https:// to an insecure coordinator says so.
    let insecure = TestCluster::start(0, Duration::from_millis(300)).await;
    let tls = Remote {
        url: insecure.url.replace("http://", "https://"),
        token: Some(token_in(&dir, "client")),
    };
    let e = client::status(&tls).await.unwrap_err().to_string();
    assert!(e.contains("--insecure") && e.contains("http://"), "{e}");
    insecure.stop().await;
    std::fs::remove_dir_all(dir).ok();
    std::fs::remove_dir_all(other).ok();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn clients_see_and_cancel_only_their_own_jobs() {
    let dir = temp("owners");
    let cluster = TestCluster::start_secure(0, Duration::from_millis(300), &dir).await;
    let store = farm_coordinator::security::TokenStore::open(&dir).expect("db");
    let ca = token_in(&dir, "admin").ca;
    let bob_token = store.create(farm_proto::auth::Role::Client, "bob", ca).expect("token");
    let alice = cluster.remote();
    let bob = Remote { url: cluster.url.clone(), token: Some(bob_token) };
    let admin = Remote { url: cluster.url.clone(), token: Some(token_in(&dir, "admin")) };
    // Alice's job waits: there are no workers.
    let a = alice.clone();
    let job = tokio::spawn(async move {
        let opts = RemoteOptions { spp: Some(SPP), ..Default::default() };
        client::submit(&a, &scene(), &opts, |_, _| {}).await
    });
    let deadline = std::time::Instant::now() + Duration::from_secs(60);
    let id = loop {
        if let Some(j) = client::status(&admin).await.expect("status").jobs.first() {
            break j.job_id;
        }
        assert!(std::time::Instant::now() < deadline, "never queued");
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    assert!(client::status(&bob).await.expect("status").jobs.is_empty(), "bob sees alice's job");
    assert_eq!(code(client::cancel(&bob, id).await), tonic::Code::PermissionDenied);
    let mut c = connect(&bob.url, bob.token.as_ref()).await.expect("connect");
    let watch = c.watch_job(v1::WatchJobRequest { job_id: id, live: false }).await.map(|_| ());
    assert_eq!(watch.unwrap_err().code(), tonic::Code::PermissionDenied);
    // The admin sees it with its owner, and Alice may cancel it.
    assert_eq!(client::status(&admin).await.expect("status").jobs[0].owner, "first client");
    assert!(client::cancel(&alice, id).await.expect("cancel"));
    let r = tokio::time::timeout(Duration::from_secs(30), job).await.expect("ends").expect("task");
    assert!(matches!(r, Err(farm_cli::Error::JobFailed(_))), "{:?}", r.map(|s| s.output));
    cluster.stop().await;
    std::fs::remove_dir_all(dir).ok();
}
