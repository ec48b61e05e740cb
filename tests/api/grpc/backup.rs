//! `CreateBackup`: the call beside `POST /v1/backups`, with the same refusals as gRPC codes
//! (and the REST code in `x-error-code`).

use nextpose::grpc::pb;
use tonic::Code;

use super::client::client;
use crate::helpers::*;

#[tokio::test]
async fn create_backup_writes_a_backup_or_says_why_not() {
    let dir = tempfile::tempdir().unwrap();
    let app = spawn_on(test_database(dir.path()).await).await;
    let mut c = client(&app).await;
    let backup = |name: Option<&str>| pb::CreateBackupRequest {
        name: name.map(String::from),
    };
    if on_postgres() {
        let e = c.create_backup(backup(None)).await.unwrap_err();
        assert_eq!(e.code(), Code::FailedPrecondition, "{e:?}");
        assert_eq!(
            e.metadata().get("x-error-code").unwrap(),
            "backup_unsupported"
        );
        assert!(e.message().contains("pg_dump"), "{e:?}");
        return;
    }
    let written = c
        .create_backup(backup(Some("grpc.db")))
        .await
        .unwrap()
        .into_inner();
    let path = dir.path().join("backups/grpc.db");
    assert_eq!(written.name, "grpc.db");
    assert_eq!(written.path, path.display().to_string());
    assert_eq!(written.bytes, std::fs::metadata(&path).unwrap().len());
    let auto = c.create_backup(backup(None)).await.unwrap().into_inner();
    assert!(auto.name.starts_with("nextpose-"), "{auto:?}");

    let e = c.create_backup(backup(Some("grpc.db"))).await.unwrap_err();
    assert_eq!(e.code(), Code::AlreadyExists, "{e:?}");
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "conflict");
    let e = c
        .create_backup(backup(Some("../grpc.db")))
        .await
        .unwrap_err();
    assert_eq!(e.code(), Code::InvalidArgument, "{e:?}");
    assert_eq!(e.metadata().get("x-error-code").unwrap(), "invalid");
    assert!(!dir.path().join("grpc.db").exists());
}
