//! Which page controls the arm: a lease that one client holds at a time and renews by its
//! heartbeat; the others watch. A lease that lapses (the page closed, the network went) or
//! whose event stream broke is released, and the engine then stops playback the soft way.
//! A page whose lease lapsed while it lived (a busy machine kept its heartbeat back) takes it
//! back by acting, if no other page has taken it meanwhile: its key is proof of life, as a
//! heartbeat is, and what was playing has been stopped already.

use std::time::{Duration, Instant};

/// A controller that has not been heard from for this long has gone.
pub(crate) const LEASE: Duration = Duration::from_secs(2);

/// Why a client may not act.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ControlRefusal {
    /// Another page holds the lease.
    #[error("another page controls the arm; this one watches (close the other page, or wait until it lets go)")]
    Taken,
    /// The page acts without holding the lease.
    #[error("this page does not control the arm (Take control asks for it)")]
    NotController,
    /// A client id that is not 1 to 64 letters, digits or '-' (the id, shortened to 80).
    #[error("client id {0:?}: expected 1 to 64 letters, digits or '-'")]
    BadClient(String),
}

/// Which page controls the arm, if any, and whether a controller was lost.
#[derive(Debug, Default)]
pub struct Lease {
    holder: Option<(String, Instant)>,
    /// Set when a holder is lost (not when it lets go on purpose); taken by the engine.
    lost: bool,
    /// The holder whose lease lapsed last, while nobody holds it since.
    lapsed: Option<String>,
}

impl Lease {
    /// Grants the lease to `client` when it is free, lapsed or already `client`'s (a renewal:
    /// the heartbeat).
    pub fn claim(&mut self, client: &str, now: Instant) -> Result<(), ControlRefusal> {
        valid_client(client)?;
        self.expire(now);
        match &mut self.holder {
            Some((holder, seen)) if holder == client => *seen = now,
            Some(_) => return Err(ControlRefusal::Taken),
            None => self.grant(client, now),
        }
        Ok(())
    }

    fn grant(&mut self, client: &str, now: Instant) {
        self.holder = Some((client.to_string(), now));
        self.lapsed = None;
    }

    /// Whether `client` may act now: it holds the lease, or held it until it lapsed and nobody
    /// has taken it since (it takes it back).
    pub(crate) fn check(&mut self, client: &str, now: Instant) -> Result<(), ControlRefusal> {
        self.expire(now);
        match &self.holder {
            Some((holder, _)) if holder == client => Ok(()),
            Some(_) => Err(ControlRefusal::Taken),
            None if self.lapsed.as_deref() == Some(client) => {
                self.grant(client, now);
                Ok(())
            }
            None => Err(ControlRefusal::NotController),
        }
    }

    /// `client` lets go (a button) — or, with `lost`, its connection broke.
    pub(crate) fn release(&mut self, client: &str, lost: bool) -> bool {
        if self.holder.as_ref().is_some_and(|(h, _)| h == client) {
            self.holder = None;
            self.lapsed = None;
            self.lost |= lost;
            true
        } else {
            false
        }
    }

    /// Releases a holder not heard from for [`LEASE`].
    pub(crate) fn expire(&mut self, now: Instant) {
        if self
            .holder
            .as_ref()
            .is_some_and(|(_, seen)| now.saturating_duration_since(*seen) > LEASE)
        {
            self.lapsed = self.holder.take().map(|(holder, _)| holder);
            self.lost = true;
        }
    }

    /// A page controls the arm.
    pub fn is_held(&self) -> bool {
        self.holder.is_some()
    }

    /// Whether a controller was lost since the last call.
    pub fn take_lost(&mut self) -> bool {
        std::mem::take(&mut self.lost)
    }
}

fn valid_client(client: &str) -> Result<(), ControlRefusal> {
    let ok = (1..=64).contains(&client.len())
        && client
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-');
    if ok {
        Ok(())
    } else {
        Err(ControlRefusal::BadClient(client.chars().take(80).collect()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_client_controls_and_the_others_watch() {
        let t0 = Instant::now();
        let mut lease = Lease::default();
        assert_eq!(lease.check("a", t0), Err(ControlRefusal::NotController));
        assert_eq!(lease.claim("a", t0), Ok(()));
        assert_eq!(lease.claim("b", t0), Err(ControlRefusal::Taken));
        assert_eq!(lease.check("b", t0), Err(ControlRefusal::Taken));
        assert_eq!(lease.check("a", t0), Ok(()));
        assert!(
            !lease.release("b", true),
            "a watcher cannot release the controller"
        );
        assert!(lease.release("a", false));
        assert!(!lease.take_lost(), "letting go on purpose is not a loss");
        assert_eq!(lease.claim("b", t0), Ok(()));
    }

    #[test]
    fn heartbeats_keep_the_lease_and_silence_loses_it() {
        let t0 = Instant::now();
        let mut lease = Lease::default();
        lease.claim("a", t0).unwrap();
        // Renewed every 1.5 s, it holds past the 2 s lease.
        for i in 1..=4 {
            assert_eq!(
                lease.claim("a", t0 + Duration::from_millis(1500 * i)),
                Ok(())
            );
        }
        let last = t0 + Duration::from_millis(6000);
        assert_eq!(lease.check("a", last + Duration::from_millis(2000)), Ok(()));
        assert!(!lease.take_lost());
        // 2.001 s of silence: gone, and the engine hears of it once.
        let lapsed = last + Duration::from_millis(2001);
        lease.expire(lapsed);
        assert!(!lease.is_held());
        assert!(lease.take_lost());
        assert!(!lease.take_lost());
        assert_eq!(lease.claim("b", lapsed), Ok(()));
        // The page that lapsed finds it taken.
        assert_eq!(lease.check("a", lapsed), Err(ControlRefusal::Taken));
    }

    #[test]
    fn a_page_whose_lease_lapsed_takes_it_back_by_acting_unless_another_took_it() {
        let t0 = Instant::now();
        let lapsed = t0 + LEASE + Duration::from_millis(1);
        let mut lease = Lease::default();
        lease.claim("a", t0).unwrap();
        // A watcher does not take a lapsed lease by acting; the page that held it does,
        // and the engine has heard of the loss (playback stopped) all the same.
        assert_eq!(lease.check("b", lapsed), Err(ControlRefusal::NotController));
        assert_eq!(lease.check("a", lapsed), Ok(()));
        assert!(lease.is_held());
        assert!(lease.take_lost());
        // Letting go on purpose, or a broken stream, is not a lapse: acting does not take
        // the lease back then.
        lease.release("a", true);
        assert_eq!(lease.check("a", lapsed), Err(ControlRefusal::NotController));
        lease.claim("a", lapsed).unwrap();
        lease.release("a", false);
        assert_eq!(lease.check("a", lapsed), Err(ControlRefusal::NotController));
    }

    #[test]
    fn a_broken_stream_is_a_loss_and_bad_ids_are_refused() {
        let t0 = Instant::now();
        let mut lease = Lease::default();
        lease.claim("page-1", t0).unwrap();
        assert!(lease.release("page-1", true));
        assert!(lease.take_lost());
        for bad in ["", "a b", &"x".repeat(65), "é"] {
            assert!(matches!(
                lease.claim(bad, t0),
                Err(ControlRefusal::BadClient(_))
            ));
        }
    }
}
