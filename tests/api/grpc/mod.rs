//! The gRPC adapter through a real tonic client against the real server on its loopback port
//! (the same port as REST), by concern: unary calls for every resource (`unary`), `Teach`
//! sessions (`teach`: the same predictions as the REST loop, cancellation), import and replay
//! (`import`, `replay`: the same results as REST), backups (`backup`), error mapping and limits
//! (`errors`), and what every call goes through: token, health, reflection, metrics and request
//! ids (`transport`).
//!
//! The tests drive the generated client (`pb`), not `nextpose::client`: they assert what goes
//! over the wire (status codes and their metadata, the tags and error events of a `Teach`
//! stream, commands left unanswered, how a stream ends), which the crate's client turns into API
//! types and `ClientError`s. `client` has the connection and the message builders, `session` a
//! `Teach` stream driven command by command.

mod backup;
pub(crate) mod client;
mod errors;
mod import;
mod replay;
mod roles;
mod session;
mod settings;
mod teach;
mod transport;
mod unary;
