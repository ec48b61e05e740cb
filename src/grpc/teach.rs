//! The `Teach` stream: a teaching session over one bidirectional stream, as the pendant
//! teaches (start a routine, a waypoint at a time with the prediction after each, undo,
//! finish), without a round trip's set-up per waypoint. Each command is applied by the same
//! application calls as the unary ones, and answered on the stream with its tag; an error
//! answers that command (a [`pb::TeachError`]) and the session goes on.

use std::sync::Arc;

use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tonic::{Code, Status, Streaming};

use crate::app::audit::Recorder;
use crate::app::{Action, App, AppError, Caller, Scope};

use super::convert;
use super::pb;
use super::pb::teach_request::Command;
use super::pb::teach_response::Event;
use super::status;

/// Responses a `Teach` session may have in flight before it stops reading commands: a client
/// that does not read its responses slows down to the server's pace (HTTP/2 flow control does
/// the rest).
pub const TEACH_BUFFER: usize = 16;

/// Runs a session on `inbound` commands in a task of its own; its responses.
pub(super) fn run(
    app: Arc<App>,
    caller: Caller,
    request_id: String,
    mut inbound: Streaming<pb::TeachRequest>,
) -> ReceiverStream<Result<pb::TeachResponse, Status>> {
    let (tx, rx) = mpsc::channel(TEACH_BUFFER);
    let counted = app.metrics().teach_session();
    // The session runs in its own task, so a command being applied always completes (the
    // application applies each one atomically); between commands the task stops as soon
    // as the client goes away.
    tokio::spawn(async move {
        let _counted = counted;
        let mut session = Session {
            app,
            caller,
            request_id,
            routine: None,
        };
        loop {
            let next = tokio::select! {
                m = inbound.message() => m,
                _ = tx.closed() => break,
            };
            let request = match next {
                Ok(Some(request)) => request,
                Ok(None) => break,
                Err(e) => {
                    // The client went away, or sent what cannot be read (a message over
                    // the size limit, OUT_OF_RANGE): the stream ends with that status.
                    tracing::debug!(status = %e, "teach stream ended by the client");
                    let _ = tx.send(Err(e)).await;
                    break;
                }
            };
            let event = session.apply(request.command).await;
            let response = pb::TeachResponse {
                tag: request.tag,
                event: Some(event),
            };
            // Waits while the client is TEACH_BUFFER responses behind (back-pressure).
            if tx.send(Ok(response)).await.is_err() {
                break;
            }
        }
    });
    ReceiverStream::new(rx)
}

/// One `Teach` stream: who teaches, and which routine its commands apply to (one the caller
/// may teach: `start` asks).
struct Session {
    app: Arc<App>,
    caller: Caller,
    /// The stream's request id, which each command's audit entry carries.
    request_id: String,
    routine: Option<i64>,
}

/// An application error as the stream answers a command: its gRPC code, reason and message,
/// as a unary call would have failed.
fn app_error(e: AppError) -> pb::TeachError {
    pb::TeachError {
        code: status::code(&e) as i32,
        reason: e.code().to_string(),
        message: status::message(&e),
    }
}

/// A command the adapter refuses before the application sees it (unreadable, or no routine
/// started).
fn adapter_error(s: Status) -> pb::TeachError {
    let reason = match s.code() {
        Code::InvalidArgument => "invalid",
        Code::FailedPrecondition => "no_routine",
        _ => "bad_request",
    };
    pb::TeachError {
        code: s.code() as i32,
        reason: reason.to_string(),
        message: s.message().to_string(),
    }
}

impl Session {
    fn routine(&self) -> Result<i64, pb::TeachError> {
        self.routine.ok_or_else(|| {
            adapter_error(Status::failed_precondition(
                "no routine selected; send `start` first",
            ))
        })
    }

    /// Applies a command, recorded in the audit trail as an operation of its own
    /// (`…/Teach waypoint`) when it changes something.
    async fn apply(&mut self, command: Option<Command>) -> Event {
        let kind = match &command {
            None => "none",
            Some(Command::Start(_)) => "start",
            Some(Command::Waypoint(_)) => "waypoint",
            Some(Command::Undo(_)) => "undo",
            Some(Command::Finish(_)) => "finish",
        };
        let recorder = Recorder::new(
            &self.caller.name,
            &self.request_id,
            &format!("/nextpose.v1.Nextpose/Teach {kind}"),
        );
        let routine = match &command {
            Some(Command::Start(s)) => Some(s.routine_id),
            _ => self.routine,
        };
        if let Some(id) = routine {
            recorder.name_target(format!("routine {id}"));
        }
        let app = self.app.clone();
        let event = recorder
            .clone()
            .scope(self.try_apply(command))
            .await
            .unwrap_or_else(Event::Error);
        if let Event::Error(e) = &event {
            let code = super::code_name(Code::from(e.code));
            app.audit_answer(&recorder, false, &code).await;
        }
        event
    }

    async fn try_apply(&mut self, command: Option<Command>) -> Result<Event, pb::TeachError> {
        let app = &self.app;
        match command {
            None => Err(adapter_error(Status::invalid_argument(
                "a command (start, waypoint, undo or finish) is required",
            ))),
            Some(Command::Start(s)) => {
                app.authorize(&self.caller, Action::Teach, Scope::Routine(s.routine_id))
                    .await
                    .map_err(app_error)?;
                let detail = app.resume_routine(s.routine_id).await.map_err(app_error)?;
                self.routine = Some(s.routine_id);
                Ok(Event::Started(pb::Started {
                    routine: Some(detail.routine.into()),
                }))
            }
            Some(Command::Waypoint(w)) => {
                let id = self.routine()?;
                let input = convert::new_waypoint(w).map_err(adapter_error)?;
                let taught = app.append_waypoint(id, input).await.map_err(app_error)?;
                Ok(Event::Taught(taught.into()))
            }
            Some(Command::Undo(_)) => {
                let id = self.routine()?;
                let undone = app.undo(id).await.map_err(app_error)?;
                Ok(Event::Undone(undone.into()))
            }
            Some(Command::Finish(_)) => {
                let id = self.routine()?;
                let finished = app.finish_routine(id).await.map_err(app_error)?;
                self.routine = None;
                Ok(Event::Finished(finished.into()))
            }
        }
    }
}
