//! Starting and stopping the service: [`Application::build`] opens the database, applies the
//! migrations and binds the listener; [`Application::run_until_stopped`] serves until the
//! shutdown future completes, then drains in-flight requests and closes the database.
//! Tests start the real application on port 0 the same way `nextpose serve` does.

use std::future::Future;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;

use anyhow::Context;
use axum::serve::ListenerExt;
use tokio::net::TcpListener;

use crate::app::App;
use crate::app::robots::Robots;
use crate::grpc;
use crate::http;
use crate::storage::{Durability, Store};
use crate::telemetry::Metrics;
use crate::transport::TransportOptions;
use crate::transport::auth::BearerToken;

/// Where the database lives: an SQLite file, in memory, or a PostgreSQL URL.
pub use crate::storage::Location as Database;

#[derive(Debug, Clone)]
pub struct ServerSettings {
    pub database: Database,
    pub durability: Durability,
    /// `HOST:PORT`; port 0 picks a free one.
    pub addr: String,
    pub http: TransportOptions,
    /// A directory of robot models (`*.urdf`, and a `catalog.json`) added to the bundled ones
    /// the binary carries, or overriding them by name; `None`: the bundled ones only.
    pub robots: Option<PathBuf>,
    /// Where `POST /v1/backups` writes; `None`: `backups/` beside the SQLite file.
    pub backup_dir: Option<PathBuf>,
}

impl Default for ServerSettings {
    fn default() -> Self {
        ServerSettings {
            database: Database::File(PathBuf::from("nextpose.db")),
            durability: Durability::default(),
            addr: "127.0.0.1:8080".into(),
            http: TransportOptions::default(),
            robots: None,
            backup_dir: None,
        }
    }
}

pub struct Application {
    listener: TcpListener,
    app: Arc<App>,
    router: axum::Router,
    /// Whether a bearer token is required (logged when serving starts).
    authenticated: bool,
}

impl Application {
    pub async fn build(settings: ServerSettings) -> anyhow::Result<Application> {
        // Before anything else: a token that is set but unusable is a start-up error.
        let token = BearerToken::from_setting(settings.http.token.as_deref())?;
        let authenticated = token.is_some();
        let store = Store::connect(&settings.database, settings.durability)
            .await
            .with_context(|| format!("opening database {}", settings.database.describe()))?;
        let robots =
            Robots::load(settings.robots.as_deref()).with_context(|| match &settings.robots {
                Some(dir) => format!("loading robot models from {}", dir.display()),
                None => "loading the bundled robot models".to_string(),
            })?;
        robots.add_stored(
            &store
                .robots()
                .await
                .context("reading the uploaded robot models")?,
        );
        let app = Arc::new(
            App::new(store, Arc::new(Metrics::new()), Arc::new(robots))
                .with_backup_dir(settings.backup_dir.clone()),
        );
        // REST and gRPC on one port: gRPC calls are told apart by their content type.
        let router = grpc::beside(
            http::router(app.clone(), &settings.http, token.clone()),
            grpc::router(app.clone(), &settings.http, token).await?,
        );
        let listener = TcpListener::bind(&settings.addr)
            .await
            .with_context(|| format!("binding {}", settings.addr))?;
        Ok(Application {
            listener,
            app,
            router,
            authenticated,
        })
    }

    pub fn local_addr(&self) -> std::io::Result<SocketAddr> {
        self.listener.local_addr()
    }

    pub fn app(&self) -> &Arc<App> {
        &self.app
    }

    /// Serves until `shutdown` completes, then lets in-flight requests finish.
    pub async fn run_until_stopped(
        self,
        shutdown: impl Future<Output = ()> + Send + 'static,
    ) -> std::io::Result<()> {
        // Logged here rather than in `build`, so that `nextpose serve`'s first line on stdout
        // stays the one that gives the address.
        if self.authenticated {
            tracing::info!("bearer-token authentication is on (every route but health checks)");
        } else {
            tracing::info!("bearer-token authentication is off (NEXTPOSE_TOKEN is unset)");
        }
        // TCP_NODELAY: a pipelined Teach stream writes many small HTTP/2 frames; with Nagle's
        // algorithm each batch waited for the client's delayed ACK (~40 ms).
        let listener = self.listener.tap_io(|tcp| {
            if let Err(e) = tcp.set_nodelay(true) {
                tracing::warn!(error = %e, "could not set TCP_NODELAY");
            }
        });
        let result = axum::serve(listener, self.router)
            .with_graceful_shutdown(shutdown)
            .await;
        // Operations whose callers went away run on; the database closes after them.
        self.app.finish_operations().await;
        self.app.store().close().await;
        result
    }
}

/// The application serving on a task of its own (tests, `nextpose simulate`'s local server),
/// until [`Running::stop`].
pub struct Running {
    addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    task: Option<tokio::task::JoinHandle<std::io::Result<()>>>,
}

impl Application {
    /// Serves on a task of the current runtime; [`Running::stop`] shuts it down gracefully.
    pub fn spawn(self) -> std::io::Result<Running> {
        let addr = self.local_addr()?;
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let task = tokio::spawn(self.run_until_stopped(async {
            let _ = stopped.await;
        }));
        Ok(Running {
            addr,
            stop: Some(stop),
            task: Some(task),
        })
    }
}

impl Running {
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// `http://HOST:PORT` of the server.
    pub fn base_url(&self) -> String {
        format!("http://{}", self.addr)
    }

    /// Stops serving (in-flight requests and operations finish) and closes the database; a
    /// second call does nothing.
    pub async fn stop(&mut self) -> anyhow::Result<()> {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(task) = self.task.take() {
            task.await.context("the server task")??;
        }
        Ok(())
    }
}

/// Completes on SIGINT (Ctrl-C) or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        if tokio::signal::ctrl_c().await.is_err() {
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
    tracing::info!("shutting down");
}
