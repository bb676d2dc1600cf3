//! The keys waiting for the state, in the order they came, with two exceptions that keep the
//! arm answerable: a stop wins over everything queued before it, and a jog never waits behind
//! another jog.
//!
//! A front end (the terminal, the studio's engine) takes every input that has arrived into an
//! [`InputQueue`] at once and hands the state one at a time with [`InputQueue::next`]:
//! - a stop (Esc, Ctrl-C, the studio's Stop button) drops every input queued before it when it
//!   arrives — a queued jog must never run after the stop that was meant to end it;
//! - while a jog runs, the jog keys at the front go to the state at once (it keeps the newest
//!   as the one pending jog), and any other key waits until the jog is over, so that a capture
//!   typed after a jog sees where the jog went.
//!
//! The rules are here, apart from any terminal or socket, so that they are tested alone.

use super::keys::Key;
use std::collections::VecDeque;

/// The most inputs that wait; more are refused (a page or a paste flooding the session).
pub const MAX_WAITING: usize = 256;

/// What the queue needs to know of an input.
pub trait Input {
    /// It asks the arm to stop.
    fn is_stop(&self) -> bool;
    /// It jogs the arm ([`Key::is_jog`]).
    fn is_jog(&self) -> bool;
}

impl Input for Key {
    fn is_stop(&self) -> bool {
        Key::is_stop(self)
    }
    fn is_jog(&self) -> bool {
        Key::is_jog(self)
    }
}

/// Inputs that have arrived and not yet been handed to the state.
#[derive(Debug)]
pub struct InputQueue<T> {
    waiting: VecDeque<T>,
}

impl<T> Default for InputQueue<T> {
    fn default() -> Self {
        Self {
            waiting: VecDeque::new(),
        }
    }
}

impl<T: Input> InputQueue<T> {
    /// Queues `input`; returns the inputs that will never be handed on: those a stop dropped,
    /// or `input` itself when [`MAX_WAITING`] are waiting already.
    pub fn push(&mut self, input: T) -> Vec<T> {
        if input.is_stop() {
            let dropped = self.waiting.drain(..).collect();
            self.waiting.push_back(input);
            return dropped;
        }
        if self.waiting.len() >= MAX_WAITING {
            return vec![input];
        }
        self.waiting.push_back(input);
        Vec::new()
    }

    /// Drops everything queued (a lost controller's keys); returns it.
    pub fn drop_all(&mut self) -> Vec<T> {
        self.waiting.drain(..).collect()
    }

    /// The next input for the state, given whether a jog is running now: the front one,
    /// unless a jog runs and the front one is not a jog or a stop (it waits for the jog).
    pub fn next(&mut self, jog_running: bool) -> Option<T> {
        let front = self.waiting.front()?;
        if jog_running && !(front.is_jog() || front.is_stop()) {
            return None;
        }
        self.waiting.pop_front()
    }

    /// How many inputs wait.
    pub fn len(&self) -> usize {
        self.waiting.len()
    }

    /// Nothing waits.
    pub fn is_empty(&self) -> bool {
        self.waiting.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn queue(keys: &[Key]) -> (InputQueue<Key>, Vec<Key>) {
        let mut queue = InputQueue::default();
        let dropped = keys.iter().flat_map(|k| queue.push(k.clone())).collect();
        (queue, dropped)
    }

    #[test]
    fn a_stop_drops_everything_queued_before_it_and_comes_first() {
        let mut keys = vec![Key::ShiftRight; 60];
        keys.extend([Key::Char('n'), Key::Char('y'), Key::Esc, Key::Left]);
        let (mut queue, dropped) = queue(&keys);
        assert_eq!(dropped.len(), 62, "the 60 jogs, n and y");
        // A stop is handed on even while a jog runs; what came after it follows.
        assert_eq!(queue.next(true), Some(Key::Esc));
        assert_eq!(queue.next(true), Some(Key::Left));
        assert_eq!(queue.next(false), None);
    }

    #[test]
    fn while_a_jog_runs_jogs_go_on_and_other_keys_wait_for_it() {
        let (mut queue, _) = queue(&[Key::Right, Key::Right, Key::Char('n'), Key::Right]);
        assert_eq!(queue.next(true), Some(Key::Right));
        assert_eq!(queue.next(true), Some(Key::Right));
        // The capture waits for the arm to arrive, and so does the jog typed after it.
        assert_eq!(queue.next(true), None);
        assert_eq!(queue.len(), 2);
        assert_eq!(queue.next(false), Some(Key::Char('n')));
        assert_eq!(queue.next(false), Some(Key::Right));
        assert!(queue.is_empty());
    }

    #[test]
    fn a_flood_is_refused_beyond_the_bound() {
        let keys = vec![Key::Char('n'); MAX_WAITING + 3];
        let (queue, refused) = queue(&keys);
        assert_eq!((queue.len(), refused.len()), (MAX_WAITING, 3));
    }
}
