//! `keypose studio`: the local web server and the embedded page, a second front end to the
//! teaching state machine of [`crate::teach`]; it knows nothing about protocol details.
//!
//! - [`engine`]: the teaching loop on the main thread, fed keys by the page, publishing
//!   [`snapshot`]s;
//! - [`server`]: HTTP routes (the page, `/api/…` JSON and the event stream), guarded by
//!   [`auth`] (token, Host, Origin) and [`control`] (one page controls, the others watch);
//! - [`robot_model`] (the chain and the simulation model's shapes) and [`timeline`] (curves,
//!   keys, limits and check findings) for the page's 3D view and timeline;
//! - [`assets`]: the page's files, compiled in.

pub mod assets;
pub mod auth;
pub mod control;
pub mod engine;
pub mod robot_model;
pub mod server;
pub mod snapshot;
pub mod timeline;

use std::net::SocketAddr;
use std::sync::Arc;

/// Plays a sequence in simulation for the page (`POST /api/simulate`): the verdict and the
/// trace as JSON, or why it could not run. Given by the binary, which owns `keypose sim`.
pub type Simulator = Box<
    dyn Fn(&crate::sequence::Sequence, &crate::robot::Robot) -> Result<serde_json::Value, String>
        + Send
        + Sync,
>;

/// The studio's server, listening; [`Studio::run`] then drives the session.
pub struct Studio {
    http: tiny_http::Server,
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
        let http = tiny_http::Server::http(addr).map_err(|e| listen_error(e.to_string()))?;
        let bound = http
            .server_addr()
            .to_ip()
            .ok_or_else(|| listen_error("not an IP address".into()))?;
        let guard = auth::Guard::new(auth::new_token().map_err(StudioError::Token)?, bound);
        // Ctrl-C is the studio's from now on (before the URL is printed, so that whoever
        // reads it can stop the studio): it waits in the channel until the engine runs.
        let (inputs, received) = std::sync::mpsc::channel();
        let interrupts = inputs.clone();
        crate::stop::on_signal(move || {
            let _ = interrupts.send(engine::Input::Interrupt);
        });
        Ok(Studio {
            http,
            guard,
            inputs,
            received,
        })
    }

    /// The page's URL, token included.
    pub fn url(&self) -> String {
        self.guard.url()
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
            server::Context::new(self.guard, hub.clone(), self.inputs, state.robot().clone());
        context.simulator = simulator;
        context.brake = session.brake();
        // The first snapshot before the first request is served: requests that arrive as soon
        // as the URL is printed wait in the listening socket until then.
        hub.publish(state, session.describe());
        server::spawn(self.http, context);
        Ok(engine::run(state, session, &hub, self.received)?)
    }
}
