//! Prometheus metrics: requests and their latency per route (REST) or per call (gRPC), recorded
//! by the adapters, and predictions offered or withheld by reason (recorded by the
//! application, so they count whichever adapter asked).

use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{Histogram, exponential_buckets};
use prometheus_client::registry::Registry;

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct RequestLabels {
    pub method: String,
    /// The route template (`/v1/routines/{routine_id}/waypoints`), not the raw path.
    pub route: String,
    pub status: u16,
}

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct RouteLabels {
    pub method: String,
    pub route: String,
}

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct GrpcLabels {
    /// `nextpose.v1.Nextpose`, `grpc.health.v1.Health`, … (`unknown` for calls answered
    /// `UNIMPLEMENTED`, so made-up names do not become label values).
    pub service: String,
    /// `CreateCell`, `Teach`, …
    pub method: String,
}

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct GrpcCodeLabels {
    pub service: String,
    pub method: String,
    /// The status code's canonical name: `OK`, `NOT_FOUND`, `INVALID_ARGUMENT`, …
    pub code: String,
}

#[derive(Debug, Clone, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct PredictionLabels {
    /// `offered` or `withheld`.
    pub outcome: String,
    /// The withheld reason (`none` when offered).
    pub reason: String,
}

fn latency_histogram() -> Histogram {
    // 50 µs … ~1.6 s
    Histogram::new(exponential_buckets(0.000_05, 2.0, 16))
}

/// The service's metrics registry.
#[derive(Debug)]
pub struct Metrics {
    registry: Registry,
    requests: Family<RequestLabels, Counter>,
    latency: Family<RouteLabels, Histogram, fn() -> Histogram>,
    grpc_calls: Family<GrpcCodeLabels, Counter>,
    grpc_latency: Family<GrpcLabels, Histogram, fn() -> Histogram>,
    predictions: Family<PredictionLabels, Counter>,
    teach_sessions: Gauge,
    divergences: Counter,
}

impl Default for Metrics {
    fn default() -> Self {
        Metrics::new()
    }
}

impl Metrics {
    pub fn new() -> Metrics {
        let mut registry = Registry::with_prefix("nextpose");
        let requests = Family::<RequestLabels, Counter>::default();
        let latency = Family::<RouteLabels, Histogram, fn() -> Histogram>::new_with_constructor(
            latency_histogram,
        );
        let grpc_calls = Family::<GrpcCodeLabels, Counter>::default();
        let grpc_latency = Family::<GrpcLabels, Histogram, fn() -> Histogram>::new_with_constructor(
            latency_histogram,
        );
        let predictions = Family::<PredictionLabels, Counter>::default();
        let teach_sessions = Gauge::default();
        let divergences = Counter::default();
        registry.register(
            "http_requests",
            "HTTP requests by method, route and status",
            requests.clone(),
        );
        registry.register(
            "http_request_duration_seconds",
            "HTTP request latency by method and route",
            latency.clone(),
        );
        registry.register(
            "grpc_requests",
            "gRPC calls by service, method and status code",
            grpc_calls.clone(),
        );
        registry.register(
            "grpc_request_duration_seconds",
            "gRPC call latency by service and method (a stream: its whole life)",
            grpc_latency.clone(),
        );
        registry.register(
            "predictions",
            "Predictions made, offered or withheld by reason",
            predictions.clone(),
        );
        registry.register(
            "grpc_teach_sessions",
            "gRPC Teach sessions whose commands are still being applied",
            teach_sessions.clone(),
        );
        registry.register(
            "model_divergences",
            "Rebuilds that found a cell's model in memory different from the one rebuilt from \
             the database (a bug: it should stay 0)",
            divergences.clone(),
        );
        Metrics {
            registry,
            requests,
            latency,
            grpc_calls,
            grpc_latency,
            predictions,
            teach_sessions,
            divergences,
        }
    }

    /// A rebuild found the model in memory out of step with the database.
    pub fn record_divergence(&self) {
        self.divergences.inc();
    }

    /// A Teach session starts applying commands; it counts until the returned guard is dropped
    /// (when its task has applied its last command).
    pub fn teach_session(&self) -> TeachSession {
        self.teach_sessions.inc();
        TeachSession(self.teach_sessions.clone())
    }

    pub fn record_request(&self, method: &str, route: &str, status: u16, seconds: f64) {
        self.requests
            .get_or_create(&RequestLabels {
                method: method.to_string(),
                route: route.to_string(),
                status,
            })
            .inc();
        self.latency
            .get_or_create(&RouteLabels {
                method: method.to_string(),
                route: route.to_string(),
            })
            .observe(seconds);
    }

    /// Counts a finished gRPC call (`code`: the status code's name) and observes its latency.
    pub fn record_grpc(&self, service: &str, method: &str, code: &str, seconds: f64) {
        self.grpc_calls
            .get_or_create(&GrpcCodeLabels {
                service: service.to_string(),
                method: method.to_string(),
                code: code.to_string(),
            })
            .inc();
        self.grpc_latency
            .get_or_create(&GrpcLabels {
                service: service.to_string(),
                method: method.to_string(),
            })
            .observe(seconds);
    }

    /// Counts a prediction: `reason` is None when it was offered.
    pub fn record_prediction(&self, reason: Option<&str>) {
        let labels = match reason {
            None => PredictionLabels {
                outcome: "offered".into(),
                reason: "none".into(),
            },
            Some(r) => PredictionLabels {
                outcome: "withheld".into(),
                reason: r.to_string(),
            },
        };
        self.predictions.get_or_create(&labels).inc();
    }

    /// The OpenMetrics text exposition.
    pub fn encode(&self) -> String {
        let mut out = String::new();
        // Writing into a String cannot fail.
        let _ = prometheus_client::encoding::text::encode(&mut out, &self.registry);
        out
    }
}

/// Counts one Teach session in `nextpose_grpc_teach_sessions` while it lives.
#[derive(Debug)]
pub struct TeachSession(Gauge);

impl Drop for TeachSession {
    fn drop(&mut self) {
        self.0.dec();
    }
}
