//! Connecting the generated client to the test server, and the messages the tests send built
//! from the JSON poses and uploads the REST tests use.

use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use serde_json::Value;
use tonic::transport::Channel;

use crate::helpers::TestApp;

pub(super) type Client = NextposeClient<Channel>;

pub(crate) async fn channel(app: &TestApp) -> Channel {
    Channel::from_shared(app.base.clone())
        .expect("uri")
        .connect()
        .await
        .expect("connect")
}

pub(crate) async fn client(app: &TestApp) -> Client {
    NextposeClient::new(channel(app).await)
}

pub(crate) fn pb_pose(v: &Value) -> pb::Pose {
    let f = |k: &str| v[k].as_f64().expect(k);
    pb::Pose {
        x: f("x"),
        y: f("y"),
        z: f("z"),
        qw: f("qw"),
        qx: f("qx"),
        qy: f("qy"),
        qz: f("qz"),
    }
}

pub(super) fn waypoint(v: &Value) -> pb::NewWaypoint {
    pb::NewWaypoint {
        pose: Some(pb_pose(v)),
        ..Default::default()
    }
}

/// A cell offering predictions its arm cannot reach, flagged (as `TestApp::create_cell`).
pub(super) async fn create_cell(c: &mut Client, name: &str) -> pb::Cell {
    c.create_cell(pb::CreateCellRequest {
        name: name.into(),
        settings: Some(pb::CellSettingsInput {
            reach_policy: pb::ReachPolicy::Flag.into(),
            ..Default::default()
        }),
    })
    .await
    .expect("create cell")
    .into_inner()
}

pub(super) fn pb_files(files: &[Value]) -> Vec<pb::UploadedFile> {
    files
        .iter()
        .map(|f| pb::UploadedFile {
            name: f["name"].as_str().expect("name").into(),
            content: f["content"].as_str().expect("content").into(),
        })
        .collect()
}
