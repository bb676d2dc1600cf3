//! Who may talk to the studio: the access token of the printed URL, and requests that come
//! from the studio's own page at the address it listens on.
//!
//! A token alone is not enough in a browser: any other page the user opens could send
//! requests to a local port (they would fail the token, but a GET of a guessable route would
//! still reach the server), and a DNS-rebinding site makes the browser believe the studio is
//! its own origin. So every request is also refused when its `Host` is not the listening
//! address (or `localhost` on its port) and when it carries an `Origin` other than the
//! studio's own.

use std::io::Read;
use std::net::SocketAddr;

/// The header the page's scripts send the token in (the query's `token=` works too, for the
/// page itself and for `EventSource`, which cannot send headers).
pub(crate) const TOKEN_HEADER: &str = "X-Keypose-Token";

/// Why a request was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(crate) enum Refusal {
    #[error("Host {found:?} is not this studio's address (expected one of {expected}): refused against DNS rebinding")]
    Host { found: String, expected: String },
    #[error("Origin {found:?} is not this studio's page ({expected}): another site may not drive the arm")]
    Origin { found: String, expected: String },
    #[error("no access token: open the URL keypose studio printed (it ends in ?token=…)")]
    NoToken,
    #[error("wrong access token: open the URL this keypose studio printed")]
    WrongToken,
}

/// What a request says about itself, as far as access goes.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Credentials<'a> {
    pub host: Option<&'a str>,
    pub origin: Option<&'a str>,
    /// From the header or the query.
    pub token: Option<&'a str>,
}

/// The access rules of one running studio.
#[derive(Debug, Clone)]
pub struct Guard {
    token: String,
    /// `Host` values that name this server: the address it listens on, and `localhost` with
    /// its port when that address is a loopback one.
    hosts: Vec<String>,
}

impl Guard {
    /// The rules of a studio listening on `addr` whose pages carry `token`.
    pub fn new(token: String, addr: SocketAddr) -> Guard {
        let port = addr.port();
        let mut hosts = vec![addr.to_string()];
        if addr.ip().is_loopback() {
            hosts.push(format!("localhost:{port}"));
        }
        Guard { token, hosts }
    }

    /// The page's URL, with the token.
    pub(crate) fn url(&self) -> String {
        format!("http://{}/?token={}", self.hosts[0], self.token)
    }

    /// Host and Origin: checked on every request, the page's assets included.
    pub(crate) fn check_origin(&self, request: &Credentials) -> Result<(), Refusal> {
        let host = request.host.unwrap_or("");
        if !self.hosts.iter().any(|h| h.eq_ignore_ascii_case(host)) {
            return Err(Refusal::Host {
                found: host.to_string(),
                expected: self.hosts.join(", "),
            });
        }
        // A browser sends Origin on every POST and on cross-origin GETs; a same-origin GET
        // (the page, its scripts) may come without one. A request from another page, or the
        // "null" of a sandboxed one, names its origin and is refused.
        if let Some(origin) = request.origin {
            let ours = self.hosts.iter().map(|h| format!("http://{h}"));
            if !ours.clone().any(|o| o.eq_ignore_ascii_case(origin)) {
                return Err(Refusal::Origin {
                    found: origin.to_string(),
                    expected: ours.collect::<Vec<_>>().join(", "),
                });
            }
        }
        Ok(())
    }

    /// Host, Origin and the token: the page and every API call.
    pub(crate) fn check(&self, request: &Credentials) -> Result<(), Refusal> {
        self.check_origin(request)?;
        match request.token {
            None | Some("") => Err(Refusal::NoToken),
            Some(token) if same_secret(token.as_bytes(), self.token.as_bytes()) => Ok(()),
            Some(_) => Err(Refusal::WrongToken),
        }
    }
}

/// Compares two secrets in time that depends on their lengths only, so that the time an
/// answer takes does not tell an attacker how many leading characters were right.
pub(crate) fn same_secret(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    a.iter().zip(b).fold(0u8, |acc, (x, y)| acc | (x ^ y)) == 0
}

/// 32 random bytes from the kernel, in hex: the access token.
pub(crate) fn new_token() -> std::io::Result<String> {
    let mut bytes = [0u8; 32];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut bytes)?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guard() -> Guard {
        Guard::new("ab".repeat(32), "127.0.0.1:8123".parse().unwrap())
    }

    fn request<'a>(
        host: &'a str,
        origin: Option<&'a str>,
        token: Option<&'a str>,
    ) -> Credentials<'a> {
        Credentials {
            host: Some(host),
            origin,
            token,
        }
    }

    #[test]
    fn the_own_page_with_the_token_passes() {
        let token = "ab".repeat(32);
        let g = guard();
        assert_eq!(
            g.check(&request("127.0.0.1:8123", None, Some(&token))),
            Ok(())
        );
        assert_eq!(
            g.check(&request(
                "localhost:8123",
                Some("http://localhost:8123"),
                Some(&token)
            )),
            Ok(())
        );
        assert_eq!(g.url(), format!("http://127.0.0.1:8123/?token={token}"));
    }

    #[test]
    fn a_missing_or_wrong_token_is_refused() {
        let g = guard();
        assert_eq!(
            g.check(&request("127.0.0.1:8123", None, None)),
            Err(Refusal::NoToken)
        );
        assert_eq!(
            g.check(&request("127.0.0.1:8123", None, Some(&"ab".repeat(31)))),
            Err(Refusal::WrongToken)
        );
        // Same length, last character off.
        let almost = format!("{}ac", "ab".repeat(31));
        assert_eq!(
            g.check(&request("127.0.0.1:8123", None, Some(&almost))),
            Err(Refusal::WrongToken)
        );
    }

    #[test]
    fn foreign_origins_and_rebound_hosts_are_refused_even_with_the_token() {
        let token = "ab".repeat(32);
        let g = guard();
        for origin in [
            "http://evil.example",
            "null",
            "http://127.0.0.1:9999",
            "https://127.0.0.1:8123",
        ] {
            assert!(
                matches!(
                    g.check(&request("127.0.0.1:8123", Some(origin), Some(&token))),
                    Err(Refusal::Origin { .. })
                ),
                "{origin}"
            );
        }
        // A DNS-rebinding page reaches the port under its own name.
        for host in ["evil.example:8123", "127.0.0.1:8124", ""] {
            assert!(
                matches!(
                    g.check(&request(host, None, Some(&token))),
                    Err(Refusal::Host { .. })
                ),
                "{host}"
            );
        }
        // On a non-loopback address, localhost is not the server's name.
        let lan = Guard::new(token.clone(), "192.168.1.5:8123".parse().unwrap());
        assert!(lan
            .check(&request("localhost:8123", None, Some(&token)))
            .is_err());
        assert!(lan
            .check(&request("192.168.1.5:8123", None, Some(&token)))
            .is_ok());
    }

    #[test]
    fn tokens_are_64_hex_digits_and_differ() {
        let (a, b) = (new_token().unwrap(), new_token().unwrap());
        assert_eq!(a.len(), 64);
        assert!(a.chars().all(|c| c.is_ascii_hexdigit()));
        assert_ne!(a, b);
        assert!(same_secret(a.as_bytes(), a.clone().as_bytes()));
        assert!(!same_secret(a.as_bytes(), b.as_bytes()));
    }
}
