//! A `Teach` session driven command by command, at the level of the wire: each command is sent
//! with its tag and one event read back, and a test can also send without reading, or read the
//! stream's end. (`nextpose::client::TeachStream` does the lock-step part too, but answers with
//! API types and turns error events into errors, which is what these tests look at.)

use nextpose::grpc::pb;
use nextpose::grpc::pb::teach_request::Command;
use nextpose::grpc::pb::teach_response::Event;
use serde_json::Value;
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::Streaming;

use super::client::{Client, waypoint};

/// An open teach session: commands go in, one event comes back per command.
pub(super) struct Teach {
    pub(super) tx: mpsc::Sender<pb::TeachRequest>,
    pub(super) rx: Streaming<pb::TeachResponse>,
    tag: u64,
}

impl Teach {
    pub(super) async fn open(c: &mut Client) -> Teach {
        let (tx, rx) = mpsc::channel(16);
        let stream = c
            .teach(ReceiverStream::new(rx))
            .await
            .expect("teach")
            .into_inner();
        Teach {
            tx,
            rx: stream,
            tag: 0,
        }
    }

    pub(super) async fn send(&mut self, command: Command) -> u64 {
        self.tag += 1;
        self.tx
            .send(pb::TeachRequest {
                tag: self.tag,
                command: Some(command),
            })
            .await
            .expect("send");
        self.tag
    }

    pub(super) async fn next(&mut self) -> (u64, Event) {
        let r = self
            .rx
            .message()
            .await
            .expect("stream ok")
            .expect("an event");
        (r.tag, r.event.expect("event set"))
    }

    pub(super) async fn call(&mut self, command: Command) -> Event {
        let tag = self.send(command).await;
        let (got, event) = self.next().await;
        assert_eq!(got, tag);
        event
    }

    pub(super) async fn start(&mut self, routine_id: i64) -> pb::Routine {
        match self
            .call(Command::Start(pb::StartCommand { routine_id }))
            .await
        {
            Event::Started(s) => s.routine.expect("routine"),
            other => panic!("expected started, got {other:?}"),
        }
    }

    pub(super) async fn waypoint(&mut self, pose: &Value) -> pb::Taught {
        match self.call(Command::Waypoint(waypoint(pose))).await {
            Event::Taught(t) => t,
            other => panic!("expected taught, got {other:?}"),
        }
    }

    pub(super) async fn finish(&mut self) -> pb::Finished {
        match self.call(Command::Finish(pb::FinishCommand {})).await {
            Event::Finished(f) => f,
            other => panic!("expected finished, got {other:?}"),
        }
    }
}
