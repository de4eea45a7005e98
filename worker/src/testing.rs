//! Test helpers: a tiny scene and a fake coordinator that scripts `Work`
//! sessions, serves blobs and counts fetches.

use farm_common::geometry::{DMat4, DVec3};
use farm_common::scene::{
    AnimatedXform, Entity, FileLoc, LightEntity, Param, ParamSet, ParamValue, SceneDescription,
    ShapeEntity,
};
use farm_proto::convert::Hash;
use farm_proto::v1::coordinator_server::{Coordinator, CoordinatorServer};
use farm_proto::v1::*;
use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use tokio::sync::mpsc;
use tokio_stream::wrappers::{ReceiverStream, TcpListenerStream};
use tonic::{Request, Response, Status, Streaming};

fn entity(name: &str, params: Vec<(&str, ParamValue)>) -> Entity {
    let mut set = ParamSet::default();
    for (n, v) in params {
        set.add(Param { name: n.into(), value: v, loc: FileLoc::default() });
    }
    Entity { name: name.into(), params: set, loc: FileLoc::default() }
}

/// A unit sphere 5 units in front of the camera, a point light by the
/// camera, a `size`² film and one (unused) asset.
pub fn tiny_scene(size: i32) -> SceneDescription {
    let mut desc = SceneDescription { name: "tiny".into(), ..Default::default() };
    let res = vec![
        ("xresolution", ParamValue::Int(vec![size])),
        ("yresolution", ParamValue::Int(vec![size])),
    ];
    desc.film = entity("image", res);
    desc.sampler = entity("random", vec![("pixelsamples", ParamValue::Int(vec![1]))]);
    desc.camera.entity = Entity::named("perspective");
    let eye = AnimatedXform::fixed(DMat4::from_translation(DVec3::new(0.0, 0.0, -5.0)));
    desc.camera.world_from_camera = eye;
    desc.shapes.push(ShapeEntity {
        entity: Entity::named("sphere"),
        world_from_object: AnimatedXform::default(),
        reverse_orientation: false,
        material: None,
        area_light: None,
        media: Default::default(),
    });
    desc.lights.push(LightEntity {
        entity: Entity::named("point"),
        world_from_light: eye,
        medium: None,
        shapes_before: 1,
    });
    desc.assets.insert("note.txt".into(), b"an asset".to_vec());
    desc
}

/// The script side of one `Work` session.
pub struct FakeSession {
    /// Messages to the worker; dropping it ends the stream.
    pub to_worker: mpsc::Sender<Result<CoordinatorMessage, Status>>,
    /// Messages from the worker; ends when the worker closes its side.
    pub from_worker: mpsc::Receiver<WorkerMessage>,
}

/// A coordinator whose sessions are driven by the test.
pub struct FakeCoordinator {
    blobs: HashMap<Vec<u8>, Vec<u8>>,
    /// FetchBlob calls so far.
    pub fetches: Arc<AtomicUsize>,
    refuse: bool,
    sessions: mpsc::Sender<FakeSession>,
}

/// Starts a fake coordinator on a free port serving `blobs`; `refuse`
/// makes it refuse every registration. Returns its URL, the sessions as
/// they open and the fetch counter.
pub async fn start_fake(
    blobs: Vec<Vec<u8>>,
    refuse: bool,
) -> (String, mpsc::Receiver<FakeSession>, Arc<AtomicUsize>) {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr: SocketAddr = listener.local_addr().unwrap();
    let (sessions, rx) = mpsc::channel(4);
    let fetches = Arc::new(AtomicUsize::new(0));
    let blobs = blobs.into_iter().map(|d| (blake3::hash(&d).as_bytes().to_vec(), d)).collect();
    let fake = FakeCoordinator { blobs, fetches: fetches.clone(), refuse, sessions };
    tokio::spawn(
        tonic::transport::Server::builder()
            .add_service(CoordinatorServer::new(fake))
            .serve_with_incoming(TcpListenerStream::new(listener)),
    );
    (format!("http://{addr}"), rx, fetches)
}

/// The scene's manifest hash and all its blobs.
pub fn scene_blobs(desc: &SceneDescription) -> (Hash, Vec<Vec<u8>>) {
    let (manifest, assets) = farm_proto::convert::encode_scene(&mut desc.clone()).unwrap();
    let all = std::iter::once(&manifest).chain(&assets).map(|b| b.data.as_ref().clone()).collect();
    (manifest.hash, all)
}

type Stream<T> = ReceiverStream<Result<T, Status>>;

#[tonic::async_trait]
impl Coordinator for FakeCoordinator {
    async fn register_worker(
        &self,
        request: Request<RegisterWorkerRequest>,
    ) -> Result<Response<RegisterWorkerResponse>, Status> {
        let r = request.into_inner();
        if self.refuse || r.protocol_version != farm_proto::PROTOCOL_VERSION {
            return Err(Status::failed_precondition("protocol version 99 expected"));
        }
        Ok(Response::new(RegisterWorkerResponse {
            worker_id: 7,
            heartbeat_interval_ms: 50,
            session_key: vec![7; 32],
        }))
    }

    type WorkStream = Stream<CoordinatorMessage>;
    async fn work(
        &self,
        request: Request<Streaming<WorkerMessage>>,
    ) -> Result<Response<Self::WorkStream>, Status> {
        let mut inbound = request.into_inner();
        let (to_worker, rx) = mpsc::channel(64);
        let (tx, from_worker) = mpsc::channel(256);
        tokio::spawn(async move {
            while let Ok(Some(m)) = inbound.message().await {
                let _ = tx.send(m).await;
            }
        });
        let _ = self.sessions.send(FakeSession { to_worker, from_worker }).await;
        Ok(Response::new(ReceiverStream::new(rx)))
    }

    type FetchBlobStream = Stream<BlobChunk>;
    async fn fetch_blob(
        &self,
        request: Request<FetchBlobRequest>,
    ) -> Result<Response<Self::FetchBlobStream>, Status> {
        self.fetches.fetch_add(1, Ordering::SeqCst);
        let hash = request.into_inner().hash;
        let data = self.blobs.get(&hash).ok_or_else(|| Status::not_found("no such blob"))?;
        // Small chunks, to exercise reassembly.
        let (tx, rx) = mpsc::channel(data.len() / 7 + 2);
        for (i, piece) in data.chunks(7).enumerate() {
            let chunk = BlobChunk {
                hash: hash.clone(),
                total_size: data.len() as u64,
                offset: (i * 7) as u64,
                data: piece.to_vec(),
            };
            let _ = tx.try_send(Ok(chunk));
        }
        Ok(Response::new(ReceiverStream::new(rx)))
    }

    async fn upload_blob(
        &self,
        _: Request<Streaming<BlobChunk>>,
    ) -> Result<Response<UploadBlobResponse>, Status> {
        Err(Status::unimplemented("fake"))
    }

    async fn submit_job(
        &self,
        _: Request<SubmitJobRequest>,
    ) -> Result<Response<SubmitJobResponse>, Status> {
        Err(Status::unimplemented("fake"))
    }

    type WatchJobStream = Stream<JobEvent>;
    async fn watch_job(
        &self,
        _: Request<WatchJobRequest>,
    ) -> Result<Response<Self::WatchJobStream>, Status> {
        Err(Status::unimplemented("fake"))
    }

    async fn get_status(
        &self,
        _: Request<GetStatusRequest>,
    ) -> Result<Response<GetStatusResponse>, Status> {
        Err(Status::unimplemented("fake"))
    }

    async fn cancel_job(
        &self,
        _: Request<CancelJobRequest>,
    ) -> Result<Response<CancelJobResponse>, Status> {
        Err(Status::unimplemented("fake"))
    }
}
