//! What every call goes through: the bearer token (and health checks without it), reflection
//! beside REST on one port, and the metrics and request ids of calls and streams.

use nextpose::grpc::pb;
use nextpose::grpc::pb::nextpose_client::NextposeClient;
use nextpose::transport::TransportOptions;
use reqwest::StatusCode;
use tonic::Code;

use super::client::{channel, client};
use super::session::Teach;
use crate::helpers::*;

#[tokio::test]
async fn the_bearer_token_applies_to_grpc_metadata() {
    let app = spawn_with(TransportOptions {
        token: Some("s3cret".into()),
        ..TransportOptions::default()
    })
    .await;
    let ch = channel(&app).await;

    let mut anonymous = NextposeClient::new(ch.clone());
    let e = anonymous
        .list_cells(pb::ListCellsRequest {})
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::Unauthenticated, "{e:?}");
    let e = anonymous
        .teach(tokio_stream::empty())
        .await
        .map(|_| ())
        .unwrap_err();
    assert_eq!(e.code(), Code::Unauthenticated);

    let mut wrong = NextposeClient::with_interceptor(ch.clone(), |mut r: tonic::Request<()>| {
        r.metadata_mut()
            .insert("authorization", "Bearer nope".parse().unwrap());
        Ok(r)
    });
    let e = wrong.list_cells(pb::ListCellsRequest {}).await.unwrap_err();
    assert_eq!(e.code(), Code::Unauthenticated);

    let mut authorised =
        NextposeClient::with_interceptor(ch.clone(), |mut r: tonic::Request<()>| {
            r.metadata_mut()
                .insert("authorization", "Bearer s3cret".parse().unwrap());
            Ok(r)
        });
    let cells = authorised
        .list_cells(pb::ListCellsRequest {})
        .await
        .unwrap()
        .into_inner();
    assert!(cells.cells.is_empty());
    // The scheme is case-insensitive (RFC 7235), as over REST.
    for scheme in ["bearer", "BEARER"] {
        let value: tonic::metadata::MetadataValue<_> = format!("{scheme} s3cret").parse().unwrap();
        let mut c =
            NextposeClient::with_interceptor(ch.clone(), move |mut r: tonic::Request<()>| {
                r.metadata_mut().insert("authorization", value.clone());
                Ok(r)
            });
        c.list_cells(pb::ListCellsRequest {})
            .await
            .unwrap_or_else(|e| panic!("{scheme}: {e:?}"));
    }

    // Health checks need no token, like /healthz.
    let mut health = tonic_health::pb::health_client::HealthClient::new(ch);
    let status = health
        .check(tonic_health::pb::HealthCheckRequest {
            service: "nextpose.v1.Nextpose".into(),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(
        status.status(),
        tonic_health::pb::health_check_response::ServingStatus::Serving
    );

    // REST is unchanged: JSON errors without the token.
    let mut rest = TestApp::remote(&app.base);
    rest.token = None;
    expect_error(
        rest.get("/v1/cells").await,
        StatusCode::UNAUTHORIZED,
        "unauthorized",
    )
    .await;
}

#[tokio::test]
async fn reflection_lists_the_service() {
    use tonic_reflection::pb::v1::ServerReflectionRequest;
    use tonic_reflection::pb::v1::server_reflection_client::ServerReflectionClient;
    use tonic_reflection::pb::v1::server_reflection_request::MessageRequest;
    use tonic_reflection::pb::v1::server_reflection_response::MessageResponse;

    let app = spawn_app().await;
    let mut c = ServerReflectionClient::new(channel(&app).await);
    let request = ServerReflectionRequest {
        host: String::new(),
        message_request: Some(MessageRequest::ListServices(String::new())),
    };
    let mut stream = c
        .server_reflection_info(tokio_stream::iter([request]))
        .await
        .unwrap()
        .into_inner();
    let response = stream.message().await.unwrap().unwrap();
    let Some(MessageResponse::ListServicesResponse(list)) = response.message_response else {
        panic!("unexpected {response:?}");
    };
    let names: Vec<_> = list.service.iter().map(|s| s.name.as_str()).collect();
    assert!(names.contains(&"nextpose.v1.Nextpose"), "{names:?}");
    // The health service is described too (grpcurl calls it by reflection).
    assert!(names.contains(&"grpc.health.v1.Health"), "{names:?}");

    // A plain REST request on the same port still gets REST.
    let health = app.get_ok("/healthz").await;
    assert_eq!(health["status"], "ok");
}

#[tokio::test]
async fn grpc_calls_are_counted_in_metrics_and_carry_request_ids() {
    let app = spawn_app().await;
    let mut c = client(&app).await;

    // A call that succeeds, one that fails, a Teach stream closed by the client, and a call
    // to a method that does not exist.
    let response = c
        .create_cell(pb::CreateCellRequest {
            name: "counted".into(),
            settings: None,
        })
        .await
        .unwrap();
    let id = response
        .metadata()
        .get("x-request-id")
        .expect("a request id");
    assert!(!id.is_empty());
    let cell = response.into_inner();
    let mut request = tonic::Request::new(pb::GetCellRequest { cell_id: 999 });
    request
        .metadata_mut()
        .insert("x-request-id", "pendant-42".parse().unwrap());
    let e = c.get_cell(request).await.unwrap_err();
    assert_eq!(e.code(), Code::NotFound);
    assert_eq!(e.metadata().get("x-request-id").unwrap(), "pendant-42");
    c.get_cell(pb::GetCellRequest { cell_id: cell.id })
        .await
        .unwrap();

    let program = app.create_program(cell.id, "p").await;
    let routine = app.create_routine(program).await;
    let mut session = Teach::open(&mut c).await;
    session.start(routine).await;
    let Teach { tx, mut rx, .. } = session;
    drop(tx);
    // The server ends the stream with its status once the client's side is closed.
    assert!(rx.message().await.unwrap().is_none());

    let mut raw = tonic::client::Grpc::new(channel(&app).await);
    raw.ready().await.unwrap();
    let e = raw
        .unary::<_, pb::ListCellsResponse, _>(
            tonic::Request::new(pb::ListCellsRequest {}),
            "/nextpose.v1.Nextpose/NoSuchMethod".parse().unwrap(),
            tonic_prost::ProstCodec::default(),
        )
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::Unimplemented);

    let metrics = app.client.get(app.url("/metrics")).send().await.unwrap();
    let metrics = metrics.text().await.unwrap();
    let calls = |method: &str, code: &str| {
        sample(
            &metrics,
            &format!(
                "nextpose_grpc_requests_total{{service=\"nextpose.v1.Nextpose\",method=\"{method}\",code=\"{code}\"}}"
            ),
        )
    };
    assert_eq!(calls("CreateCell", "OK"), Some(1.0), "{metrics}");
    assert_eq!(calls("GetCell", "NOT_FOUND"), Some(1.0), "{metrics}");
    assert_eq!(calls("GetCell", "OK"), Some(1.0), "{metrics}");
    assert_eq!(calls("Teach", "OK"), Some(1.0), "{metrics}");
    assert_eq!(
        sample(
            &metrics,
            "nextpose_grpc_request_duration_seconds_count{service=\"nextpose.v1.Nextpose\",method=\"GetCell\"}"
        ),
        Some(2.0),
        "{metrics}"
    );
    assert_eq!(
        sample(
            &metrics,
            "nextpose_grpc_requests_total{service=\"unknown\",method=\"unknown\",code=\"UNIMPLEMENTED\"}"
        ),
        Some(1.0),
        "{metrics}"
    );
    assert!(!metrics.contains("NoSuchMethod"), "{metrics}");
    // The REST requests of this test are counted as before.
    assert!(
        metrics.contains("nextpose_http_requests_total{method=\"POST\",route=\"/v1/cells/{cell_id}/programs\",status=\"201\"} 1"),
        "{metrics}"
    );
}
