//! A worker driven by hand over gRPC, to send what no honest worker would.

use farm_proto::v1::{self, coordinator_client::CoordinatorClient, worker_message};
use farm_proto::PROTOCOL_VERSION;
use tokio::sync::mpsc;
use tokio_stream::wrappers::UnboundedReceiverStream;

/// A registered worker with its Work stream open.
pub struct FakeWorker {
    /// Its id.
    pub id: u64,
    /// The secret its session was opened with.
    pub session_key: Vec<u8>,
    /// Messages to the coordinator.
    pub tx: mpsc::UnboundedSender<v1::WorkerMessage>,
    /// Messages from the coordinator.
    pub inbound: tonic::Streaming<v1::CoordinatorMessage>,
    /// Its connection, for more calls.
    pub client: CoordinatorClient<tonic::transport::Channel>,
}

impl FakeWorker {
    /// Registers at `url` and opens the Work stream asking for `max_in_flight` tiles.
    pub async fn connect(url: &str, max_in_flight: u32) -> FakeWorker {
        let mut client = CoordinatorClient::connect(url.to_string()).await.expect("connect");
        let reg = v1::RegisterWorkerRequest {
            protocol_version: PROTOCOL_VERSION,
            name: "fake".into(),
            threads: 1,
        };
        let reply = client.register_worker(reg).await.expect("register").into_inner();
        let (tx, inbound) =
            open_session(&mut client, reply.worker_id, &reply.session_key, max_in_flight)
                .await
                .expect("work stream");
        FakeWorker { id: reply.worker_id, session_key: reply.session_key, tx, inbound, client }
    }

    /// The next assignment, skipping other messages.
    pub async fn assignment(&mut self) -> v1::TileAssignment {
        loop {
            let msg = self.inbound.message().await.expect("stream").expect("a message");
            if let Some(v1::coordinator_message::Kind::Assign(a)) = msg.kind {
                return a;
            }
        }
    }

    /// Sends a result.
    pub fn send(&self, result: v1::TileResult) {
        let msg = v1::WorkerMessage { kind: Some(worker_message::Kind::Result(result)) };
        self.tx.send(msg).expect("send");
    }
}

/// Opens a Work stream for worker `id` presenting `key`.
pub async fn open_session(
    client: &mut CoordinatorClient<tonic::transport::Channel>,
    id: u64,
    key: &[u8],
    max_in_flight: u32,
) -> Result<
    (mpsc::UnboundedSender<v1::WorkerMessage>, tonic::Streaming<v1::CoordinatorMessage>),
    tonic::Status,
> {
    let (tx, rx) = mpsc::unbounded_channel();
    let hello = v1::Hello { worker_id: id, max_in_flight, session_key: key.to_vec() };
    tx.send(v1::WorkerMessage { kind: Some(worker_message::Kind::Hello(hello)) }).expect("hello");
    let inbound = client.work(UnboundedReceiverStream::new(rx)).await?.into_inner();
    Ok((tx, inbound))
}
