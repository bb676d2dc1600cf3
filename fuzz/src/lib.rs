//! Helpers the fuzz targets share: reading structured choices from the fuzzer's bytes, the
//! built-in robots, the packet properties both decoder targets check, trajectories and names
//! for the export targets and a C reader for the header's.

pub mod c_text;
pub mod decoding;
pub mod exports;

use keypose::robot::{Robot, BUILTIN_NAMES};
use keypose::sequence::Sequence;
use std::borrow::Cow;
use std::sync::OnceLock;

/// The fuzzer's bytes read front to back as a series of choices; once they run out every
/// choice is 0, so any input is a complete (if short) scenario.
pub struct Choices<'a> {
    data: &'a [u8],
}

impl<'a> Choices<'a> {
    pub fn new(data: &'a [u8]) -> Self {
        Choices { data }
    }

    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    pub fn byte(&mut self) -> u8 {
        match self.data.split_first() {
            Some((&b, rest)) => {
                self.data = rest;
                b
            }
            None => 0,
        }
    }

    /// The next `n` bytes (fewer at the end).
    pub fn take(&mut self, n: usize) -> &'a [u8] {
        let (taken, rest) = self.data.split_at(n.min(self.data.len()));
        self.data = rest;
        taken
    }

    /// One of `items`, chosen by the next byte.
    pub fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[usize::from(self.byte()) % items.len()]
    }

    /// Whatever is left.
    pub fn rest(&mut self) -> &'a [u8] {
        std::mem::take(&mut self.data)
    }
}

/// The built-in robot chosen by `selector`, parsed once per process (parsing it again on every
/// execution would dominate the cheaper targets).
pub fn builtin_robot(selector: u8) -> &'static Robot {
    static ROBOTS: OnceLock<Vec<Robot>> = OnceLock::new();
    let robots = ROBOTS.get_or_init(|| {
        BUILTIN_NAMES
            .iter()
            .map(|name| Robot::builtin(name).expect("a built-in robot"))
            .collect()
    });
    &robots[usize::from(selector) % robots.len()]
}

/// The built-in robot called `name`, if there is one.
pub fn builtin_named(name: &str) -> Option<&'static Robot> {
    let index = BUILTIN_NAMES.iter().position(|n| *n == name)?;
    Some(builtin_robot(index as u8))
}

/// The robot a sequence is loaded against: the built-in it names (the SO-101 when it names
/// none), or for a sequence of several arms the cell of the built-ins its arms name (None when
/// an arm names no built-in or the arms make no cell).
pub fn sequence_robot(sequence: &Sequence) -> Option<Cow<'static, Robot>> {
    if sequence.is_cell() {
        return keypose::plan::builtin_robot_of(sequence).map(Cow::Owned);
    }
    let robot = builtin_named(&sequence.robot).unwrap_or_else(|| builtin_robot(0));
    Some(Cow::Borrowed(robot))
}
