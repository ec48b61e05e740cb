//! The generated messages, client and server of `proto/nextpose/v1/nextpose.proto`.

#![allow(clippy::all, clippy::pedantic, missing_docs)]

tonic::include_proto!("nextpose.v1");
