//! The HTTP side: one thread accepts, one thread per request answers (an event stream keeps
//! its thread while the page is open). Every request passes [`Guard`]'s Host and Origin
//! checks; the page and `/api/` also need the token. Handlers only read the published
//! snapshot or hand an action to the engine: no rule of the session is here.

use super::assets;
use super::auth::{Credentials, Guard, Refusal, TOKEN_HEADER};
use super::control::ControlRefusal;
use super::engine::{self, Action, Hub, Input, News};
use crate::robot::Robot;
use crate::teach::Brake;
use serde_json::{json, Value};
use std::io::{Read, Write};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::Sender;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tiny_http::{Header, Method, Request, Response};

/// The header the page sends its client id in (for control).
pub const CLIENT_HEADER: &str = "X-Keypose-Client";
/// Largest request body: a key or a typed line is a few bytes.
const MAX_BODY: u64 = 4096;
/// Event streams open at once; more are refused (each holds a thread).
const MAX_STREAMS: usize = 16;
/// How long a stream stays silent before a comment line checks the connection.
const KEEPALIVE: Duration = Duration::from_secs(1);
/// How long a request waits for the engine to carry out its action.
const ACTION_TIMEOUT: Duration = Duration::from_secs(10);

/// What the request handlers share.
pub struct Context {
    pub guard: Guard,
    pub hub: Arc<Hub>,
    pub inputs: Sender<Input>,
    /// Brakes the moving arm from the request's own thread: a Stop never waits for the
    /// engine.
    pub brake: Brake,
    pub robot: Robot,
    /// `GET /api/robot`, built once.
    pub robot_model: String,
    /// `POST /api/simulate`, when the binary gives one; one run at a time.
    pub simulator: Option<super::Simulator>,
    simulating: std::sync::Mutex<()>,
    streams: AtomicUsize,
}

impl Context {
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
            simulating: std::sync::Mutex::new(()),
            streams: AtomicUsize::new(0),
        }
    }
}

/// Serves `http` on a thread of its own until the process ends.
pub fn spawn(http: tiny_http::Server, context: Context) {
    let context = Arc::new(context);
    std::thread::spawn(move || {
        for request in http.incoming_requests() {
            let context = context.clone();
            std::thread::spawn(move || handle(request, &context));
        }
    });
}

/// A request's header value.
fn header<'a>(request: &'a Request, name: &str) -> Option<&'a str> {
    request
        .headers()
        .iter()
        .find(|h| h.field.as_str().as_str().eq_ignore_ascii_case(name))
        .map(|h| h.value.as_str())
}

/// The path and query parameters of a URL (the page's values need no percent-decoding: hex
/// tokens and letter-digit ids; anything else simply does not match).
fn split_url(url: &str) -> (&str, Vec<(&str, &str)>) {
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    let params = query
        .split('&')
        .filter_map(|pair| pair.split_once('='))
        .collect();
    (path, params)
}

fn param<'a>(params: &[(&'a str, &'a str)], name: &str) -> Option<&'a str> {
    params.iter().find(|(k, _)| *k == name).map(|(_, v)| *v)
}

fn handle(request: Request, context: &Context) {
    let url = request.url().to_string();
    let (path, params) = split_url(&url);
    let credentials = Credentials {
        host: header(&request, "Host"),
        origin: header(&request, "Origin"),
        token: header(&request, TOKEN_HEADER).or_else(|| param(&params, "token")),
    };
    let asset = assets::file(path);
    let access = match asset {
        Some(_) => context.guard.check_origin(&credentials),
        None => context.guard.check(&credentials),
    };
    if let Err(refusal) = access {
        return respond(request, refused(&refusal));
    }
    if let Some((kind, bytes)) = asset {
        return respond(request, bytes_response(200, kind, bytes));
    }
    let client = header(&request, CLIENT_HEADER)
        .or_else(|| param(&params, "client"))
        .map(str::to_string);
    route(request, context, path, client);
}

/// A request that passed the guard, to its handler.
fn route(request: Request, context: &Context, path: &str, client: Option<String>) {
    let method = request.method().clone();
    match (method, path) {
        (Method::Get, "/") => {
            let response = bytes_response(200, "text/html; charset=utf-8", assets::INDEX);
            respond(request, response)
        }
        (Method::Get, "/api/robot") => {
            respond(request, json_text(200, context.robot_model.clone()))
        }
        (Method::Get, "/api/state") => {
            let text = context.hub.published().json.to_string();
            respond(request, json_text(200, text))
        }
        (Method::Get, "/api/timeline") => {
            let sequence = context.hub.published().sequence.clone();
            let value = super::timeline::timeline(sequence.as_ref(), &context.robot);
            respond(request, json_response(200, &value))
        }
        (Method::Get, "/api/events") => events(request, context, client),
        (Method::Post, "/api/control") => control(request, context, client),
        (Method::Post, "/api/release") => {
            if let Some(client) = &client {
                // The page is closing: as good as a lost connection (playback stops).
                context.hub.lease().release(client, true);
            }
            respond(request, json_response(200, &json!({"released": true})))
        }
        (Method::Post, "/api/key") => key(request, context, client),
        (Method::Post, "/api/simulate") => simulate(request, context, client),
        _ => respond(
            request,
            json_response(404, &json!({"error": format!("no route {path}")})),
        ),
    }
}

/// `POST /api/control`: take the lease, or renew it (the page's heartbeat).
fn control(request: Request, context: &Context, client: Option<String>) {
    let result = context
        .hub
        .lease()
        .claim(client.as_deref().unwrap_or(""), Instant::now());
    let response = match result {
        Ok(()) => json_response(200, &json!({"control": true})),
        Err(refusal) => control_refused(&refusal),
    };
    respond(request, response)
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
fn key(mut request: Request, context: &Context, client: Option<String>) {
    let action = read_body(&mut request).and_then(|body| parse_action(&body));
    let action = match action {
        Ok(action) => action,
        Err(message) => return respond(request, json_response(400, &json!({"error": message}))),
    };
    if action == Action::Stop {
        context.brake.soft_stop();
    } else if let Err(refusal) = controls(context, &client) {
        return respond(request, control_refused(&refusal));
    }
    let (reply, answer) = std::sync::mpsc::channel();
    let response = match context.inputs.send(Input::Action { action, reply }) {
        Err(_) => json_response(503, &json!({"error": "the session has ended"})),
        Ok(()) => match answer.recv_timeout(ACTION_TIMEOUT) {
            Ok(status) => json_response(200, &json!({"status": status})),
            Err(_) => json_response(503, &json!({"error": "the session did not answer"})),
        },
    };
    respond(request, response)
}

/// `POST /api/simulate`: the list as it is now, played in MuJoCo (seconds to a minute); the
/// arm is not involved, but only the controller may start it (it takes the machine).
fn simulate(request: Request, context: &Context, client: Option<String>) {
    if let Err(refusal) = controls(context, &client) {
        return respond(request, control_refused(&refusal));
    }
    let Some(simulator) = &context.simulator else {
        let error = json!({"error": "this studio cannot simulate"});
        return respond(request, json_response(501, &error));
    };
    let Ok(_running) = context.simulating.try_lock() else {
        let error = json!({"error": "a simulation is running already"});
        return respond(request, json_response(409, &error));
    };
    let sequence = context.hub.published().sequence.clone();
    let response = match sequence.filter(|s| !s.keyframes.is_empty()) {
        None => json_response(400, &json!({"error": "no keys to simulate: n adds one"})),
        Some(sequence) => match simulator(&sequence, &context.robot) {
            Ok(value) => json_response(200, &value),
            Err(message) => json_response(422, &json!({"error": message})),
        },
    };
    respond(request, response)
}

fn read_body(request: &mut Request) -> Result<Value, String> {
    let mut body = String::new();
    request
        .as_reader()
        .take(MAX_BODY + 1)
        .read_to_string(&mut body)
        .map_err(|e| format!("cannot read the request: {e}"))?;
    if body.len() as u64 > MAX_BODY {
        return Err(format!("request body over {MAX_BODY} bytes"));
    }
    serde_json::from_str(&body).map_err(|e| format!("request body: expected JSON ({e})"))
}

fn parse_action(body: &Value) -> Result<Action, String> {
    if let Some(token) = body.get("key").and_then(Value::as_str) {
        if token == "stop" {
            return Ok(Action::Stop);
        }
        return engine::parse_key(token).map(Action::Key);
    }
    if let Some(text) = body.get("line").and_then(Value::as_str) {
        return Ok(Action::Line(text.to_string()));
    }
    Err(r#"expected {"key": TOKEN} or {"line": TEXT}"#.into())
}

/// `GET /api/events`: the snapshots as a server-sent event stream. The controller's stream
/// breaking releases control (and the engine stops playback softly).
fn events(request: Request, context: &Context, client: Option<String>) {
    if context.streams.fetch_add(1, Ordering::SeqCst) >= MAX_STREAMS {
        context.streams.fetch_sub(1, Ordering::SeqCst);
        let error = json!({"error": format!("more than {MAX_STREAMS} pages are open")});
        return respond(request, json_response(503, &error));
    }
    let mut writer = request.into_writer();
    let head = "HTTP/1.1 200 OK\r\nContent-Type: text/event-stream\r\nCache-Control: no-store\r\n\
                X-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n";
    let mut seen = 0;
    let mut result = writer
        .write_all(head.as_bytes())
        .and_then(|_| writer.flush());
    while result.is_ok() {
        let chunk = match context.hub.wait_news(seen, KEEPALIVE) {
            News::Snapshot(seq, json) => {
                seen = seq;
                format!("id: {seq}\ndata: {json}\n\n")
            }
            News::Quiet => ": keepalive\n\n".to_string(),
            News::Ended => {
                let _ = writer.write_all(b"event: end\ndata: {}\n\n");
                let _ = writer.flush();
                break;
            }
        };
        result = writer
            .write_all(chunk.as_bytes())
            .and_then(|_| writer.flush());
    }
    if result.is_err() {
        if let Some(client) = &client {
            context.hub.lease().release(client, true);
        }
    }
    context.streams.fetch_sub(1, Ordering::SeqCst);
}

fn respond<R: Read>(request: Request, response: Response<R>) {
    // A page that went away mid-answer is not the server's problem.
    let _ = request.respond(response);
}

fn refused(refusal: &Refusal) -> Response<std::io::Cursor<Vec<u8>>> {
    json_response(403, &json!({"error": refusal.to_string()}))
}

fn control_refused(refusal: &ControlRefusal) -> Response<std::io::Cursor<Vec<u8>>> {
    let status = match refusal {
        ControlRefusal::BadClient(_) => 400,
        _ => 409,
    };
    json_response(
        status,
        &json!({"error": refusal.to_string(), "watching": true}),
    )
}

fn json_response(status: u16, value: &Value) -> Response<std::io::Cursor<Vec<u8>>> {
    json_text(status, value.to_string())
}

fn json_text(status: u16, text: String) -> Response<std::io::Cursor<Vec<u8>>> {
    with_headers(
        Response::from_data(text.into_bytes()).with_status_code(status),
        "application/json",
    )
}

fn bytes_response(
    status: u16,
    kind: &str,
    bytes: &'static [u8],
) -> Response<std::io::Cursor<Vec<u8>>> {
    with_headers(
        Response::from_data(bytes.to_vec()).with_status_code(status),
        kind,
    )
}

/// The headers every answer carries: its type, no caching (the page holds a token), no
/// framing by other sites, and a policy that runs only the studio's own scripts.
fn with_headers<R: Read>(response: Response<R>, kind: &str) -> Response<R> {
    let policy = format!(
        "default-src 'self'; script-src 'self' 'sha256-{}'; style-src 'self'; \
         img-src 'self' data: blob:; connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; \
         form-action 'none'",
        assets::IMPORTMAP_SHA256
    );
    let headers = [
        ("Content-Type", kind.to_string()),
        ("Cache-Control", "no-store".to_string()),
        ("X-Content-Type-Options", "nosniff".to_string()),
        ("X-Frame-Options", "DENY".to_string()),
        ("Referrer-Policy", "no-referrer".to_string()),
        ("Content-Security-Policy", policy),
    ];
    headers.into_iter().fold(response, |r, (name, value)| {
        match Header::from_bytes(name.as_bytes(), value.as_bytes()) {
            Ok(h) => r.with_header(h),
            Err(()) => r,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::teach::Key;

    #[test]
    fn urls_split_into_path_and_parameters() {
        let (path, params) = split_url("/api/events?token=ab12&client=page-1");
        assert_eq!(path, "/api/events");
        assert_eq!(param(&params, "token"), Some("ab12"));
        assert_eq!(param(&params, "client"), Some("page-1"));
        assert_eq!(param(&params, "other"), None);
        assert_eq!(split_url("/").0, "/");
    }

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
