//! The alarm conditions a servo reports, common to every vendor, and where a vendor's alarm
//! byte (the status byte or the alarm register) keeps each one.

use std::fmt;

/// Alarm conditions a servo reports, common to both vendors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Alarms {
    /// Supply voltage outside the allowed range.
    pub input_voltage: bool,
    /// Internal temperature above its limit.
    pub overheating: bool,
    /// Magnetic encoder / angle sensor fault.
    pub encoder: bool,
    /// Dynamixel "electrical shock"; Feetech over-current.
    pub electrical: bool,
    /// The load exceeded what the servo can hold.
    pub overload: bool,
}

impl Alarms {
    /// Whether any alarm is raised.
    pub fn any(&self) -> bool {
        self.input_voltage || self.overheating || self.encoder || self.electrical || self.overload
    }

    /// The alarms raised in either.
    pub fn or(&self, other: &Alarms) -> Alarms {
        Alarms {
            input_voltage: self.input_voltage || other.input_voltage,
            overheating: self.overheating || other.overheating,
            encoder: self.encoder || other.encoder,
            electrical: self.electrical || other.electrical,
            overload: self.overload || other.overload,
        }
    }
}

/// Which bit of a vendor's alarm byte stands for each alarm.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AlarmBits {
    /// The mask of [`Alarms::input_voltage`].
    pub input_voltage: u8,
    /// The mask of [`Alarms::overheating`].
    pub overheating: u8,
    /// The mask of [`Alarms::encoder`].
    pub encoder: u8,
    /// The mask of [`Alarms::electrical`].
    pub electrical: u8,
    /// The mask of [`Alarms::overload`].
    pub overload: u8,
}

impl AlarmBits {
    fn pairs(&self) -> [u8; 5] {
        [
            self.input_voltage,
            self.overheating,
            self.encoder,
            self.electrical,
            self.overload,
        ]
    }

    /// The alarms set in `bits`; bits this layout does not use are ignored.
    pub fn decode(&self, bits: u8) -> Alarms {
        let [input_voltage, overheating, encoder, electrical, overload] =
            self.pairs().map(|mask| bits & mask != 0);
        Alarms {
            input_voltage,
            overheating,
            encoder,
            electrical,
            overload,
        }
    }

    /// The byte a servo reports for `alarms`.
    pub fn encode(&self, alarms: &Alarms) -> u8 {
        let on = [
            alarms.input_voltage,
            alarms.overheating,
            alarms.encoder,
            alarms.electrical,
            alarms.overload,
        ];
        self.pairs()
            .into_iter()
            .zip(on)
            .filter(|(_, on)| *on)
            .fold(0, |bits, (mask, _)| bits | mask)
    }
}

impl Alarms {
    /// The name of every alarm that is set.
    pub fn names(&self) -> Vec<&'static str> {
        [
            (self.input_voltage, "input voltage"),
            (self.overheating, "overheating"),
            (self.encoder, "encoder"),
            (self.electrical, "electrical / over-current"),
            (self.overload, "overload"),
        ]
        .into_iter()
        .filter_map(|(on, name)| on.then_some(name))
        .collect()
    }
}

impl fmt::Display for Alarms {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names = self.names();
        if names.is_empty() {
            f.write_str("none")
        } else {
            f.write_str(&names.join(", "))
        }
    }
}
