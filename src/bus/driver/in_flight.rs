//! Which request an answer belongs to: the requests each servo has not answered yet, and the
//! read lengths that tell their answers apart.
//!
//! Status packets carry no request number. A servo that answers after the driver gave up on a
//! request (its answer comes later than the timeout) would otherwise have that late answer
//! taken for the answer to whatever request is current: a position from one or more periods
//! ago taken for the present one, and the servo's fault hidden, since the read "succeeded".
//!
//! A servo answers its requests in order, so an answer belongs to the oldest of its unanswered
//! requests that it fits, and the requests before that one were lost (a request garbled on the
//! line gets no answer at all). What an answer fits is its data length: while an earlier read
//! of a servo is unanswered, the next read of it asks for a few bytes more than the register
//! holds (the bytes after it are read and dropped), a length none of its unanswered reads has.
//! Every answer then names its request: the current one's is taken, an earlier one's is skipped
//! as stale. In ordinary operation every read is answered, and every read asks for exactly its
//! register.
//!
//! A servo with [`TAGS`] unanswered reads gets no new read (it could not be told apart) until
//! one is answered (the driver waits for that up to its timeout) or [`FORGOTTEN_AFTER`] has
//! passed since the oldest.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

/// Read lengths told apart: the register's own, and up to `TAGS - 1` bytes more.
pub const TAGS: usize = 4;
/// An unanswered request older than this is taken for lost: its late answer, if it ever came,
/// could no longer be told from a new one's.
pub const FORGOTTEN_AFTER: Duration = Duration::from_secs(2);

#[derive(Debug, Clone, Copy)]
struct Request {
    /// Data bytes its answer carries.
    answer_bytes: usize,
    sent: Instant,
}

/// What an answer from a servo is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Answer {
    /// The answer to the servo's latest request.
    Current,
    /// The late answer to an earlier request, sent this long before it came.
    Earlier { late: Duration },
    /// It fits none of the servo's unanswered requests.
    Unknown,
}

/// The unanswered requests, by the id that answers them (a servo, or the broadcast id for a
/// combined answer).
#[derive(Debug)]
pub struct InFlight {
    /// Indexed by the id itself (one byte): every answer looks its servo up, so no hashing.
    requests: Vec<VecDeque<Request>>,
    /// The ids that have been sent requests: what a look at every queue visits.
    ids: Vec<u8>,
}

impl Default for InFlight {
    fn default() -> Self {
        InFlight {
            requests: vec![VecDeque::new(); usize::from(u8::MAX) + 1],
            ids: Vec::new(),
        }
    }
}

impl InFlight {
    fn queue(&self, id: u8) -> &VecDeque<Request> {
        &self.requests[usize::from(id)]
    }
    /// The smallest number of extra bytes (below [`TAGS`]) for which no unanswered request of
    /// any of `ids` expects an answer of `answer_bytes(extra)` data bytes; `None` when every
    /// one is taken, with the id and the age of the oldest request holding them.
    pub fn extra_bytes(
        &mut self,
        ids: &[u8],
        answer_bytes: impl Fn(usize) -> usize,
        now: Instant,
    ) -> Result<usize, (u8, Duration)> {
        self.forget_before(now);
        let taken = |extra: usize| {
            ids.iter().find(|&&id| {
                self.queue(id)
                    .iter()
                    .any(|r| r.answer_bytes == answer_bytes(extra))
            })
        };
        let mut holder = None;
        for extra in 0..TAGS {
            match taken(extra) {
                None => return Ok(extra),
                Some(&id) => holder = holder.or(Some(id)),
            }
        }
        let id = holder.unwrap_or_default();
        let oldest = self
            .queue(id)
            .front()
            .map_or(Duration::ZERO, |r| now.saturating_duration_since(r.sent));
        Err((id, oldest))
    }

    /// Whether any request is unanswered.
    pub fn waiting(&self) -> bool {
        self.ids.iter().any(|&id| !self.queue(id).is_empty())
    }

    /// A request to each of `ids` went out at `sent`, its answers to carry `answer_bytes`.
    pub fn sent(&mut self, ids: &[u8], answer_bytes: usize, sent: Instant) {
        for &id in ids {
            if !self.ids.contains(&id) {
                self.ids.push(id);
            }
            self.requests[usize::from(id)].push_back(Request { answer_bytes, sent });
        }
    }

    /// An answer of `answer_bytes` data bytes from `id` came at `now`: whose is it? An answer
    /// that fits a request settles it and every earlier one of the servo (lost, since the servo
    /// answers in order).
    pub fn answered(&mut self, id: u8, answer_bytes: usize, now: Instant) -> Answer {
        let queue = &mut self.requests[usize::from(id)];
        let Some(at) = queue.iter().position(|r| r.answer_bytes == answer_bytes) else {
            return Answer::Unknown;
        };
        let current = at + 1 == queue.len();
        let request = queue[at];
        queue.drain(..=at);
        if current {
            Answer::Current
        } else {
            Answer::Earlier {
                late: now.saturating_duration_since(request.sent),
            }
        }
    }

    /// Drops the requests sent more than [`FORGOTTEN_AFTER`] before `now`.
    fn forget_before(&mut self, now: Instant) {
        for &id in &self.ids {
            let queue = &mut self.requests[usize::from(id)];
            while queue
                .front()
                .is_some_and(|r| now.saturating_duration_since(r.sent) > FORGOTTEN_AFTER)
            {
                queue.pop_front();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ID: u8 = 4;

    #[test]
    fn a_late_answer_names_its_request_by_its_length() {
        let t0 = Instant::now();
        let mut in_flight = InFlight::default();
        let exact = |extra: usize| 2 + extra;
        // The first read asks for the register's 2 bytes and is not answered in time.
        assert_eq!(in_flight.extra_bytes(&[ID], exact, t0), Ok(0));
        in_flight.sent(&[ID], 2, t0);
        // The retry asks for 3: the late answer to the first (2 bytes) is known for what it is.
        let t1 = t0 + Duration::from_millis(40);
        assert_eq!(in_flight.extra_bytes(&[ID], exact, t1), Ok(1));
        in_flight.sent(&[ID], 3, t1);
        let t2 = t0 + Duration::from_millis(50);
        assert_eq!(
            in_flight.answered(ID, 2, t2),
            Answer::Earlier {
                late: Duration::from_millis(50)
            }
        );
        assert_eq!(in_flight.answered(ID, 3, t2), Answer::Current);
        // All answered: the next read asks for the register alone again.
        assert_eq!(in_flight.extra_bytes(&[ID], exact, t2), Ok(0));
    }

    #[test]
    fn a_lost_request_is_settled_by_the_answer_to_a_later_one() {
        let t0 = Instant::now();
        let mut in_flight = InFlight::default();
        let exact = |extra: usize| 2 + extra;
        in_flight.sent(&[ID], 2, t0);
        in_flight.sent(&[ID], 3, t0);
        // The first was garbled and never answered; the second's answer comes.
        assert_eq!(in_flight.answered(ID, 3, t0), Answer::Current);
        assert_eq!(in_flight.extra_bytes(&[ID], exact, t0), Ok(0));
    }

    #[test]
    fn a_servo_that_answers_nothing_in_time_is_given_no_fifth_read_until_it_is_forgotten() {
        let t0 = Instant::now();
        let mut in_flight = InFlight::default();
        let exact = |extra: usize| 2 + extra;
        for k in 0..TAGS {
            let at = t0 + Duration::from_millis(40 * k as u64);
            let extra = in_flight.extra_bytes(&[1, ID], exact, at).unwrap();
            assert_eq!(extra, k);
            in_flight.sent(&[1, ID], exact(extra), at);
            // Servo 1 answers every one; servo 4 none.
            assert_eq!(in_flight.answered(1, exact(extra), at), Answer::Current);
        }
        let t = t0 + Duration::from_millis(200);
        assert_eq!(
            in_flight.extra_bytes(&[1, ID], exact, t),
            Err((ID, Duration::from_millis(200)))
        );
        // Forgotten: the oldest is taken for lost.
        let later = t0 + FORGOTTEN_AFTER + Duration::from_millis(1);
        assert_eq!(in_flight.extra_bytes(&[1, ID], exact, later), Ok(0));
    }

    #[test]
    fn an_answer_no_request_fits_is_unknown() {
        let mut in_flight = InFlight::default();
        let t0 = Instant::now();
        assert_eq!(in_flight.answered(ID, 2, t0), Answer::Unknown);
        in_flight.sent(&[ID], 2, t0);
        assert_eq!(in_flight.answered(ID, 7, t0), Answer::Unknown);
        assert_eq!(in_flight.answered(ID, 2, t0), Answer::Current);
    }
}
