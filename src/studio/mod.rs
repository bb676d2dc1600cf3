//! `keypose studio`: the local web server and the embedded page, a second front end to the
//! teaching state machine of [`crate::teach`]; it knows nothing about protocol details.
//! [`Studio::listen`] then [`Studio::run`] is all a caller needs.
//!
//! - [`engine`]: the teaching loop on the main thread, fed keys by the page, publishing
//!   snapshots of the state;
//! - `server`: the sockets, every client bounded before its token is checked (connections,
//!   request size and time), a fault in any of its threads braking the arm; `http`: one
//!   request read within those limits ([`read_request`]), one answer written; `routes`: what
//!   each request gets ([`route`]: the page, `/api/…` JSON and the event stream), guarded by
//!   `auth` (token, Host, Origin: [`Guard`]) and `control` (one page controls, the others
//!   watch: [`Lease`]);
//! - `robot_model` (the chain and the simulation model's shapes), `meshes` (the built-in
//!   robots' official meshes, placed on their joints) and `timeline` (curves,
//!   keys, limits and check findings) for the page's 3D view and timeline;
//! - `assets`: the page's files, compiled in.
//!
//! The server's pieces are the crate's own; [`read_request`], [`route`] and what they take
//! are public only for the fuzz target that reads and routes requests as a connection's
//! thread does (`fuzz/fuzz_targets/studio_http.rs`), and [`Lease::claim`] for the engine's
//! tests (a page taking control).

mod assets;
mod auth;
mod control;
pub mod engine;
mod http;
mod meshes;
mod robot_model;
mod routes;
mod server;
mod snapshot;
mod timeline;

pub use auth::Guard;
pub use control::{ControlRefusal, Lease};
pub use http::{read_request, HttpError, Limits, Request, Response};
pub use routes::{route, Context, Reply};

use std::net::{SocketAddr, TcpListener};
use std::sync::Arc;
use std::time::Duration;

/// How long a request may take to arrive whole, in milliseconds, instead of
/// [`Limits::default`]'s 10 s (the tests shorten it to see a slow client cut off, or
/// lengthen it to hold idle connections).
pub const READ_TIMEOUT_VAR: &str = "KEYPOSE_STUDIO_READ_TIMEOUT_MS";
/// `handler` or `accept`: the tests' server fault (`POST /api/fault` panics in the request's
/// thread, or the thread that accepts connections panics at its next connection).
pub const TEST_FAULT_VAR: &str = "KEYPOSE_STUDIO_TEST_FAULT";

/// Plays a sequence in simulation for the page (`POST /api/simulate`): the verdict and the
/// trace as JSON, or why it could not run (the page is told the error and its causes). Given
/// by the binary, which owns `keypose sim`.
pub type Simulator = Box<
    dyn Fn(
            &crate::sequence::Sequence,
            &crate::robot::Robot,
        ) -> Result<serde_json::Value, Box<dyn std::error::Error + Send + Sync>>
        + Send
        + Sync,
>;

/// The studio's server, listening; [`Studio::run`] then drives the session.
pub struct Studio {
    listener: TcpListener,
    addr: SocketAddr,
    limits: http::Limits,
    test_fault: Option<routes::TestFault>,
    guard: auth::Guard,
    inputs: std::sync::mpsc::Sender<engine::Input>,
    received: std::sync::mpsc::Receiver<engine::Input>,
}

/// Why the studio did not start.
#[derive(Debug, thiserror::Error)]
pub enum StudioError {
    /// The address cannot be listened on.
    #[error("cannot listen on {addr}: {message}")]
    Listen {
        /// The address asked for.
        addr: String,
        /// Why not.
        message: String,
    },
    /// The system gave no random bytes for the page's token.
    #[error("cannot make an access token: {0}")]
    Token(std::io::Error),
    /// A setting from the environment that does not parse.
    #[error("{name}={value:?}: expected {expected}")]
    Setting {
        /// The variable's name.
        name: &'static str,
        /// Its value.
        value: String,
        /// What it should be.
        expected: &'static str,
    },
    /// The session ended early.
    #[error(transparent)]
    Teach(#[from] crate::teach::TeachError),
}

impl Studio {
    /// Listens on `addr` (port 0: a free one) with a fresh token.
    pub fn listen(addr: SocketAddr) -> Result<Studio, StudioError> {
        let listen_error = |message: String| StudioError::Listen {
            addr: addr.to_string(),
            message,
        };
        if addr.ip().is_unspecified() {
            // Every request's Host must name the server, and "any address" names none.
            return Err(listen_error(
                "give the address of one interface (such as 192.168.1.5:8080), not \
                 0.0.0.0 or ::, so that requests can be checked against it"
                    .into(),
            ));
        }
        let (limits, test_fault) = (limits_from_env()?, test_fault_from_env()?);
        let listener = TcpListener::bind(addr).map_err(|e| listen_error(e.to_string()))?;
        let bound = listener
            .local_addr()
            .map_err(|e| listen_error(e.to_string()))?;
        let guard = auth::Guard::new(auth::new_token().map_err(StudioError::Token)?, bound);
        // Ctrl-C is the studio's from now on (before the URL is printed, so that whoever
        // reads it can stop the studio): it waits in the channel until the engine runs.
        let (inputs, received) = std::sync::mpsc::channel();
        let interrupts = inputs.clone();
        crate::stop::on_signal(move || {
            let _ = interrupts.send(engine::Input::Interrupt);
        });
        Ok(Studio {
            listener,
            addr: bound,
            limits,
            test_fault,
            guard,
            inputs,
            received,
        })
    }

    /// The page's URL, token included.
    pub fn url(&self) -> String {
        self.guard.url()
    }

    /// The address the studio listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Serves the page and runs the session until the page quits it or Ctrl-C ends it (a
    /// moving arm is stopped the soft way first; it holds where it stopped).
    pub fn run(
        self,
        state: &mut crate::teach::TeachState,
        session: &mut crate::teach::Session,
        simulator: Option<Simulator>,
    ) -> Result<engine::Ended, StudioError> {
        let hub = Arc::new(engine::Hub::default());
        // From now on Ctrl-C (SIGTERM, SIGHUP) brakes the arm at once, on the handler's thread,
        // and then asks the engine to end the session.
        let (brake, interrupts) = (session.brake(), self.inputs.clone());
        crate::stop::on_signal(move || {
            brake.soft_stop();
            let _ = interrupts.send(engine::Input::Interrupt);
        });
        let mut context =
            routes::Context::new(self.guard, hub.clone(), self.inputs, state.robot().clone());
        context.simulator = simulator;
        context.brake = session.brake();
        context.test_fault = self.test_fault;
        // The first snapshot before the first request is served: requests that arrive as soon
        // as the URL is printed wait in the listening socket until then.
        hub.publish(state, session.describe());
        server::spawn(self.listener, context, self.limits);
        Ok(engine::run(state, session, &hub, self.received)?)
    }
}

/// The request limits, with [`READ_TIMEOUT_VAR`]'s time when it is set.
fn limits_from_env() -> Result<http::Limits, StudioError> {
    let mut limits = http::Limits::default();
    if let Ok(value) = std::env::var(READ_TIMEOUT_VAR) {
        let ms = value.parse::<u64>().ok().filter(|&ms| ms > 0);
        limits.time = Duration::from_millis(ms.ok_or(StudioError::Setting {
            name: READ_TIMEOUT_VAR,
            value,
            expected: "a whole number of milliseconds above 0",
        })?);
    }
    Ok(limits)
}

fn test_fault_from_env() -> Result<Option<routes::TestFault>, StudioError> {
    match std::env::var(TEST_FAULT_VAR) {
        Err(_) => Ok(None),
        Ok(value) => match value.as_str() {
            "handler" => Ok(Some(routes::TestFault::Handler)),
            "accept" => Ok(Some(routes::TestFault::Accept)),
            _ => Err(StudioError::Setting {
                name: TEST_FAULT_VAR,
                value,
                expected: "handler or accept",
            }),
        },
    }
}
