//! What each request gets, once [`super::http`] has read it whole: every request passes
//! [`Guard`]'s Host and Origin checks; the page and `/api/` also need the token. Handlers only
//! read the published snapshot or hand an action to the engine: no rule of the session is
//! here. Nothing here touches a socket either (the event stream writes to whatever it is
//! given), so the fuzzer drives [`route`] with parsed bytes.

use super::assets;
use super::auth::{Credentials, Guard, Refusal, TOKEN_HEADER};
use super::control::ControlRefusal;
use super::engine::{self, Action, Hub, Input, News};
use super::http::{Method, Request, Response};
use crate::robot::Robot;
use crate::teach::Brake;
use serde::Deserialize;
use serde_json::{json, Value};
use std::io::Write;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// The header the page sends its client id in (for control).
pub(crate) const CLIENT_HEADER: &str = "X-Keypose-Client";
/// Event streams open at once; more are refused (each holds a connection and a thread).
pub(crate) const MAX_STREAMS: usize = 16;
/// How long a stream stays silent before a comment line checks the connection.
const KEEPALIVE: Duration = Duration::from_secs(1);
/// How long a request waits for the engine to carry out its action.
const ACTION_TIMEOUT: Duration = Duration::from_secs(10);

/// A server fault the tests can cause (`KEYPOSE_STUDIO_TEST_FAULT`): `POST /api/fault` with
/// the token panics in the request's thread, or makes the thread that accepts connections
/// panic at its next connection. Without it there is no such route.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum TestFault {
    Handler,
    Accept,
}

/// What the request handlers share: the guard, the hub shared with the engine, the channel
/// to it, the robot.
pub struct Context {
    pub(crate) guard: Guard,
    /// What the engine publishes, and the lease of control.
    pub hub: Arc<Hub>,
    pub(crate) inputs: Sender<Input>,
    /// Brakes the moving arm from the request's own thread: a Stop never waits for the
    /// engine.
    pub(crate) brake: Brake,
    pub(crate) robot: Robot,
    /// `GET /api/robot`, built once.
    pub(crate) robot_model: String,
    /// `POST /api/simulate`, when the binary gives one; one run at a time.
    pub(crate) simulator: Option<super::Simulator>,
    pub(crate) test_fault: Option<TestFault>,
    /// Set by `/api/fault` under [`TestFault::Accept`]; the accept loop panics when it sees it.
    pub(crate) accept_fault_armed: AtomicBool,
    simulating: std::sync::Mutex<()>,
    streams: Arc<AtomicUsize>,
}

impl Context {
    /// The handlers' context of a studio on `robot`: `guard` admits requests, `hub` is shared
    /// with the engine, `inputs` reaches it; no simulator, no test fault.
    pub fn new(guard: Guard, hub: Arc<Hub>, inputs: Sender<Input>, robot: Robot) -> Context {
        let robot_model = super::robot_model::model(&robot).to_string();
        Context {
            guard,
            hub,
            inputs,
            brake: Brake::default(),
            robot,
            robot_model,
            simulator: None,
            test_fault: None,
            accept_fault_armed: AtomicBool::new(false),
            simulating: std::sync::Mutex::new(()),
            streams: Arc::new(AtomicUsize::new(0)),
        }
    }

    /// A fault of the server (a panic in one of its threads): the arm is braked here and now,
    /// and the engine ends the session once it is at rest. Nothing a page does can reach the
    /// arm once its server is broken, so the arm must not go on moving.
    pub(crate) fn fault(&self, what: String) {
        self.brake.soft_stop();
        let _ = self.inputs.send(Input::Fault(what));
    }
}

/// What a request gets: an answer, or the event stream (which needs the connection).
pub enum Reply {
    /// An answer to write, and the connection closes.
    Answer(Response),
    /// The event stream the page asked for (admitted): the snapshots follow on the
    /// connection.
    Events(EventStream),
}

/// An admitted event stream, counted among [`MAX_STREAMS`] until dropped.
pub struct EventStream {
    client: Option<String>,
    open: Arc<AtomicUsize>,
}

impl Drop for EventStream {
    fn drop(&mut self) {
        self.open.fetch_sub(1, Ordering::SeqCst);
    }
}

/// The request's credentials and client id, checked, then its handler.
pub fn route(request: &Request, context: &Context) -> Reply {
    let path = request.path();
    let credentials = Credentials {
        host: request.header("Host"),
        origin: request.header("Origin"),
        token: request
            .header(TOKEN_HEADER)
            .or_else(|| request.param("token")),
    };
    let asset = assets::file(path);
    let access = match asset {
        Some(_) => context.guard.check_origin(&credentials),
        None => context.guard.check(&credentials),
    };
    if let Err(refusal) = access {
        return Reply::Answer(refused(&refusal));
    }
    if let Some((kind, bytes)) = asset {
        return Reply::Answer(bytes_response(200, kind, bytes));
    }
    let client = request
        .header(CLIENT_HEADER)
        .or_else(|| request.param("client"))
        .map(str::to_string);
    Reply::Answer(match (request.method, path) {
        (Method::Get, "/") => bytes_response(200, "text/html; charset=utf-8", assets::INDEX),
        (Method::Get, "/api/robot") => json_text(200, context.robot_model.clone()),
        (Method::Get, "/api/state") => {
            let text = context.hub.published().json.to_string();
            json_text(200, text)
        }
        (Method::Get, "/api/timeline") => {
            let sequence = context.hub.published().sequence.clone();
            let value = super::timeline::timeline(sequence.as_ref(), &context.robot);
            json_response(200, &value)
        }
        (Method::Get, "/api/events") => return events(context, client),
        (Method::Post, "/api/control") => control(context, client),
        (Method::Post, "/api/release") => {
            if let Some(client) = &client {
                // The page is closing: as good as a lost connection (playback stops).
                context.hub.lease().release(client, true);
            }
            json_response(200, &json!({"released": true}))
        }
        (Method::Post, "/api/key") => key(request, context, client),
        (Method::Post, "/api/simulate") => simulate(context, client),
        (Method::Post, "/api/fault") if context.test_fault.is_some() => test_fault(context),
        _ => json_response(404, &json!({"error": format!("no route {path}")})),
    })
}

/// `POST /api/control`: take the lease, or renew it (the page's heartbeat).
fn control(context: &Context, client: Option<String>) -> Response {
    let result = context
        .hub
        .lease()
        .claim(client.as_deref().unwrap_or(""), Instant::now());
    match result {
        Ok(()) => json_response(200, &json!({"control": true})),
        Err(refusal) => control_refused(&refusal),
    }
}

/// Whether `client` controls the arm now.
fn controls(context: &Context, client: &Option<String>) -> Result<(), ControlRefusal> {
    context
        .hub
        .lease()
        .check(client.as_deref().unwrap_or(""), Instant::now())
}

/// `POST /api/key` with `{"key": TOKEN}` or `{"line": TEXT}`: one action of the controller,
/// or the Stop button of any page (the token is checked already: whoever may watch may stop).
/// A stop brakes the arm here and now, then goes to the engine, where it drops whatever keys
/// are still queued.
fn key(request: &Request, context: &Context, client: Option<String>) -> Response {
    let action = match read_body(request).and_then(|body| parse_action(&body)) {
        Ok(action) => action,
        Err(message) => return json_response(400, &json!({"error": message.to_string()})),
    };
    if action == Action::Stop {
        context.brake.soft_stop();
    } else if let Err(refusal) = controls(context, &client) {
        return control_refused(&refusal);
    }
    let (reply, answer) = std::sync::mpsc::channel();
    match context.inputs.send(Input::Action { action, reply }) {
        Err(_) => json_response(503, &json!({"error": "the session has ended"})),
        Ok(()) => match answer.recv_timeout(ACTION_TIMEOUT) {
            Ok(status) => json_response(200, &json!({"status": status})),
            Err(_) => json_response(503, &json!({"error": "the session did not answer"})),
        },
    }
}

/// `POST /api/simulate`: the list as it is now, played in MuJoCo (seconds to a minute); the
/// arm is not involved, but only the controller may start it (it takes the machine).
fn simulate(context: &Context, client: Option<String>) -> Response {
    if let Err(refusal) = controls(context, &client) {
        return control_refused(&refusal);
    }
    let Some(simulator) = &context.simulator else {
        return json_response(501, &json!({"error": "this studio cannot simulate"}));
    };
    let Ok(_running) = context.simulating.try_lock() else {
        return json_response(409, &json!({"error": "a simulation is running already"}));
    };
    let sequence = context.hub.published().sequence.clone();
    match sequence.filter(|s| !s.keyframes.is_empty()) {
        None => json_response(400, &json!({"error": "no keys to simulate: n adds one"})),
        Some(sequence) => match simulator(&sequence, &context.robot) {
            Ok(value) => json_response(200, &value),
            Err(e) => {
                let message = crate::error::Report(e.as_ref()).to_string();
                json_response(422, &json!({"error": message}))
            }
        },
    }
}

/// `POST /api/fault`, the tests' server fault (see [`TestFault`]).
fn test_fault(context: &Context) -> Response {
    match context.test_fault {
        Some(TestFault::Accept) => {
            context.accept_fault_armed.store(true, Ordering::SeqCst);
            json_response(200, &json!({"armed": "accept"}))
        }
        _ => panic!("test fault: a panic in a request's thread (KEYPOSE_STUDIO_TEST_FAULT)"),
    }
}

/// The body of `POST /api/key`, as the page sends it: `{"key": TOKEN}` or `{"line": TEXT}`
/// (a key wins when both are there; members of another type count as missing).
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
struct ActionBody {
    #[serde(deserialize_with = "string_or_none")]
    key: Option<String>,
    #[serde(deserialize_with = "string_or_none")]
    line: Option<String>,
}

fn string_or_none<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    Ok(match Value::deserialize(d)? {
        Value::String(text) => Some(text),
        _ => None,
    })
}

/// Why a request to `POST /api/key` is refused (400).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
enum BodyError {
    #[error("request body: expected UTF-8 JSON")]
    NotUtf8,
    #[error("request body: expected JSON ({0})")]
    NotJson(String),
    #[error(r#"expected {{"key": TOKEN}} or {{"line": TEXT}}"#)]
    NoAction,
    #[error(transparent)]
    Key(#[from] engine::PageKeyError),
}

fn read_body(request: &Request) -> Result<Value, BodyError> {
    let body = std::str::from_utf8(&request.body).map_err(|_| BodyError::NotUtf8)?;
    serde_json::from_str(body).map_err(|e| BodyError::NotJson(e.to_string()))
}

fn parse_action(body: &Value) -> Result<Action, BodyError> {
    match ActionBody::deserialize(body).unwrap_or_default() {
        ActionBody {
            key: Some(token), ..
        } if token == "stop" => Ok(Action::Stop),
        ActionBody {
            key: Some(token), ..
        } => Ok(Action::Key(engine::parse_key(&token)?)),
        ActionBody {
            line: Some(text), ..
        } => Ok(Action::Line(text)),
        _ => Err(BodyError::NoAction),
    }
}

/// `GET /api/events`: admitted while fewer than [`MAX_STREAMS`] are open.
fn events(context: &Context, client: Option<String>) -> Reply {
    if context.streams.fetch_add(1, Ordering::SeqCst) >= MAX_STREAMS {
        context.streams.fetch_sub(1, Ordering::SeqCst);
        let error = json!({"error": format!("more than {MAX_STREAMS} pages are open")});
        return Reply::Answer(json_response(503, &error));
    }
    Reply::Events(EventStream {
        client,
        open: context.streams.clone(),
    })
}

/// The snapshots as a server-sent event stream, until the session ends or the connection
/// breaks. The controller's stream breaking releases control (and the engine stops playback
/// softly).
pub(crate) fn stream_events(stream: EventStream, out: &mut impl Write, context: &Context) {
    let head = with_headers(Response::new(200, &b""[..]), "text/event-stream").head(None);
    let mut seen = 0;
    let mut result = out.write_all(&head).and_then(|_| out.flush());
    while result.is_ok() {
        let chunk = match context.hub.wait_news(seen, KEEPALIVE) {
            News::Snapshot(seq, json) => {
                seen = seq;
                format!("id: {seq}\ndata: {json}\n\n")
            }
            News::Quiet => ": keepalive\n\n".to_string(),
            News::Ended => {
                let _ = out.write_all(b"event: end\ndata: {}\n\n");
                let _ = out.flush();
                break;
            }
        };
        result = out.write_all(chunk.as_bytes()).and_then(|_| out.flush());
    }
    if result.is_err() {
        if let Some(client) = &stream.client {
            context.hub.lease().release(client, true);
        }
    }
}

fn refused(refusal: &Refusal) -> Response {
    json_response(403, &json!({"error": refusal.to_string()}))
}

fn control_refused(refusal: &ControlRefusal) -> Response {
    let status = match refusal {
        ControlRefusal::BadClient(_) => 400,
        _ => 409,
    };
    json_response(
        status,
        &json!({"error": refusal.to_string(), "watching": true}),
    )
}

pub(crate) fn json_response(status: u16, value: &Value) -> Response {
    json_text(status, value.to_string())
}

fn json_text(status: u16, text: String) -> Response {
    with_headers(Response::new(status, text.into_bytes()), "application/json")
}

fn bytes_response(status: u16, kind: &str, bytes: &'static [u8]) -> Response {
    with_headers(Response::new(status, bytes), kind)
}

/// The headers every answer carries: its type, no caching (the page holds a token), no
/// framing by other sites, no Referer (the page's URL holds the token until the page takes
/// it out), and a policy that runs only the studio's own scripts.
fn with_headers(response: Response, kind: &str) -> Response {
    let policy = format!(
        "default-src 'self'; script-src 'self' 'sha256-{}'; style-src 'self'; \
         img-src 'self' data: blob:; connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; \
         form-action 'none'",
        assets::IMPORTMAP_SHA256
    );
    response
        .with_header("Content-Type", kind)
        .with_header("Cache-Control", "no-store")
        .with_header("X-Content-Type-Options", "nosniff")
        .with_header("X-Frame-Options", "DENY")
        .with_header("Referrer-Policy", "no-referrer")
        .with_header("Content-Security-Policy", policy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::teach::Key;

    #[test]
    fn a_body_is_a_key_a_line_or_the_stop_button() {
        assert_eq!(
            parse_action(&json!({"key": "u"})),
            Ok(Action::Key(Key::Char('u')))
        );
        assert_eq!(parse_action(&json!({"key": "stop"})), Ok(Action::Stop));
        assert_eq!(
            parse_action(&json!({"line": "wave"})),
            Ok(Action::Line("wave".into()))
        );
        assert!(parse_action(&json!({"key": "write:/tmp/x.json"})).is_err());
        assert!(parse_action(&json!({"keys": "u"})).is_err());
    }
}
