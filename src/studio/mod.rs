//! `keypose studio`: the local web server and the embedded page, a second front end to the
//! teaching state machine of [`crate::teach`]; it knows nothing about protocol details.
//!
//! - [`engine`]: the teaching loop on the main thread, fed keys by the page, publishing
//!   [`snapshot`]s;
//! - [`server`]: the sockets, every client bounded before its token is checked (connections,
//!   request size and time), a fault in any of its threads braking the arm; [`http`]: one
//!   request read within those limits, one answer written; [`routes`]: what each request gets
//!   (the page, `/api/…` JSON and the event stream), guarded by [`auth`] (token, Host,
//!   Origin) and [`control`] (one page controls, the others watch);
//! - [`robot_model`] (the chain and the simulation model's shapes) and [`timeline`] (curves,
//!   keys, limits and check findings) for the page's 3D view and timeline;
//! - [`assets`]: the page's files, compiled in.

pub mod assets;
pub mod auth;
pub mod control;
pub mod engine;
pub mod http;
pub mod robot_model;
pub mod routes;
pub mod server;
pub mod snapshot;
pub mod timeline;

use std::net::{SocketAddr, TcpListener};
use std::sync::Arc;
use std::time::Duration;

/// How long a request may take to arrive whole, in milliseconds, instead of
/// [`http::Limits::default`]'s 10 s (the tests shorten it to see a slow client cut off, or
/// lengthen it to hold idle connections).
pub const READ_TIMEOUT_VAR: &str = "KEYPOSE_STUDIO_READ_TIMEOUT_MS";
/// `handler` or `accept`: the tests' server fault ([`routes::TestFault`]).
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
    #[error("cannot listen on {addr}: {message}")]
    Listen { addr: String, message: String },
    #[error("cannot make an access token: {0}")]
    Token(std::io::Error),
    #[error("{name}={value:?}: expected {expected}")]
    Setting {
        name: &'static str,
        value: String,
        expected: &'static str,
    },
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
