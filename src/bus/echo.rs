//! Echoes of our own packets on half-duplex adapters that loop the line back.
//!
//! Many Feetech boards hear their own transmission. The echo of a packet reaches the host after
//! a delay of its own: a packet that gets no answer (a sync write) can have its echo arrive only
//! after the driver has flushed its input for the next packet. A Feetech echo cannot be told
//! from a status packet by its shape (the instruction byte sits where the error byte is), only
//! by being byte for byte what was sent, at the place in the stream where it was sent: echoes
//! come back in the order the packets went out, each before any answer to it.

use std::collections::VecDeque;

/// How many sent packets may still be waiting for their echo. Only the last few can be: each
/// answer proves every earlier echo has passed.
const MAX_PENDING: usize = 8;

/// The packets sent whose echo has not been seen, oldest first.
#[derive(Debug, Default)]
pub struct Echoes {
    pending: VecDeque<Vec<u8>>,
}

/// What the front of the input is.
#[derive(Debug, PartialEq, Eq)]
pub enum Front {
    /// The start of an echo, or nothing yet: read more before deciding.
    Undecided,
    /// An echo, now removed from the input: these bytes.
    Echo(Vec<u8>),
    /// Not an echo: a packet (or noise) for the decoder.
    NotEcho,
}

impl Echoes {
    /// Notes a packet just written.
    pub fn sent(&mut self, bytes: Vec<u8>) {
        if self.pending.len() == MAX_PENDING {
            self.pending.pop_front();
        }
        self.pending.push_back(bytes);
    }

    /// An answer to the last packet sent arrived: every echo still to come would have come
    /// before it, so none is pending any more (on an adapter without echo, none ever was).
    pub fn answered(&mut self) {
        self.pending.clear();
    }

    /// Removes an echo from the front of `rx` if one is there. A pending echo that does not
    /// come next is not dropped: noise or a servo's late answer can come before it. An echo
    /// found behind older pending ones means those were flushed, so they go too.
    pub fn strip(&mut self, rx: &mut Vec<u8>) -> Front {
        if let Some(k) = self.pending.iter().position(|echo| rx.starts_with(echo)) {
            let echo = self.pending.remove(k).unwrap_or_default();
            self.pending.drain(..k);
            rx.drain(..echo.len());
            return Front::Echo(echo);
        }
        if self.pending.iter().any(|echo| echo.starts_with(rx)) {
            Front::Undecided
        } else {
            Front::NotEcho
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PING_1: [u8; 6] = [0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB];
    const WRITE_1: [u8; 8] = [0xFF, 0xFF, 0x01, 0x04, 0x03, 0x28, 0x01, 0xCE];

    #[test]
    fn an_echo_is_removed_and_what_follows_is_left() {
        let mut echoes = Echoes::default();
        echoes.sent(PING_1.to_vec());
        let mut rx = PING_1.to_vec();
        rx.extend([0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC]);
        assert_eq!(echoes.strip(&mut rx), Front::Echo(PING_1.to_vec()));
        assert_eq!(rx, [0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC]);
        // Nothing pending: the answer goes to the decoder.
        assert_eq!(echoes.strip(&mut rx), Front::NotEcho);
    }

    #[test]
    fn a_partial_echo_waits_and_a_differing_byte_decides() {
        let mut echoes = Echoes::default();
        echoes.sent(PING_1.to_vec());
        assert_eq!(echoes.strip(&mut Vec::new()), Front::Undecided);
        assert_eq!(echoes.strip(&mut vec![0xFF, 0xFF, 0x01]), Front::Undecided);
        // Error byte 0x00 where the ping has 0x01: an answer.
        let mut rx = vec![0xFF, 0xFF, 0x01, 0x02, 0x00];
        assert_eq!(echoes.strip(&mut rx), Front::NotEcho);
        assert_eq!(rx.len(), 5);
    }

    #[test]
    fn a_late_echo_is_found_behind_noise_and_flushed_ones_are_dropped() {
        let mut echoes = Echoes::default();
        echoes.sent(vec![0xAA; 4]); // flushed: never seen
        echoes.sent(PING_1.to_vec());
        echoes.sent(WRITE_1.to_vec());
        let mut rx = vec![0x00];
        assert_eq!(echoes.strip(&mut rx), Front::NotEcho);
        rx.remove(0); // the decoder skips the noise
        rx.extend(PING_1);
        rx.extend(WRITE_1);
        assert_eq!(echoes.strip(&mut rx), Front::Echo(PING_1.to_vec()));
        assert_eq!(echoes.strip(&mut rx), Front::Echo(WRITE_1.to_vec()));
        assert!(rx.is_empty());
        assert!(echoes.pending.is_empty());
    }
}
