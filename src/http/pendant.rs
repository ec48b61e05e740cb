//! The reference teach pendant: a page of plain ES modules and CSS (`src/http/pendant/`, with
//! three.js vendored under `vendor/three/` by `scripts/refresh-three.sh`) embedded in the
//! binary and served at `/` and `/pendant/…`. It calls only the public REST API. A debug build
//! reads the directory from disk (edits show on reload); a release build carries the files.
//!
//! Served without the bearer token (the page asks for it and sends it on its API calls), with
//! a strict Content-Security-Policy (same origin only, no inline script or style), `nosniff`,
//! no referrer, no framing, and an ETag so a reload revalidates instead of downloading again.

use axum::Router;
use axum::extract::Path;
use axum::http::{HeaderMap, HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use rust_embed::RustEmbed;

use super::error::for_status;

#[derive(RustEmbed)]
#[folder = "src/http/pendant/"]
struct Assets;

/// Where the page's files are served from.
pub const PREFIX: &str = "/pendant/";

/// The policy: everything from this origin, nothing inline, no plugins, no framing.
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'self'; script-src 'self'; \
     style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; object-src 'none'; \
     base-uri 'none'; frame-ancestors 'none'; form-action 'self'";

/// Whether a request path is the page's (served without the token).
pub fn is_page(path: &str) -> bool {
    path == "/" || path.starts_with(PREFIX)
}

pub fn router<S: Clone + Send + Sync + 'static>() -> Router<S> {
    Router::new()
        .route("/", get(index))
        .route("/pendant/{*path}", get(asset))
}

async fn index(headers: HeaderMap) -> Response {
    serve("index.html", &headers)
}

async fn asset(Path(path): Path<String>, headers: HeaderMap) -> Response {
    serve(&path, &headers)
}

fn content_type(path: &str) -> &'static str {
    match path.rsplit_once('.').map(|(_, ext)| ext) {
        Some("html") => "text/html; charset=utf-8",
        Some("js") => "text/javascript; charset=utf-8",
        Some("css") => "text/css; charset=utf-8",
        Some("svg") => "image/svg+xml",
        Some("png") => "image/png",
        Some("json") => "application/json",
        _ => "text/plain; charset=utf-8",
    }
}

fn serve(path: &str, request: &HeaderMap) -> Response {
    // Only names inside the folder (a debug build reads it from disk).
    let inside = path
        .split(['/', '\\'])
        .all(|segment| !segment.is_empty() && segment != "." && segment != "..");
    let Some(file) = inside.then(|| Assets::get(path)).flatten() else {
        return for_status(StatusCode::NOT_FOUND).into_response();
    };
    let etag: String = file
        .metadata
        .sha256_hash()
        .iter()
        .take(16)
        .map(|b| format!("{b:02x}"))
        .collect();
    let etag = format!("\"{etag}\"");
    let fresh = request
        .get(header::IF_NONE_MATCH)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.split(',').any(|t| t.trim() == etag));
    // The vendored library changes only with its version: a day; the page's own files are
    // revalidated on every load (a 304 when unchanged).
    let cache = if path.starts_with("vendor/") {
        "public, max-age=86400"
    } else {
        "no-cache"
    };
    let mut response = if fresh {
        StatusCode::NOT_MODIFIED.into_response()
    } else {
        (StatusCode::OK, file.data.into_owned()).into_response()
    };
    let h = response.headers_mut();
    h.insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static(content_type(path)),
    );
    if let Ok(v) = HeaderValue::from_str(&etag) {
        h.insert(header::ETAG, v);
    }
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static(cache));
    h.insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(CONTENT_SECURITY_POLICY),
    );
    h.insert(
        header::X_CONTENT_TYPE_OPTIONS,
        HeaderValue::from_static("nosniff"),
    );
    h.insert(
        header::REFERRER_POLICY,
        HeaderValue::from_static("no-referrer"),
    );
    h.insert(header::X_FRAME_OPTIONS, HeaderValue::from_static("DENY"));
    response
}
