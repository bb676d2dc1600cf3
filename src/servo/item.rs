//! One entry of a model's full control table, as the vendor's manual lists it: the register
//! (name, address, size, encoding), who may write it, where it lives, what it holds from the
//! factory and which values a write may carry. The tables themselves are data in the model
//! files; the emulated servos (`bus::virtual_bus::servo`) read them, and a unit test checks
//! that the registers the drivers use ([`RegisterTable`](super::RegisterTable)) agree with
//! them.

use super::register::{Encoding, Register};

/// Who may write the item.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Access {
    /// Only the servo writes it.
    ReadOnly,
    /// A write instruction may set it.
    ReadWrite,
}

/// Where the item lives: EEPROM items keep their value over a power cycle, and on the
/// Dynamixel X series accept writes only while the torque is off.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Area {
    /// Kept over a power cycle.
    Eeprom,
    /// Reset at power-on.
    Ram,
}

/// What the item holds at power-on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Default {
    /// A fixed factory value.
    Value(i64),
    /// Set by the servo itself: its model number, a present value, the goal it holds.
    Live,
}

/// One control-table item.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Item {
    /// Its name, address, size and encoding.
    pub register: Register,
    /// Who may write it.
    pub access: Access,
    /// EEPROM or RAM.
    pub area: Area,
    /// What it holds at power-on.
    pub default: Default,
    /// The values a write may carry (inclusive); a write outside is refused with the
    /// servo's own error. Read-only items have the register's whole range.
    pub range: (i64, i64),
}

impl Item {
    /// Its name in the manual's table.
    pub fn name(&self) -> &'static str {
        self.register.name
    }

    /// Whether the item occupies any byte of `start..end`.
    pub fn overlaps(&self, start: usize, end: usize) -> bool {
        usize::from(self.register.address) < end && usize::from(self.register.end()) > start
    }

    /// Whether every byte of the item lies in `start..end`.
    pub fn inside(&self, start: usize, end: usize) -> bool {
        usize::from(self.register.address) >= start && usize::from(self.register.end()) <= end
    }

    /// Whether a write of `value` is inside [`Self::range`].
    pub fn accepts(&self, value: i64) -> bool {
        (self.range.0..=self.range.1).contains(&value)
    }
}

/// The item called `name` in `items`.
pub fn find(items: &'static [Item], name: &str) -> Option<&'static Item> {
    items.iter().find(|item| item.name() == name)
}

const fn item(
    register: Register,
    access: Access,
    area: Area,
    default: Default,
    range: (i64, i64),
) -> Item {
    Item {
        register,
        access,
        area,
        default,
        range,
    }
}

const fn register(name: &'static str, address: u16, size: u8, encoding: Encoding) -> Register {
    Register::new(name, address, size, encoding)
}

/// An unsigned EEPROM item anyone may write.
pub(super) const fn eeprom(
    name: &'static str,
    address: u16,
    size: u8,
    default: i64,
    range: (i64, i64),
) -> Item {
    let r = register(name, address, size, Encoding::Unsigned);
    writable(r, Area::Eeprom, Default::Value(default), range)
}

/// An unsigned RAM item anyone may write.
pub(super) const fn ram(
    name: &'static str,
    address: u16,
    size: u8,
    default: i64,
    range: (i64, i64),
) -> Item {
    let r = register(name, address, size, Encoding::Unsigned);
    writable(r, Area::Ram, Default::Value(default), range)
}

/// A writable item with its own encoding.
pub(super) const fn writable(
    register: Register,
    area: Area,
    default: Default,
    range: (i64, i64),
) -> Item {
    item(register, Access::ReadWrite, area, default, range)
}

/// A read-only item: its range is whatever the register can hold.
pub(super) const fn read_only(register: Register, area: Area, default: Default) -> Item {
    item(
        register,
        Access::ReadOnly,
        area,
        default,
        (i64::MIN, i64::MAX),
    )
}

/// A read-only unsigned RAM item the servo keeps up to date.
pub(super) const fn live(name: &'static str, address: u16, size: u8) -> Item {
    read_only(
        register(name, address, size, Encoding::Unsigned),
        Area::Ram,
        Default::Live,
    )
}
