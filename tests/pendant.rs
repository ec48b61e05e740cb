//! The web pendant in a real browser (issue 16): headless Chromium, driven over WebDriver
//! (chromedriver + fantoccini), against the real server on a loopback port with a token.
//!
//! A person's session: enter the token, create a cell, a program and a routine on the page;
//! teach a routine by jogging and recording; finish it; start a second copy elsewhere and see
//! the suggestion drawn as a ghost of the arm; accept it, undo, reject one; start a copy at the
//! edge of the arm's reach and see the suggestion flagged unreachable with its reason. The
//! page's state is asserted through the DOM, the server's through its REST API (stored
//! waypoints, feedback counts). With tokens of each role (issue 31) the page shows who is signed
//! in and turns off what the role may not do. Screenshots go to `$CARGO_TARGET_TMPDIR/pendant/`, with the
//! Record → suggestion latencies the page measured (`latency.json`, reported in docs/results/performance.md, not
//! asserted). Any console error fails the test.
//!
//! Needs Debian's `chromium` and `chromium-driver` (`scripts/test.sh` installs them when
//! missing); `NEXTPOSE_CHROMIUM` and `NEXTPOSE_CHROMEDRIVER` point elsewhere.

use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use fantoccini::wd::WebDriverCompatibleCommand;
use fantoccini::{Client, ClientBuilder, Locator};
use nextpose::server::{Application, Database, Running, ServerSettings};
use nextpose::storage::Durability;
use nextpose::transport::TransportOptions;
use serde_json::{Value, json};

const TOKEN: &str = "pendant-test-token";
/// Longest wait for the page to show something (generous: a loaded 2-core machine).
const PATIENCE: Duration = Duration::from_secs(30);
/// How many times an element the page replaced between finding and using it is found again.
const STALE_RETRIES: usize = 5;

fn binary(var: &str, default: &str) -> PathBuf {
    let path = std::env::var_os(var)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(default));
    assert!(
        path.exists(),
        "{} is missing: install Debian's chromium and chromium-driver \
         (`scripts/test.sh` does, or set {var})",
        path.display()
    );
    path
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// chromedriver, stopped when dropped.
struct Driver {
    child: Child,
    url: String,
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

async fn start_driver() -> Driver {
    let port = free_port();
    let child = Command::new(binary("NEXTPOSE_CHROMEDRIVER", "/usr/bin/chromedriver"))
        .arg(format!("--port={port}"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start chromedriver");
    let driver = Driver {
        child,
        url: format!("http://127.0.0.1:{port}"),
    };
    // Ready when its status says so.
    let http = reqwest::Client::new();
    for _ in 0..200 {
        if let Ok(r) = http.get(format!("{}/status", driver.url)).send().await
            && let Ok(v) = r.json::<Value>().await
            && v["value"]["ready"] == true
        {
            return driver;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    panic!("chromedriver did not become ready");
}

async fn start_server(dir: &tempfile::TempDir) -> Running {
    let settings = ServerSettings {
        database: Database::File(dir.path().join("nextpose.db")),
        durability: Durability::Process,
        addr: "127.0.0.1:0".into(),
        http: TransportOptions {
            token: Some(TOKEN.into()),
            ..TransportOptions::default()
        },
        robots: None,
        backup_dir: None,
    };
    Application::build(settings)
        .await
        .expect("build")
        .spawn()
        .expect("addr")
}

async fn browser(driver: &Driver, profile: &tempfile::TempDir) -> Client {
    let chromium = binary("NEXTPOSE_CHROMIUM", "/usr/bin/chromium");
    let mut caps = serde_json::Map::new();
    caps.insert(
        "goog:chromeOptions".into(),
        json!({
            "binary": chromium,
            "args": [
                "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--disable-dev-shm-usage",
                "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                "--window-size=1280,800",
                format!("--user-data-dir={}", profile.path().display()),
            ],
        }),
    );
    caps.insert("goog:loggingPrefs".into(), json!({ "browser": "ALL" }));
    ClientBuilder::new(hyper_util::client::legacy::connect::HttpConnector::new())
        .capabilities(caps)
        .connect(&driver.url)
        .await
        .expect("a WebDriver session")
}

/// chromedriver's console log of the page (`POST /session/{id}/se/log`): every entry since
/// the last call.
#[derive(Debug)]
struct BrowserLog;

impl WebDriverCompatibleCommand for BrowserLog {
    fn endpoint(
        &self,
        base: &url::Url,
        session: Option<&str>,
    ) -> Result<url::Url, url::ParseError> {
        base.join(&format!("session/{}/se/log", session.unwrap_or_default()))
    }

    fn method_and_body(&self, _: &url::Url) -> (http::Method, Option<String>) {
        (
            http::Method::POST,
            Some(json!({ "type": "browser" }).to_string()),
        )
    }
}

/// The test's view of the page.
struct Page {
    c: Client,
    /// Console entries read so far.
    console: Vec<Value>,
    shots: PathBuf,
}

impl Page {
    async fn read_console(&mut self) {
        let log = self.c.issue_cmd(BrowserLog).await.expect("browser log");
        if let Value::Array(entries) = log {
            self.console.extend(entries);
        }
    }

    fn errors(&self) -> Vec<&Value> {
        self.console
            .iter()
            .filter(|e| e["level"] == "SEVERE")
            .collect()
    }

    async fn wait_for(&self, css: &str) -> fantoccini::elements::Element {
        self.wait_until(Locator::Css(css), css).await
    }

    /// Waits for an element `locator` finds; `what` says what was awaited when it fails.
    async fn wait_until(&self, locator: Locator<'_>, what: &str) -> fantoccini::elements::Element {
        self.c
            .wait()
            .at_most(PATIENCE)
            .for_element(locator)
            .await
            .unwrap_or_else(|e| panic!("{what} did not appear: {e}"))
    }

    /// Waits until the statistics panel shows `n` for `stat`.
    async fn wait_for_stat(&self, stat: &str, n: impl std::fmt::Display) {
        let xpath =
            format!("//*[@id='stats']//*[@data-stat='{stat}' and normalize-space(text())='{n}']");
        self.wait_until(
            Locator::XPath(&xpath),
            &format!("{stat} = {n} in the statistics"),
        )
        .await;
    }

    /// Clicks the element once it is on. The page re-renders its lists, so an element found
    /// may be replaced before the click reaches it: then it is found again.
    async fn click(&self, css: &str) {
        let on = format!("{css}:not([disabled])");
        for _ in 0..STALE_RETRIES {
            match self.wait_for(&on).await.click().await {
                Err(e) if e.is_stale_element_reference() => continue,
                done => return done.unwrap_or_else(|e| panic!("click {css}: {e}")),
            }
        }
        panic!("click {css}: replaced {STALE_RETRIES} times in a row");
    }

    /// Types into a field once it is on (the page turns its controls on when it knows who
    /// is calling).
    async fn fill(&self, css: &str, text: &str) {
        for _ in 0..STALE_RETRIES {
            let e = self.wait_for(&format!("{css}:not([disabled])")).await;
            let typed = match e.clear().await {
                Ok(()) => e.send_keys(text).await,
                cleared => cleared,
            };
            match typed {
                Err(e) if e.is_stale_element_reference() => continue,
                typed => return typed.unwrap_or_else(|e| panic!("type into {css}: {e}")),
            }
        }
        panic!("type into {css}: replaced {STALE_RETRIES} times in a row");
    }

    async fn select(&self, css: &str, value: &str) {
        self.click(&format!("{css}:not([disabled]) option[value=\"{value}\"]"))
            .await;
    }

    async fn attr(&self, css: &str, name: &str) -> Option<String> {
        for _ in 0..STALE_RETRIES {
            match self.wait_for(css).await.attr(name).await {
                Err(e) if e.is_stale_element_reference() => continue,
                read => return read.unwrap_or_else(|e| panic!("{css} [{name}]: {e}")),
            }
        }
        panic!("{css} [{name}]: replaced {STALE_RETRIES} times in a row");
    }

    async fn text(&self, css: &str) -> String {
        for _ in 0..STALE_RETRIES {
            match self.wait_for(css).await.text().await {
                Err(e) if e.is_stale_element_reference() => continue,
                read => return read.unwrap_or_else(|e| panic!("text of {css}: {e}")),
            }
        }
        panic!("text of {css}: replaced {STALE_RETRIES} times in a row");
    }

    /// Jogs `n` steps along one axis (`x+`, `rz-`, ...), each step waiting until the arm has
    /// moved (its joints change).
    async fn jog(&self, axis: &str, n: usize) {
        for _ in 0..n {
            let before = self.attr("#view3d", "data-joints").await;
            self.click(&format!("[data-jog=\"{axis}\"]")).await;
            let moved = format!(
                "//*[@id='view3d' and @data-joints!='{}']",
                before.unwrap_or_default()
            );
            self.wait_until(Locator::XPath(&moved), &format!("the arm's move on {axis}"))
                .await;
        }
    }

    async fn waypoints(&self) -> usize {
        self.c
            .find_all(Locator::Css("#waypoints li"))
            .await
            .expect("list")
            .len()
    }

    /// Records, and waits for the list to grow and the suggestion to be answered.
    async fn record(&self) {
        let n = self.waypoints().await;
        let answered = self.latencies().await.len();
        self.click("#record").await;
        self.wait_for(&format!("#waypoints li:nth-child({})", n + 1))
            .await;
        let shown = format!("//*[@id='latency' and @data-count='{}']", answered + 1);
        self.wait_until(Locator::XPath(&shown), "the suggestion after Record")
            .await;
    }

    async fn latencies(&self) -> Vec<f64> {
        let v = self
            .c
            .execute("return window.nextposeLatencies || [];", vec![])
            .await
            .expect("latencies");
        v.as_array()
            .expect("array")
            .iter()
            .filter_map(Value::as_f64)
            .collect()
    }

    /// Whether each control is off, and its title: `(id, disabled, title)`.
    async fn controls(&self, ids: &[&str]) -> Vec<(String, bool, String)> {
        let v = self
            .c
            .execute(
                "return arguments[0].map((id) => { const e = document.getElementById(id); \
                   return [id, e.disabled, e.title]; });",
                vec![json!(ids)],
            )
            .await
            .expect("controls");
        v.as_array()
            .expect("array")
            .iter()
            .map(|c| {
                (
                    c[0].as_str().expect("id").to_string(),
                    c[1].as_bool().expect("disabled"),
                    c[2].as_str().expect("title").to_string(),
                )
            })
            .collect()
    }

    /// Sets aside the console errors logged so far whose message contains `expected` (a
    /// refused request the test caused on purpose: Chromium logs its status).
    async fn set_aside(&mut self, expected: &str) {
        self.read_console().await;
        self.console.retain(|e| {
            !(e["level"] == "SEVERE" && e["message"].as_str().is_some_and(|m| m.contains(expected)))
        });
    }

    /// Fails on any console error the page logged, then closes the browser.
    async fn close(mut self) {
        self.read_console().await;
        let errors = self.errors();
        assert!(errors.is_empty(), "console errors: {errors:#?}");
        self.c.close().await.expect("close the browser");
    }

    async fn screenshot(&self, name: &str) {
        let png = self.c.screenshot().await.expect("screenshot");
        std::fs::write(self.shots.join(name), png).expect("write screenshot");
    }
}

/// The REST API as the test checks the server's state.
struct Api {
    base: String,
    http: reqwest::Client,
}

impl Api {
    async fn get(&self, path: &str) -> Value {
        let r = self
            .http
            .get(format!("{}{path}", self.base))
            .bearer_auth(TOKEN)
            .send()
            .await
            .expect("send");
        assert!(r.status().is_success(), "{path}: {}", r.status());
        r.json().await.expect("json")
    }

    async fn post(&self, path: &str, body: Value) -> Value {
        let r = self
            .http
            .post(format!("{}{path}", self.base))
            .bearer_auth(TOKEN)
            .json(&body)
            .send()
            .await
            .expect("send");
        assert!(r.status().is_success(), "{path}: {}", r.status());
        r.json().await.expect("json")
    }
}

impl Api {
    async fn patch(&self, path: &str, body: Value) -> Value {
        let r = self
            .http
            .patch(format!("{}{path}", self.base))
            .bearer_auth(TOKEN)
            .json(&body)
            .send()
            .await
            .expect("send");
        assert!(r.status().is_success(), "{path}: {}", r.status());
        r.json().await.expect("json")
    }

    /// A route's answer with `bearer` (or none): its status and body, as any client meets it.
    async fn answer(&self, path: &str, bearer: Option<&str>) -> (u16, Value) {
        let mut request = self.http.get(format!("{}{path}", self.base));
        if let Some(secret) = bearer {
            request = request.bearer_auth(secret);
        }
        let r = request.send().await.expect("send");
        let status = r.status().as_u16();
        (status, r.json().await.expect("json"))
    }

    /// The stored waypoints of a routine.
    async fn waypoints(&self, routine: i64) -> Vec<Value> {
        self.get(&format!("/v1/routines/{routine}")).await["waypoints"]
            .as_array()
            .expect("waypoints")
            .clone()
    }

    async fn feedback_count(&self, cell: i64, verdict: &str) -> i64 {
        self.get(&format!("/v1/cells/{cell}/stats")).await["feedback"][verdict]
            .as_i64()
            .expect("a count")
    }
}

/// Polls `check` until it gives an answer, for at most [`PATIENCE`]: the bounded wait of a
/// condition the test cannot express as one DOM query (the server's state, or either of two
/// outcomes).
async fn eventually<T, F, Fut>(what: &str, mut check: F) -> T
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = Option<T>>,
{
    let deadline = tokio::time::Instant::now() + PATIENCE;
    loop {
        if let Some(v) = check().await {
            return v;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "{what}: not within {PATIENCE:?}"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

fn position(v: &Value) -> [f64; 3] {
    let f = |k: &str| v[k].as_f64().expect(k);
    [f("x"), f("y"), f("z")]
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-3)
}

/// What a browser test runs against: the server on a loopback port with a token (its database
/// in a temporary directory), chromedriver, and a browser with its own profile, each kept
/// until the test drops it.
struct Session {
    _dir: tempfile::TempDir,
    server: Running,
    api: Api,
    driver: Driver,
    _profile: tempfile::TempDir,
    page: Page,
}

impl Session {
    async fn open() -> Session {
        let dir = tempfile::tempdir().expect("temp dir");
        let server = start_server(&dir).await;
        let api = Api {
            base: server.base_url(),
            http: reqwest::Client::new(),
        };
        let driver = start_driver().await;
        let profile = tempfile::tempdir().expect("profile dir");
        let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("pendant");
        std::fs::create_dir_all(&shots).expect("screenshot dir");
        let page = Page {
            c: browser(&driver, &profile).await,
            console: Vec::new(),
            shots,
        };
        Session {
            _dir: dir,
            server,
            api,
            driver,
            _profile: profile,
            page,
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_person_teaches_through_the_pendant_page() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        mut page,
    } = Session::open().await;
    let base = api.base.clone();

    // The page asks for the token.
    page.c
        .goto(&format!("{base}/"))
        .await
        .expect("open the page");
    page.wait_for("#token-dialog[open]").await;
    // The console check sees what the page logs: a probe error is read, then set aside.
    page.c
        .execute("console.error('nextpose console probe');", vec![])
        .await
        .expect("probe");
    page.read_console().await;
    let probe = page.errors().iter().any(|e| {
        e["message"]
            .as_str()
            .is_some_and(|m| m.contains("nextpose console probe"))
    });
    assert!(
        probe,
        "the browser log shows console errors: {:?}",
        page.console
    );
    page.console.clear();
    page.fill("#token-input", TOKEN).await;
    page.click("#token-submit").await;

    // A cell, a program, a routine.
    page.fill("#new-cell-name", "browser cell").await;
    page.select("#new-cell-robot", "abb_irb140").await;
    page.select("#new-cell-policy", "flag").await;
    page.click("#create-cell").await;
    page.wait_for("#cell-select option:checked").await;
    page.fill("#new-program-name", "Seams").await;
    page.click("#create-program").await;
    page.wait_for("#program-select option:checked").await;
    page.click("#create-routine").await;
    page.wait_for("#routine-select option:checked").await;

    let cells = api.get("/v1/cells").await;
    let cell = cells
        .as_array()
        .expect("cells")
        .iter()
        .find(|c| c["name"] == "browser cell")
        .expect("the cell the page created");
    let cell_id = cell["id"].as_i64().expect("id");
    assert_eq!(cell["settings"]["robot"], "abb_irb140");
    assert_eq!(cell["settings"]["reach_policy"], "flag");
    let home = position(&api.get(&format!("/v1/cells/{cell_id}/frames")).await["tcp"]);

    // Routine 1, jogged in the work frame with 20 mm steps: a U over a seam.
    page.select("#jog-frame", "work").await;
    page.fill("#jog-step", "20").await;
    let moves: [(&str, usize); 5] = [("x+", 3), ("y+", 2), ("z-", 2), ("x-", 3), ("z+", 2)];
    page.record().await;
    for (axis, n) in moves {
        page.jog(axis, n).await;
        page.record().await;
    }
    assert_eq!(page.waypoints().await, 6);
    page.click("#finish").await;
    page.wait_for("#stats [data-stat=states]").await;
    // A cell created with its arm only learns its operator and steers its own threshold: the
    // panel says so (one routine shows no repeats yet: exact, the seed's tolerance).
    page.wait_for_stat("noise", "0.0 mm (learned)").await;
    page.wait_for_stat("tolerance", "1.0 mm (learned)").await;
    let steered = page
        .wait_until(
            Locator::XPath(
                "//*[@id='stats']//*[@data-stat='threshold' and contains(text(), '(steered)')]",
            ),
            "a steered threshold in the statistics",
        )
        .await;
    let shown: f64 = steered
        .text()
        .await
        .expect("threshold text")
        .split_whitespace()
        .next()
        .and_then(|v| v.parse().ok())
        .expect("a number first");
    assert!((0.0..=1.0).contains(&shown), "{shown}");

    let programs = api.get(&format!("/v1/cells/{cell_id}/programs")).await;
    let program_id = programs[0]["id"].as_i64().expect("program id");
    let routines = api
        .get(&format!("/v1/programs/{program_id}/routines"))
        .await;
    let first = api
        .get(&format!("/v1/routines/{}", routines[0]["id"]))
        .await;
    let stored: Vec<[f64; 3]> = first["waypoints"]
        .as_array()
        .expect("waypoints")
        .iter()
        .map(|w| position(&w["pose"]))
        .collect();
    let offsets = [
        [0.0, 0.0, 0.0],
        [60.0, 0.0, 0.0],
        [60.0, 40.0, 0.0],
        [60.0, 40.0, -40.0],
        [0.0, 40.0, -40.0],
        [0.0, 40.0, 0.0],
    ];
    assert_eq!(stored.len(), offsets.len());
    for (s, o) in stored.iter().zip(offsets) {
        let want = [home[0] + o[0], home[1] + o[1], home[2] + o[2]];
        assert!(close(*s, want), "stored {s:?}, jogged to {want:?}");
    }
    assert!(
        first["waypoints"]
            .as_array()
            .expect("waypoints")
            .iter()
            .all(|w| w["joints"].as_array().is_some_and(|j| j.len() == 6)),
        "the page records the arm's joints with each pose"
    );

    // Routine 2, from where routine 1 ended (its start + 40 mm in y), 120 mm to the side: the
    // ghost appears after its first waypoint.
    page.click("#create-routine").await;
    page.jog("y-", 6).await;
    page.record().await;
    page.wait_for("#suggestion[data-state=offered]").await;
    page.wait_for("#view3d[data-ghost=shown]").await;
    page.screenshot("pendant-ghost.png").await;
    let suggested = page
        .attr("#suggestion", "data-prediction-id")
        .await
        .expect("prediction id");

    // Accept: the arm goes there and the waypoint is recorded, with feedback.
    page.click("#accept").await;
    page.wait_for("#waypoints li:nth-child(2)").await;
    page.wait_for_stat("accepted", 1).await;
    let second = routines_of(&api, program_id).await;
    let open = api.get(&format!("/v1/routines/{}", second[1])).await;
    let taught = open["waypoints"].as_array().expect("waypoints");
    assert_eq!(taught.len(), 2);
    let start = [home[0], home[1] + 40.0 - 120.0, home[2]];
    assert!(
        close(position(&taught[0]["pose"]), start),
        "{:?}",
        taught[0]["pose"]
    );
    let want = [start[0] + 60.0, start[1], start[2]];
    assert!(
        close(position(&taught[1]["pose"]), want),
        "accepted {:?}, the copy's next corner is {want:?}",
        position(&taught[1]["pose"])
    );
    let stats = api.get(&format!("/v1/cells/{cell_id}/stats")).await;
    assert_eq!(stats["feedback"]["accepted"], 1, "{stats}");

    // Undo: the accepted waypoint goes; the same suggestion is offered again (the service
    // keeps one prediction per waypoint and model, and its feedback), and Reject is not
    // offered for it.
    page.click("#undo").await;
    page.wait_until(
        Locator::XPath("//*[@id='waypoints' and count(li)=1]"),
        "one waypoint after undo",
    )
    .await;
    page.wait_for(&format!(
        "#suggestion[data-state=offered][data-prediction-id=\"{suggested}\"]"
    ))
    .await;
    page.wait_for("#reject[disabled]").await;
    let open = api.get(&format!("/v1/routines/{}", second[1])).await;
    assert_eq!(open["waypoints"].as_array().expect("waypoints").len(), 1);

    // Accept it again (no second feedback), then reject the next suggestion.
    page.click("#accept").await;
    page.wait_for("#waypoints li:nth-child(2)").await;
    page.wait_for("#suggestion[data-state=offered]").await;
    let next = page
        .attr("#suggestion", "data-prediction-id")
        .await
        .expect("prediction id");
    assert_ne!(next, suggested, "the next corner is a new prediction");
    page.click("#reject").await;
    page.wait_for("#suggestion[data-state=none]").await;
    page.wait_for("#view3d[data-ghost=none]").await;
    page.wait_for_stat("rejected", 1).await;
    let open = api.get(&format!("/v1/routines/{}", second[1])).await;
    let taught = open["waypoints"].as_array().expect("waypoints");
    assert_eq!(taught.len(), 2);
    assert!(close(position(&taught[1]["pose"]), want));
    page.click("#finish").await;

    // Routine 3 at the edge of the arm's reach (from routine 2's end, 320 mm out in x): the
    // next corner, 60 mm further, is beyond it.
    page.click("#create-routine").await;
    page.fill("#jog-step", "80").await;
    page.jog("x+", 4).await;
    page.record().await;
    page.wait_for("#suggestion[data-state=unreachable]").await;
    page.wait_for("#view3d[data-ghost=unreachable]").await;
    let reason = page.text("#suggestion-reason").await;
    assert!(reason.contains("reach"), "the reason is shown: {reason:?}");
    page.screenshot("pendant-unreachable.png").await;

    let stats = api.get(&format!("/v1/cells/{cell_id}/stats")).await;
    assert_eq!(stats["feedback"]["accepted"], 1, "{stats}");
    assert_eq!(stats["feedback"]["rejected"], 1, "{stats}");
    assert_eq!(stats["model"]["routines"], 2, "{stats}");

    // The optional calibration: one point recorded three times, turning the tool away and back
    // between records. Jogs are exact, so the scatter is none: the cell's noise is set to 0.
    page.click("#calibration summary").await;
    for k in 0..3 {
        if k > 0 {
            page.jog("rz+", 1).await;
            page.jog("rz-", 1).await;
        }
        page.click("#calib-record").await;
        page.wait_for(&format!("#calib-count[data-count=\"{}\"]", k + 1))
            .await;
    }
    page.click("#calib-apply").await;
    page.wait_for_stat("noise", "0.0 mm (set)").await;
    page.wait_for("#calib-count[data-count=\"0\"]").await;
    let cell = api.get(&format!("/v1/cells/{cell_id}")).await;
    let noise = &cell["settings"]["noise"];
    assert!(noise["mm"].as_f64().expect("noise set") < 1e-6, "{noise}");
    let stats = api.get(&format!("/v1/cells/{cell_id}/stats")).await;
    assert_eq!(stats["teaching"]["noise_learned"], false, "{stats}");

    // At a pendant's 800×600 the view and every action button are on screen.
    page.c.set_window_size(800, 600).await.expect("resize");
    let off_screen = page
        .c
        .execute(
            "return ['view3d', 'record', 'accept', 'adjust', 'reject', 'undo', 'finish', \
                     'waypoints', 'suggestion', 'latency'].filter((id) => { \
               const r = document.getElementById(id).getBoundingClientRect(); \
               return r.width === 0 || r.left < 0 || r.top < 0 || \
                      r.right > window.innerWidth || r.bottom > window.innerHeight; });",
            vec![],
        )
        .await
        .expect("layout");
    assert_eq!(off_screen, json!([]), "off screen at 800×600");
    page.screenshot("pendant-800x600.png").await;

    // The page's own measurements, and its console.
    let latencies = page.latencies().await;
    assert!(latencies.len() >= 8, "{latencies:?}");
    let mut sorted = latencies.clone();
    sorted.sort_by(f64::total_cmp);
    let summary = json!({
        "samples": latencies,
        "median_ms": sorted[sorted.len() / 2],
        "max_ms": sorted[sorted.len() - 1],
    });
    std::fs::write(
        page.shots.join("latency.json"),
        serde_json::to_string_pretty(&summary).expect("json"),
    )
    .expect("write latencies");
    eprintln!("Record → suggestion (ms): {summary}");
    page.close().await;
    drop(driver);
    drop(server);
}

async fn routines_of(api: &Api, program_id: i64) -> Vec<i64> {
    api.get(&format!("/v1/programs/{program_id}/routines"))
        .await
        .as_array()
        .expect("routines")
        .iter()
        .map(|r| r["id"].as_i64().expect("id"))
        .collect()
}

/// Issue 30's pendant: a grid of slots taught by hand (per slot an approach and a place 40 mm
/// below it) on an IRB 140 cell created with its arm only. The first row of seven slots (60 mm
/// apart along y) and the first slot of the second row (80 mm out in x) are jogged and
/// recorded; from then on the cell suggests the rest of the row. With the look-ahead on, the
/// page shows the next suggestions as ghosts and flags the first slot the arm cannot reach (the
/// second row's last, at the edge of the arm's reach) before the operator gets there; one
/// action accepts the next five slots (ten suggestions), each recorded as an accepted
/// suggestion, and the stored waypoints are the lattice's points.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_grid_is_finished_by_suggestions_on_the_pendant() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        page,
    } = Session::open().await;
    let base = api.base.clone();
    page.c
        .goto(&format!("{base}/"))
        .await
        .expect("open the page");
    page.fill("#token-input", TOKEN).await;
    page.click("#token-submit").await;
    page.fill("#new-cell-name", "grid cell").await;
    page.select("#new-cell-robot", "abb_irb140").await;
    page.click("#create-cell").await;
    page.wait_for("#cell-select option:checked").await;
    page.fill("#new-program-name", "Tray").await;
    page.click("#create-program").await;
    page.wait_for("#program-select option:checked").await;
    page.click("#create-routine").await;
    page.wait_for("#routine-select option:checked").await;
    let cells = api.get("/v1/cells").await;
    let cell_id = cells[0]["id"].as_i64().expect("cell id");
    let home = position(&api.get(&format!("/v1/cells/{cell_id}/frames")).await["tcp"]);

    // The grid: slot (row, col) at 80 mm × row out in x and 60 mm × col along y from the
    // first, which is 240 mm out from home; the approach at home's height, the place 40 mm
    // below. The second row's last slot is beyond the arm's reach, every other one within it.
    let (cols, depth) = (7, 40.0);
    let slot = |row: usize, col: usize, placed: bool| {
        [
            home[0] + 240.0 + 80.0 * row as f64,
            home[1] + 60.0 * col as f64,
            home[2] - if placed { depth } else { 0.0 },
        ]
    };
    let reach = |p: [f64; 3]| {
        let api = &api;
        async move {
            let pose = json!({"x": p[0], "y": p[1], "z": p[2], "qw": 0.0, "qx": 0.0, "qy": -1.0, "qz": 0.0});
            let r = api
                .http
                .post(format!("{}/v1/cells/{cell_id}/reach", api.base))
                .bearer_auth(TOKEN)
                .json(&json!({ "pose": pose }))
                .send()
                .await
                .expect("reach");
            r.json::<Value>().await.expect("json")["reachable"] == true
        }
    };
    for row in 0..2 {
        for col in 0..cols {
            for placed in [false, true] {
                let p = slot(row, col, placed);
                let last = row == 1 && col == cols - 1;
                assert_eq!(reach(p).await, !last, "reach of {p:?}");
            }
        }
    }

    // Jog: out to the first slot, then each slot's approach and place; after the first row,
    // back along it and out to the second row's first slot.
    let jog_by = |axis: &'static str, mm: f64| {
        let page = &page;
        async move {
            page.fill("#jog-step", &format!("{mm}")).await;
            page.jog(axis, 1).await;
        }
    };
    page.select("#jog-frame", "work").await;
    jog_by("x+", 240.0).await;
    for col in 0..cols {
        if col > 0 {
            jog_by("z+", depth).await;
            jog_by("y+", 60.0).await;
        }
        page.record().await;
        jog_by("z-", depth).await;
        page.record().await;
    }
    jog_by("z+", depth).await;
    jog_by("y-", 60.0 * (cols - 1) as f64).await;
    jog_by("x+", 80.0).await;
    page.record().await;
    jog_by("z-", depth).await;
    page.record().await;
    let taught = 2 * cols + 2;
    assert_eq!(page.waypoints().await, taught);

    // The second row's second slot is suggested by the lattice expert.
    page.wait_for("#suggestion[data-state=offered]").await;
    let text = page.text("#suggestion-text").await;
    assert!(text.contains("lattice"), "suggested by {text:?}");

    // The look-ahead shows the rest of the row as ghosts, and flags its last slot, out of
    // reach, before the operator gets there: ten suggestions within reach, the eleventh flagged.
    page.fill("#lookahead-k", "20").await;
    page.click("#show-path").await;
    page.wait_for("#ahead[data-count='11'][data-unreachable='11']")
        .await;
    page.screenshot("pendant-grid-ahead.png").await;

    // One action accepts the next five slots: ten suggestions, each with its feedback.
    page.fill("#accept-n-count", "10").await;
    page.click("#accept-n").await;
    page.wait_for(&format!("#waypoints li:nth-child({})", taught + 10))
        .await;
    page.wait_for_stat("accepted", 10).await;
    // What is left of the row: the flagged slot, now next.
    page.wait_for("#ahead[data-count='1'][data-unreachable='1']")
        .await;
    let programs = api.get(&format!("/v1/cells/{cell_id}/programs")).await;
    let program_id = programs[0]["id"].as_i64().expect("program id");
    let routine = routines_of(&api, program_id).await[0];
    let stored = api.get(&format!("/v1/routines/{routine}")).await;
    let stored: Vec<[f64; 3]> = stored["waypoints"]
        .as_array()
        .expect("waypoints")
        .iter()
        .map(|w| position(&w["pose"]))
        .collect();
    assert_eq!(stored.len(), taught + 10);
    for (i, s) in stored[taught..].iter().enumerate() {
        let want = slot(1, 1 + i / 2, i % 2 == 1);
        assert!(
            close(*s, want),
            "accepted waypoint {i}: {s:?}, the slot is {want:?}"
        );
    }
    let stats = api.get(&format!("/v1/cells/{cell_id}/stats")).await;
    assert_eq!(stats["feedback"]["accepted"], 10, "{stats}");
    assert_eq!(stats["feedback"]["rejected"], 0, "{stats}");
    // The next slot is not offered: the arm cannot reach it.
    page.wait_for("#accept-n[disabled]").await;
    page.screenshot("pendant-grid-accepted.png").await;

    page.close().await;
    drop(driver);
    drop(server);
}

/// Issue 31's tokens with roles on the page: the bootstrap admin creates a cell with an open
/// routine (and another cell) and two tokens limited to that cell, an operator and an engineer.
/// Signed in with each in turn (the page's *Change token* forgets the one before), then with
/// the admin token, the header says who is signed in, and each control is on or off as the
/// role allows (src/app/access.rs): the operator teaches (Record is on and a recorded waypoint
/// is stored) but may not create cells or programs, edit waypoints or calibrate, and each such
/// control's title names the role it needs; the engineer may edit but, limited to a cell, not
/// create cells; the admin may do all. A 403 the operator meets anyway (a control forced on, as
/// on a page whose token lost a role) is shown with the service's message and changes nothing.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_page_shows_who_is_signed_in_and_greys_out_what_the_role_may_not_do() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        mut page,
    } = Session::open().await;
    let base = api.base.clone();
    let arm = json!({ "robot": "abb_irb140" });
    api.post(
        "/v1/cells",
        json!({ "name": "other cell", "settings": arm }),
    )
    .await;
    let cell = api
        .post("/v1/cells", json!({ "name": "line 3", "settings": arm }))
        .await;
    let cell_id = cell["id"].as_i64().expect("cell id");
    let program = api
        .post(
            &format!("/v1/cells/{cell_id}/programs"),
            json!({ "name": "Seams" }),
        )
        .await;
    let program_id = program["id"].as_i64().expect("program id");
    let routine = api
        .post(&format!("/v1/programs/{program_id}/routines"), json!({}))
        .await;
    let routine_id = routine["id"].as_i64().expect("routine id");
    let token = |name: &'static str, role: &'static str| {
        let api = &api;
        async move {
            let created = api
                .post(
                    "/v1/tokens",
                    json!({ "name": name, "role": role, "cells": [cell_id] }),
                )
                .await;
            assert_eq!(created["token"]["role"], role, "{created}");
            created["secret"].as_str().expect("secret").to_string()
        }
    };
    let operator = token("op-1", "operator").await;
    let engineer = token("eng-1", "engineer").await;

    // What a role may not use, by the least role each needs.
    let edits = [
        "create-program",
        "new-program-name",
        "wp-reteach",
        "wp-rename",
        "wp-motion",
        "wp-insert-before",
        "wp-insert-after",
        "wp-delete",
        "calib-record",
        "calib-apply",
        "calib-clear",
    ];
    let whole_service = [
        "create-cell",
        "new-cell-name",
        "new-cell-robot",
        "new-cell-policy",
    ];
    let teaching = ["record", "undo", "finish", "create-routine", "show-path"];

    // The operator signs in through the token dialog.
    page.c
        .goto(&format!("{base}/"))
        .await
        .expect("open the page");
    page.wait_for("#token-dialog[open]").await;
    page.fill("#token-input", &operator).await;
    page.click("#token-submit").await;
    let signed_in = page
        .wait_for("#signed-in[data-role=operator][data-name=op-1]")
        .await
        .text()
        .await
        .expect("text");
    assert!(
        signed_in.contains("op-1")
            && signed_in.contains("operator")
            && signed_in.contains(&format!("cell {cell_id}")),
        "{signed_in:?}"
    );
    // It sees its cell only, and teaches in its open routine.
    page.wait_for("#record:not([disabled])").await;
    let listed = page
        .c
        .execute(
            "return [...document.querySelectorAll('#cell-select option')].map((o) => o.value);",
            vec![],
        )
        .await
        .expect("cells listed");
    assert_eq!(listed, json!([cell_id.to_string()]));
    page.record().await;
    let stored = api.get(&format!("/v1/routines/{routine_id}")).await;
    assert_eq!(
        stored["waypoints"].as_array().expect("waypoints").len(),
        1,
        "the operator's Record is stored"
    );
    // With a waypoint selected, the edits would be on for a role that may edit.
    page.click("#waypoints li").await;
    page.wait_for("#waypoints li[aria-selected=true]").await;
    for (id, off, title) in page.controls(&teaching).await {
        assert!(!off, "{id} is on for the operator ({title:?})");
    }
    for (id, off, title) in page
        .controls(&[&edits[..], &whole_service[..]].concat())
        .await
    {
        assert!(off, "{id} is off for the operator");
        assert!(
            title.contains("needs the engineer role"),
            "{id}'s title says what it needs: {title:?}"
        );
    }

    // A 403 all the same (a control forced on and pressed) is shown, and creates nothing.
    page.c
        .execute(
            "const b = document.getElementById('create-program'); b.disabled = false; b.click();",
            vec![],
        )
        .await
        .expect("press create-program");
    page.wait_for("#status[data-level=error][data-code=forbidden]")
        .await;
    let shown = page.attr("#status", "title").await.unwrap_or_default();
    assert!(
        shown.contains("op-1") && shown.contains("engineer"),
        "the service's message is shown: {shown:?}"
    );
    page.wait_for("#create-program[disabled]").await;
    let programs = api.get(&format!("/v1/cells/{cell_id}/programs")).await;
    assert_eq!(programs.as_array().expect("programs").len(), 1);
    page.set_aside("status of 403").await;
    page.screenshot("pendant-operator.png").await;

    // Change token: the engineer of the same cell may edit, but not create a cell.
    page.click("#sign-out").await;
    page.wait_for("#token-dialog[open]").await;
    page.fill("#token-input", &engineer).await;
    page.click("#token-submit").await;
    page.wait_for("#signed-in[data-role=engineer][data-name=eng-1]")
        .await;
    page.wait_for("#record:not([disabled])").await;
    page.click("#waypoints li").await;
    page.wait_for("#waypoints li[aria-selected=true]").await;
    for (id, off, title) in page.controls(&teaching).await {
        assert!(!off, "{id} is on for the engineer ({title:?})");
    }
    for (id, off, title) in page.controls(&edits).await {
        // Setting the noise waits for three recorded points.
        assert_eq!(
            off,
            id == "calib-apply",
            "{id} for the engineer ({title:?})"
        );
    }
    for (id, off, title) in page.controls(&whole_service).await {
        assert!(off, "{id} is off for an engineer limited to a cell");
        assert!(
            title.contains("not limited to some cells"),
            "{id}'s title says why: {title:?}"
        );
    }

    // The bootstrap admin may do all, in every cell.
    page.click("#sign-out").await;
    page.wait_for("#token-dialog[open]").await;
    page.fill("#token-input", TOKEN).await;
    page.click("#token-submit").await;
    let signed_in = page
        .wait_for("#signed-in[data-role=admin][data-name=bootstrap]")
        .await
        .text()
        .await
        .expect("text");
    assert!(!signed_in.contains("cell"), "{signed_in:?}");
    page.wait_for("#record:not([disabled])").await;
    page.wait_for("#cell-select option:nth-child(2)").await;
    page.click("#waypoints li").await;
    page.wait_for("#waypoints li[aria-selected=true]").await;
    for (id, off, title) in page
        .controls(&[&teaching[..], &edits[..], &whole_service[..]].concat())
        .await
    {
        assert_eq!(off, id == "calib-apply", "{id} for the admin ({title:?})");
    }
    page.screenshot("pendant-admin.png").await;

    page.close().await;
    drop(driver);
    drop(server);
}

// ---- issue 46: what a new user met on the page ----

impl Page {
    /// Opens the page and signs in with `secret` through the token dialog.
    async fn open_signed_in(&self, base: &str, secret: &str) {
        self.c
            .goto(&format!("{base}/"))
            .await
            .expect("open the page");
        self.wait_for("#token-dialog[open]").await;
        self.fill("#token-input", secret).await;
        self.click("#token-submit").await;
        self.wait_for("#token-dialog:not([open])").await;
    }

    /// Runs a script in the page and gives its value.
    async fn js(&self, script: &str) -> Value {
        self.c
            .execute(script, vec![])
            .await
            .unwrap_or_else(|e| panic!("{script}: {e}"))
    }

    /// The header's status: `(level, text)`.
    async fn status(&self) -> (String, String) {
        let v = self
            .js("const s = document.getElementById('status'); return [s.dataset.level, s.textContent];")
            .await;
        (
            v[0].as_str().unwrap_or_default().to_string(),
            v[1].as_str().unwrap_or_default().to_string(),
        )
    }

    /// Whether the page has no press in flight (the page marks it on `body[data-busy]`).
    async fn idle(&self) -> bool {
        self.js("return document.body.dataset.busy === '0';").await == json!(true)
    }
}

/// A cell of an IRB 140 that has learned one routine (six waypoints jogged in the work frame:
/// a U over a seam, as the first test teaches it) and a second routine under way, 120 mm to the
/// side, with its first waypoint: the next corner is on offer. All through the API, each
/// waypoint with the joints the arm reaches it with.
struct Taught {
    cell: i64,
    program: i64,
    routine: i64,
    /// The arm's ready TCP position, which the routines are placed from.
    home: [f64; 3],
}

async fn teach_a_seam(api: &Api, robot: &str) -> Taught {
    let cell = api
        .post(
            "/v1/cells",
            json!({ "name": "seam cell", "settings": { "robot": robot } }),
        )
        .await;
    let cell = cell["id"].as_i64().expect("cell id");
    let program = api
        .post(
            &format!("/v1/cells/{cell}/programs"),
            json!({ "name": "Seams" }),
        )
        .await;
    let program = program["id"].as_i64().expect("program id");
    let tcp = api.get(&format!("/v1/cells/{cell}/frames")).await["tcp"].clone();
    let home = position(&tcp);
    let mut near = api.get(&format!("/v1/cells/{cell}/frames")).await["joints"].clone();
    let mut teach = async |routine: i64, offset: [f64; 3]| {
        let mut pose = tcp.clone();
        for (k, o) in ["x", "y", "z"].iter().zip(offset) {
            pose[*k] = json!(tcp[*k].as_f64().expect("coordinate") + o);
        }
        let reach = api
            .post(
                &format!("/v1/cells/{cell}/reach"),
                json!({ "pose": pose, "near": near }),
            )
            .await;
        assert_eq!(reach["reachable"], true, "{pose} is within reach: {reach}");
        near = reach["chosen"].clone();
        api.post(
            &format!("/v1/routines/{routine}/waypoints"),
            json!({ "pose": pose, "joints": near, "motion": "linear" }),
        )
        .await
    };
    let first = api
        .post(&format!("/v1/programs/{program}/routines"), json!({}))
        .await["id"]
        .as_i64()
        .expect("routine id");
    for o in [
        [0.0, 0.0, 0.0],
        [60.0, 0.0, 0.0],
        [60.0, 40.0, 0.0],
        [60.0, 40.0, -40.0],
        [0.0, 40.0, -40.0],
        [0.0, 40.0, 0.0],
    ] {
        teach(first, o).await;
    }
    api.post(&format!("/v1/routines/{first}/finish"), json!({}))
        .await;
    let routine = api
        .post(&format!("/v1/programs/{program}/routines"), json!({}))
        .await["id"]
        .as_i64()
        .expect("routine id");
    let taught = teach(routine, [0.0, -80.0, 0.0]).await;
    assert_eq!(
        taught["prediction"]["offered"], true,
        "the copy's next corner is offered: {taught}"
    );
    Taught {
        cell,
        program,
        routine,
        home,
    }
}

/// Issue 46: a double click on Accept, or `a` pressed twice quickly, records one waypoint, the
/// suggestion that was on screen; a double-clicked *Accept next* counts what it accepted. The
/// two clicks (and the two key presses) are dispatched in one script, so no answer of the
/// service can come between them: the second lands while the first is in flight.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_double_press_accepts_once_and_only_what_was_on_screen() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        page,
    } = Session::open().await;
    let base = api.base.clone();
    let t = teach_a_seam(&api, "abb_irb140").await;
    page.open_signed_in(&base, TOKEN).await;
    page.wait_for("#suggestion[data-state=offered]").await;
    page.wait_for("#accept:not([disabled])").await;
    let shown = page
        .attr("#suggestion", "data-prediction-id")
        .await
        .expect("prediction id");
    let offered = api
        .get(&format!("/v1/routines/{}/prediction", t.routine))
        .await["predictions"][0]
        .clone();
    assert_eq!(offered["id"].to_string(), shown);

    // Accept pressed just after the finished routine was picked (both in one script): the
    // press carries the suggestion on screen, which is gone when its turn comes, so nothing is
    // sent and the header says why.
    let routines = routines_of(&api, t.program).await;
    page.js(&format!(
        "const s = document.getElementById('routine-select'); s.value = '{}'; \
         s.dispatchEvent(new Event('change')); document.getElementById('accept').click();",
        routines[0]
    ))
    .await;
    let said = page
        .wait_until(
            Locator::XPath("//*[@id='status' and @data-level='error']"),
            "the refused Accept",
        )
        .await
        .text()
        .await
        .expect("status");
    assert!(said.contains("suggestion on screen changed"), "{said:?}");
    assert_eq!(api.waypoints(t.routine).await.len(), 1);
    assert_eq!(api.waypoints(routines[0]).await.len(), 6);
    assert_eq!(api.feedback_count(t.cell, "accepted").await, 0);
    page.select("#routine-select", &t.routine.to_string()).await;
    page.wait_for(&format!(
        "#suggestion[data-state=offered][data-prediction-id=\"{shown}\"]"
    ))
    .await;

    // One press, or two: each ends when the page is idle again, or when the service holds more
    // waypoints than one press may record.
    let pressed = |before: usize| {
        let (api, page) = (&api, &page);
        async move {
            eventually("the press to be taken", || async move {
                // Idle first: once the page is idle, what is stored is the press's last word.
                let idle = page.idle().await;
                let stored = api.waypoints(t.routine).await.len();
                (stored > before + 1 || (stored == before + 1 && idle)).then_some(stored)
            })
            .await
        }
    };

    // A double click on Accept.
    page.js("const b = document.getElementById('accept'); b.click(); b.click();")
        .await;
    let stored = pressed(1).await;
    assert_eq!(
        stored,
        2,
        "a double click on Accept recorded {} waypoints",
        stored - 1
    );
    let w = api.waypoints(t.routine).await;
    assert!(
        close(position(&w[1]["pose"]), position(&offered["pose"])),
        "the accepted waypoint {:?} is the suggestion on screen {:?}",
        w[1]["pose"],
        offered["pose"]
    );
    assert_eq!(api.feedback_count(t.cell, "accepted").await, 1);
    let (level, text) = page.status().await;
    assert_ne!(level, "error", "{text}");

    // `a` twice.
    page.wait_for("#suggestion[data-state=offered]").await;
    page.wait_for("#accept:not([disabled])").await;
    page.js("for (const k of ['a', 'a']) document.body.dispatchEvent(\
           new KeyboardEvent('keydown', { key: k, bubbles: true }));")
        .await;
    let stored = pressed(2).await;
    assert_eq!(stored, 3, "a, a recorded {} waypoints, not one", stored - 2);
    assert_eq!(api.feedback_count(t.cell, "accepted").await, 2);

    // A double click on Accept next (5): the status counts what was accepted.
    page.wait_for("#accept-n:not([disabled])").await;
    page.fill("#accept-n-count", "5").await;
    page.js("const b = document.getElementById('accept-n'); b.click(); b.click();")
        .await;
    // Idle first, then the status: read the other way round, the status could be the one
    // before Accept next when it ends between the two reads.
    let settled = eventually("Accept next to end", || async {
        let idle = page.idle().await;
        let (_, text) = page.status().await;
        (idle || text.contains("accepted 0")).then_some(text)
    })
    .await;
    let accepted = api.waypoints(t.routine).await.len() - 3;
    assert!(accepted >= 1, "Accept next accepted nothing");
    assert!(
        settled.starts_with(&format!("accepted {accepted}")),
        "the status says {settled:?}; {accepted} were accepted"
    );
    assert_eq!(
        api.feedback_count(t.cell, "accepted").await,
        2 + accepted as i64
    );
    let (level, text) = page.status().await;
    assert_ne!(level, "error", "{text}");

    page.close().await;
    drop(driver);
    drop(server);
}

/// Issue 46: feedback, undo and a reload agree with the service. Accepted, then the page is
/// reloaded and the waypoint undone: the same suggestion is back, the page knows it has its
/// feedback (Reject is off) and Accept records it again without a second feedback. Feedback
/// given elsewhere (another pendant, here the API) is the service's word too: Accept records
/// the waypoint, Reject says the suggestion already has feedback and changes nothing.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn feedback_after_a_reload_and_an_undo_agrees_with_the_service() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        mut page,
    } = Session::open().await;
    let base = api.base.clone();
    let t = teach_a_seam(&api, "abb_irb140").await;
    page.open_signed_in(&base, TOKEN).await;
    page.wait_for("#suggestion[data-state=offered]").await;
    let first = page
        .attr("#suggestion", "data-prediction-id")
        .await
        .expect("prediction id");
    page.click("#accept").await;
    page.wait_for("#waypoints li:nth-child(2)").await;
    page.wait_for_stat("accepted", 1).await;

    page.c.refresh().await.expect("reload");
    page.wait_for("#waypoints li:nth-child(2)").await;
    page.click("#undo").await;
    page.wait_until(
        Locator::XPath("//*[@id='waypoints' and count(li)=1]"),
        "one waypoint after undo",
    )
    .await;
    page.wait_for(&format!(
        "#suggestion[data-state=offered][data-prediction-id=\"{first}\"]"
    ))
    .await;
    page.wait_for("#accept:not([disabled])").await;
    let (off, title) = {
        let c = page.controls(&["reject"]).await;
        (c[0].1, c[0].2.clone())
    };
    assert!(
        off && title.contains("already has feedback (accepted)"),
        "Reject is off for a suggestion with feedback, and says why ({title:?})"
    );

    // Accept again: recorded, no second feedback, no error.
    page.click("#accept").await;
    let stored = eventually("the accepted waypoint to be stored", || async {
        let w = api.waypoints(t.routine).await;
        (w.len() == 2).then_some(w)
    })
    .await;
    page.wait_for("#waypoints li:nth-child(2)").await;
    let want = [t.home[0] + 60.0, t.home[1] - 80.0, t.home[2]];
    assert!(close(position(&stored[1]["pose"]), want), "{:?}", stored[1]);
    page.wait_for("#status[data-level=info]").await;
    assert_eq!(api.feedback_count(t.cell, "accepted").await, 1);

    // Feedback from elsewhere on the next suggestion, then Accept on the page: recorded.
    page.wait_for("#suggestion[data-state=offered]").await;
    let second = page
        .attr("#suggestion", "data-prediction-id")
        .await
        .expect("prediction id");
    assert_ne!(second, first);
    api.post(
        &format!("/v1/predictions/{second}/feedback"),
        json!({ "verdict": "rejected" }),
    )
    .await;
    page.click("#accept").await;
    eventually("the third waypoint to be stored", || async {
        (api.waypoints(t.routine).await.len() == 3).then_some(())
    })
    .await;
    let shown = page
        .wait_for("#status[data-level=info]")
        .await
        .text()
        .await
        .expect("status");
    assert!(shown.contains("rejected"), "the status says so: {shown:?}");

    // And Reject on a suggestion accepted elsewhere: nothing recorded, the page says why.
    page.wait_for("#suggestion[data-state=offered]").await;
    let third = page
        .attr("#suggestion", "data-prediction-id")
        .await
        .expect("prediction id");
    api.post(
        &format!("/v1/predictions/{third}/feedback"),
        json!({ "verdict": "accepted" }),
    )
    .await;
    page.click("#reject").await;
    page.wait_for("#suggestion[data-state=none]").await;
    let shown = page.text("#status").await;
    assert!(
        shown.contains("already has feedback") && shown.contains("accepted"),
        "{shown:?}"
    );
    assert_eq!(page.status().await.0, "info");
    assert_eq!(api.feedback_count(t.cell, "accepted").await, 2);
    assert_eq!(api.feedback_count(t.cell, "rejected").await, 1);
    assert_eq!(api.waypoints(t.routine).await.len(), 3);

    // The service's 409s the page was told and took as its word.
    page.set_aside("status of 409").await;
    page.close().await;
    drop(driver);
    drop(server);
}

/// Issue 46: the token dialog closed with Escape leaves a Sign in that opens it again; an empty
/// or a wrong token is refused with the service's own reason (its 401 body), the right one signs
/// in; *Change token* closed with Escape keeps the token the page had.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_token_dialog_can_always_be_opened_again_and_says_why_a_token_is_refused() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        mut page,
    } = Session::open().await;
    let base = api.base.clone();
    const ESCAPE: &str = "\u{e00c}";
    page.c
        .goto(&format!("{base}/"))
        .await
        .expect("open the page");
    page.wait_for("#token-dialog[open]").await;
    page.wait_for("#token-input")
        .await
        .send_keys(ESCAPE)
        .await
        .expect("Escape");
    page.wait_for("#token-dialog:not([open])").await;
    page.wait_for("#signed-in[data-role='']").await;
    page.click("#sign-in:not([hidden])").await;
    page.wait_for("#token-dialog[open]").await;

    // What the service says to a request without a token, and with a wrong one.
    let (status, refused) = api.answer("/v1/whoami", None).await;
    assert_eq!(status, 401);
    let without = refused["error"]["message"]
        .as_str()
        .expect("message")
        .to_string();
    let (status, refused) = api.answer("/v1/whoami", Some("not-the-token")).await;
    assert_eq!(status, 401);
    let wrong = refused["error"]["message"]
        .as_str()
        .expect("message")
        .to_string();

    page.click("#token-submit").await;
    let said = page
        .wait_for("#token-error:not([hidden])[data-code=unauthorized]")
        .await
        .text()
        .await
        .expect("text");
    assert!(said.contains(&without), "an empty token: {said:?}");
    page.js("document.getElementById('token-error').hidden = true;")
        .await;
    page.fill("#token-input", "not-the-token").await;
    page.click("#token-submit").await;
    let said = page
        .wait_for("#token-error:not([hidden])")
        .await
        .text()
        .await
        .expect("text");
    assert!(said.contains(&wrong), "a wrong token: {said:?}");
    page.wait_for("#token-dialog[open]").await;
    page.fill("#token-input", TOKEN).await;
    page.click("#token-submit").await;
    page.wait_for("#signed-in[data-role=admin]").await;
    page.wait_for("#sign-in[hidden]").await;
    page.wait_for("#new-cell-name:not([disabled])").await;

    // Change token, then Escape: still signed in as before, and the page still works.
    page.click("#sign-out").await;
    page.wait_for("#token-dialog[open]").await;
    page.wait_for("#token-input")
        .await
        .send_keys(ESCAPE)
        .await
        .expect("Escape");
    page.wait_for("#token-dialog:not([open])").await;
    page.wait_for("#signed-in[data-role=admin]").await;
    page.fill("#new-cell-name", "after escape").await;
    page.click("#create-cell").await;
    page.wait_for("#cell-select option:checked").await;
    let cells = api.get("/v1/cells").await;
    assert_eq!(cells[0]["name"], "after escape", "{cells}");

    page.set_aside("status of 401").await;
    page.close().await;
    drop(driver);
    drop(server);
}

/// Issue 46: an error in the header is cleared by the next action that succeeds (a jog beyond
/// the arm's reach, then a Record).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_error_is_cleared_by_the_next_action_that_succeeds() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        page,
    } = Session::open().await;
    let base = api.base.clone();
    let t = teach_a_seam(&api, "abb_irb140").await;
    page.open_signed_in(&base, TOKEN).await;
    page.wait_for("#record:not([disabled])").await;
    page.select("#jog-frame", "work").await;
    page.fill("#jog-step", "5000").await;
    page.click("[data-jog=\"x+\"]").await;
    let said = page
        .wait_for("#status[data-level=error]")
        .await
        .text()
        .await
        .expect("status");
    assert!(said.contains("cannot jog"), "{said:?}");
    page.record().await;
    assert_eq!(api.waypoints(t.routine).await.len(), 2);
    let (level, text) = page.status().await;
    assert_ne!(
        level, "error",
        "the jog's error is still shown after a Record: {text:?}"
    );

    page.close().await;
    drop(driver);
    drop(server);
}

/// Issue 46: names of 200 characters (the most the service takes) for the cell, the program,
/// the routine and a waypoint never widen the page, at a desktop's size or a pendant's
/// 800×600: the pickers and the list cut them, and their titles hold them whole.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn long_names_never_break_the_layout() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        page,
    } = Session::open().await;
    let base = api.base.clone();
    let t = teach_a_seam(&api, "abb_irb140").await;
    let long = |c: &str| format!("{c}{}", "W".repeat(199));
    api.patch(
        &format!("/v1/cells/{}", t.cell),
        json!({ "name": long("C") }),
    )
    .await;
    api.patch(
        &format!("/v1/programs/{}", t.program),
        json!({ "name": long("P") }),
    )
    .await;
    api.patch(
        &format!("/v1/routines/{}", t.routine),
        json!({ "name": long("R") }),
    )
    .await;
    let w = api.waypoints(t.routine).await;
    api.patch(
        &format!("/v1/waypoints/{}", w[0]["id"]),
        json!({ "name": long("N") }),
    )
    .await;
    page.open_signed_in(&base, TOKEN).await;
    page.wait_for("#waypoints li").await;
    page.wait_for("#record:not([disabled])").await;
    for (width, height) in [(1280, 800), (800, 600)] {
        page.c.set_window_size(width, height).await.expect("resize");
        let wide = page
            .js(
                "const d = document.documentElement; \
                 const out = [...document.querySelectorAll('header *, #waypoints li, aside *, footer *')] \
                   .filter((e) => e.getBoundingClientRect().right > window.innerWidth + 0.5) \
                   .map((e) => e.id || e.tagName); \
                 return [d.scrollWidth, d.clientWidth, document.body.scrollWidth, out];",
            )
            .await;
        assert!(
            wide[0].as_i64() <= wide[1].as_i64() && wide[2].as_i64() <= wide[1].as_i64(),
            "at {width}×{height} the page is wider than the window: {wide}"
        );
        assert_eq!(
            wide[3],
            json!([]),
            "at {width}×{height} beyond the right edge"
        );
        page.screenshot(&format!("pendant-long-names-{width}.png"))
            .await;
    }
    for (select, name) in [("#cell-select", long("C")), ("#program-select", long("P"))] {
        assert_eq!(
            page.attr(select, "title").await.as_deref(),
            Some(name.as_str()),
            "{select}'s title is the whole name"
        );
    }
    let routine_title = page
        .attr("#routine-select", "title")
        .await
        .unwrap_or_default();
    assert!(routine_title.contains(&long("R")), "{routine_title:?}");
    let listed = page
        .attr("#waypoints li .name", "title")
        .await
        .unwrap_or_default();
    assert!(listed.contains(&long("N")), "{listed:?}");

    page.close().await;
    drop(driver);
    drop(server);
}

/// Issue 46: renaming a waypoint to nothing clears its name (the API's `null`) and says so;
/// a name is set as given.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_empty_name_clears_a_waypoints_name_and_says_so() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        page,
    } = Session::open().await;
    let base = api.base.clone();
    let t = teach_a_seam(&api, "abb_irb140").await;
    let id = api.waypoints(t.routine).await[0]["id"]
        .as_i64()
        .expect("id");
    api.patch(&format!("/v1/waypoints/{id}"), json!({ "name": "corner" }))
        .await;
    page.open_signed_in(&base, TOKEN).await;
    page.wait_for("#waypoints li").await;
    page.wait_for("#record:not([disabled])").await;

    page.click("#waypoints li").await;
    page.wait_for("#waypoints li[aria-selected=true]").await;
    let rename = |to: &'static str| {
        let page = &page;
        async move {
            page.click("#wp-rename").await;
            eventually("the name prompt", || async {
                page.c.get_alert_text().await.ok()
            })
            .await;
            page.c.send_alert_text(to).await.expect("type the name");
            page.c.accept_alert().await.expect("accept the prompt");
        }
    };
    rename("").await;
    let said = page
        .wait_until(
            Locator::XPath("//*[@id='status' and contains(text(), 'cleared')]"),
            "the status saying the name is cleared",
        )
        .await
        .text()
        .await
        .expect("status");
    assert!(said.contains("waypoint 1"), "{said:?}");
    let stored = api.waypoints(t.routine).await;
    assert_eq!(stored[0]["name"], Value::Null, "{}", stored[0]);
    page.wait_until(
        Locator::XPath("//*[@id='waypoints']/li[1]/span[normalize-space(text())='1. p1']"),
        "the list showing no name",
    )
    .await;

    rename("start").await;
    eventually("the name to be stored", || async {
        (api.waypoints(t.routine).await[0]["name"] == "start").then_some(())
    })
    .await;

    page.close().await;
    drop(driver);
    drop(server);
}

/// The numbers an export writes for the one waypoint of a program: `[x, y, z]` and the
/// orientation as the language writes it (RAPID q1..q4, KRL A B C, FANUC W P R).
async fn exported(api: &Api, program: i64, format: &str) -> Vec<(String, f64)> {
    let e = api
        .get(&format!("/v1/programs/{program}/export?format={format}"))
        .await;
    let text: String = e["files"]
        .as_array()
        .expect("files")
        .iter()
        .map(|f| f["text"].as_str().expect("text").to_string())
        .collect::<Vec<_>>()
        .join("\n");
    let number = |s: &str| -> f64 {
        s.trim()
            .parse()
            .unwrap_or_else(|e| panic!("{s:?} in the {format} export: {e}\n{text}"))
    };
    let named = |names: [&str; 6], values: Vec<f64>| {
        names
            .iter()
            .map(|n| n.to_string())
            .zip(values)
            .collect::<Vec<_>>()
    };
    match format {
        "rapid" => {
            let at = text.find("[[").expect("a robtarget") + 2;
            let parts: Vec<&str> = text[at..].splitn(3, "],[").collect();
            let mut v: Vec<f64> = parts[0].split(',').map(number).collect();
            v.extend(parts[1].split(',').map(number));
            assert_eq!(v.len(), 7, "{text}");
            ["x", "y", "z", "q1", "q2", "q3", "q4"]
                .iter()
                .map(|n| n.to_string())
                .zip(v)
                .collect()
        }
        "krl" => {
            let at = text.find("{X ").expect("an E6POS") + 1;
            let body = &text[at..at + text[at..].find('}').expect("}")];
            let field = |k: &str| {
                body.split(',')
                    .find_map(|f| f.trim().strip_prefix(&format!("{k} ")))
                    .map(number)
                    .unwrap_or_else(|| panic!("{k} in {body}"))
            };
            named(
                ["x", "y", "z", "A", "B", "C"],
                ["X", "Y", "Z", "A", "B", "C"].map(field).to_vec(),
            )
        }
        "fanuc" => {
            let at = text.find("GP1:").expect("a position");
            let body = &text[at..];
            let field = |k: &str| {
                let from = body.find(&format!("{k} =")).expect(k) + k.len() + 2;
                number(body[from..].split_whitespace().next().expect("a value"))
            };
            named(
                ["x", "y", "z", "W", "P", "R"],
                ["X", "Y", "Z", "W", "P", "R"].map(field).to_vec(),
            )
        }
        other => panic!("no format {other}"),
    }
}

/// Half a unit of the last decimal each exporter prints (src/export/mod.rs), and a little more
/// for the page's own rounding of the same number.
fn printed(name: &str, format: &str) -> f64 {
    let decimals = match (name, format) {
        ("x" | "y" | "z", _) => 3,
        (_, "rapid") => 8,
        (_, "krl") => 4,
        _ => 3,
    };
    0.5 * 10f64.powi(-decimals) + 1e-9
}

/// `[[name, value], …]` as the page gives a pose in numbers.
fn pairs(v: &Value) -> Vec<(String, f64)> {
    v.as_array()
        .unwrap_or_else(|| panic!("pairs: {v}"))
        .iter()
        .map(|p| {
            (
                p[0].as_str().expect("name").to_string(),
                p[1].as_f64().expect("value"),
            )
        })
        .collect()
}

fn same_numbers(shown: &[(String, f64)], want: &[(String, f64)], format: &str, what: &str) {
    assert_eq!(
        shown.iter().map(|(n, _)| n).collect::<Vec<_>>(),
        want.iter().map(|(n, _)| n).collect::<Vec<_>>(),
        "{what}: the names"
    );
    for ((n, a), (_, b)) in shown.iter().zip(want) {
        assert!(
            (a - b).abs() <= printed(n, format),
            "{what}: {n} is {a} on the page, {b} in the {format} export"
        );
    }
}

/// Issue 46: the page shows the TCP pose and the suggestion in numbers, the orientation as the
/// cell's program language writes it (the arm's controller's: RAPID q1..q4, KRL A B C, FANUC
/// W P R in degrees; an arm without one, URScript here: the quaternion). The conversion in
/// js/pose.js is checked in the browser against the exporters' numbers for one pose (given to
/// the page with the quaternion's other sign), and the TCP shown on each cell's page against
/// the export of a waypoint recorded there.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn poses_are_shown_in_numbers_as_the_cells_language_writes_them() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        page,
    } = Session::open().await;
    let base = api.base.clone();
    // One pose, turned about all three axes: Rz(30°)·Ry(20°)·Rx(10°).
    let half = |deg: f64| deg.to_radians() / 2.0;
    let mul = |a: [f64; 4], b: [f64; 4]| {
        [
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        ]
    };
    let q = mul(
        mul(
            [half(30.0).cos(), 0.0, 0.0, half(30.0).sin()],
            [half(20.0).cos(), 0.0, half(20.0).sin(), 0.0],
        ),
        [half(10.0).cos(), half(10.0).sin(), 0.0, 0.0],
    );
    let new_cell = |name: &'static str, robot: &'static str| {
        let api = &api;
        async move {
            let cell = api
                .post(
                    "/v1/cells",
                    json!({ "name": name, "settings": { "robot": robot } }),
                )
                .await["id"]
                .as_i64()
                .expect("cell id");
            let program = api
                .post(
                    &format!("/v1/cells/{cell}/programs"),
                    json!({ "name": name }),
                )
                .await["id"]
                .as_i64()
                .expect("program id");
            let routine = api
                .post(&format!("/v1/programs/{program}/routines"), json!({}))
                .await["id"]
                .as_i64()
                .expect("routine id");
            (cell, program, routine)
        }
    };
    let (_, numbers, routine) = new_cell("numbers", "abb_irb140").await;
    api.post(
        &format!("/v1/routines/{routine}/waypoints"),
        json!({ "pose": { "x": 412.5, "y": -133.25, "z": 506.75,
                          "qw": q[0], "qx": q[1], "qy": q[2], "qz": q[3] } }),
    )
    .await;
    api.post(&format!("/v1/routines/{routine}/finish"), json!({}))
        .await;
    let mut cells = Vec::new();
    for (name, robot, language) in [
        ("rapid cell", "abb_irb140", "rapid"),
        ("krl cell", "kuka_kr6_r900", "krl"),
        ("fanuc cell", "fanuc_lrmate200id", "fanuc"),
    ] {
        let (cell, program, routine) = new_cell(name, robot).await;
        cells.push((cell, program, routine, language));
    }
    let (ur_cell, _, _) = new_cell("ur cell", "ur5e").await;
    let t = teach_a_seam(&api, "abb_irb140").await;
    page.open_signed_in(&base, TOKEN).await;

    // js/pose.js against the exporters, for the pose given with its quaternion's other sign.
    let other_sign = json!({ "x": 412.5, "y": -133.25, "z": 506.75,
                              "qw": -q[0], "qx": -q[1], "qy": -q[2], "qz": -q[3] });
    for language in ["rapid", "krl", "fanuc"] {
        let shown = page
            .c
            .execute_async(
                "const [pose, language, done] = arguments; \
                 import('/pendant/js/pose.js') \
                   .then((m) => { const n = m.inNumbers(pose, language); \
                                  done([...n.position, ...n.orientation]); }) \
                   .catch((e) => done(String(e)));",
                vec![other_sign.clone(), json!(language)],
            )
            .await
            .expect("pose.js");
        let want = exported(&api, numbers, language).await;
        same_numbers(&pairs(&shown), &want, language, "js/pose.js");
    }

    // The suggestion on offer in the seam cell (RAPID), in numbers.
    page.wait_for("#suggestion[data-state=offered]").await;
    let offered = api
        .get(&format!("/v1/routines/{}/prediction", t.routine))
        .await["predictions"][0]["pose"]
        .clone();
    let shown = page
        .wait_for("#suggestion-pose[data-notation=rapid]")
        .await
        .attr("data-pose")
        .await
        .expect("attr")
        .expect("the suggestion's pose");
    let shown = pairs(&serde_json::from_str(&shown).expect("json"));
    let p = position(&offered);
    let want: Vec<(String, f64)> = [
        ("x", p[0]),
        ("y", p[1]),
        ("z", p[2]),
        ("q1", offered["qw"].as_f64().expect("qw")),
        ("q2", offered["qx"].as_f64().expect("qx")),
        ("q3", offered["qy"].as_f64().expect("qy")),
        ("q4", offered["qz"].as_f64().expect("qz")),
    ]
    .iter()
    .map(|(n, v)| (n.to_string(), *v))
    .collect();
    same_numbers(&shown, &want, "rapid", "the suggestion");
    let text = page.text("#suggestion-pose").await;
    assert!(
        text.contains("mm") && text.contains("q1") && text.contains("q4"),
        "{text:?}"
    );

    // Each cell's TCP, turned off its axes, recorded, and the export of that waypoint.
    for (cell, program, routine, language) in cells {
        page.select("#cell-select", &cell.to_string()).await;
        page.wait_for(&format!("#tcp-pose[data-notation={language}]"))
            .await;
        page.wait_for("#record:not([disabled])").await;
        page.jog("rx+", 1).await;
        page.jog("ry+", 1).await;
        page.record().await;
        assert_eq!(api.waypoints(routine).await.len(), 1);
        let shown = page
            .attr("#tcp-pose", "data-pose")
            .await
            .expect("the TCP's pose");
        let shown = pairs(&serde_json::from_str(&shown).expect("json"));
        let want = exported(&api, program, language).await;
        same_numbers(&shown, &want, language, "the TCP");
        let text = page.text("#tcp-pose").await;
        for (name, _) in &want[3..] {
            assert!(text.contains(&format!("{name} ")), "{name} in {text:?}");
        }
        page.screenshot(&format!("pendant-numbers-{language}.png"))
            .await;
    }
    // An arm whose language writes no orientation the page knows: the quaternion.
    page.select("#cell-select", &ur_cell.to_string()).await;
    page.wait_for("#tcp-pose[data-notation=quaternion]").await;

    page.close().await;
    drop(driver);
    drop(server);
}

/// Issue 46: the program's history on the page. An operator sees the revisions but may not
/// restore (the control is off, its title names the engineer role); an engineer re-teaches a
/// waypoint, sees the revision (who, what), compares the one before it with now (moved mm,
/// turned degrees, as the service's diff says), restores it, and the service's program is as
/// it was.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_engineer_sees_a_revision_and_its_diff_and_restores_it() {
    let Session {
        _dir,
        server,
        api,
        driver,
        _profile,
        page,
    } = Session::open().await;
    let base = api.base.clone();
    let t = teach_a_seam(&api, "abb_irb140").await;
    let token = |name: &'static str, role: &'static str| {
        let api = &api;
        async move {
            api.post("/v1/tokens", json!({ "name": name, "role": role }))
                .await["secret"]
                .as_str()
                .expect("secret")
                .to_string()
        }
    };
    let operator = token("op-1", "operator").await;
    let engineer = token("eng-1", "engineer").await;
    let history = || {
        let api = &api;
        let path = format!("/v1/programs/{}/history", t.program);
        async move { api.get(&path).await }
    };

    // The operator: the revisions, but no restore.
    page.open_signed_in(&base, &operator).await;
    page.wait_for("#signed-in[data-role=operator]").await;
    page.click("#history summary").await;
    page.click("#revisions li").await;
    page.wait_for("#revisions li[aria-selected=true]").await;
    page.wait_for("#diff[data-revision]:not([data-revision=''])")
        .await;
    let c = page.controls(&["history-restore"]).await;
    assert!(c[0].1, "Restore is off for an operator");
    assert!(c[0].2.contains("needs the engineer role"), "{:?}", c[0].2);

    // The engineer re-teaches the routine's first waypoint 20 mm further in x.
    page.click("#sign-out").await;
    page.wait_for("#token-dialog[open]").await;
    page.fill("#token-input", &engineer).await;
    page.click("#token-submit").await;
    page.wait_for("#signed-in[data-role=engineer]").await;
    page.wait_for("#record:not([disabled])").await;
    let before = api.waypoints(t.routine).await;
    let was = history().await["revision"].as_i64().expect("revision");
    page.select("#jog-frame", "work").await;
    page.fill("#jog-step", "20").await;
    page.jog("x+", 1).await;
    page.click("#waypoints li").await;
    page.wait_for("#waypoints li[aria-selected=true]").await;
    page.click("#wp-reteach").await;
    eventually("the re-taught waypoint to be stored", || async {
        let now = api.waypoints(t.routine).await;
        (now[0]["pose"] != before[0]["pose"]).then_some(())
    })
    .await;
    let moved = position(&api.waypoints(t.routine).await[0]["pose"]);
    let from = position(&before[0]["pose"]);
    assert!(
        close(moved, [from[0] + 20.0, from[1], from[2]]),
        "{moved:?}"
    );

    // The revision: who, and what changed (the history is still open: the page loaded again
    // for the new token without a reload).
    page.wait_for("#history[open]").await;
    let newest = page
        .wait_for(&format!("#revisions li[data-revision='{}']", was + 1))
        .await
        .text()
        .await
        .expect("text");
    assert!(
        newest.contains("eng-1") && newest.contains("waypoint") && newest.contains("changed"),
        "{newest:?}"
    );
    // The revision before it against now, as the service's diff says.
    let diff = api
        .get(&format!("/v1/programs/{}/diff?from={was}", t.program))
        .await;
    let changed = &diff["waypoints_changed"][0];
    let (mm, deg) = (
        changed["moved_mm"].as_f64().expect("moved_mm"),
        changed["turned_degrees"].as_f64().expect("turned_degrees"),
    );
    assert!((mm - 20.0).abs() < 1e-6, "{diff}");
    page.click(&format!("#revisions li[data-revision='{was}']"))
        .await;
    let shown = page
        .wait_for(&format!("#diff[data-revision='{was}'] li"))
        .await
        .text()
        .await
        .expect("text");
    assert!(
        shown.contains(&format!("moved {mm:.1} mm"))
            && shown.contains(&format!("turned {deg:.1}°")),
        "{shown:?}"
    );
    page.screenshot("pendant-history.png").await;

    // Restore: the program is as it was.
    page.click("#history-restore").await;
    page.wait_until(
        Locator::XPath("//*[@id='status' and contains(text(), 'restored')]"),
        "the restore's status",
    )
    .await;
    let after = api.waypoints(t.routine).await;
    assert_eq!(after.len(), before.len());
    for (a, b) in after.iter().zip(&before) {
        assert_eq!(a["pose"], b["pose"]);
        assert_eq!(a["id"], b["id"]);
    }
    let h = history().await;
    assert_eq!(h["revision"], was + 2, "{h}");
    assert_eq!(h["revisions"][0]["token"], "eng-1");
    page.wait_for(&format!("#revisions li[data-revision='{}']", was + 2))
        .await;

    page.close().await;
    drop(driver);
    drop(server);
}
