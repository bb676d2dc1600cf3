//! The vendor SDKs as a [`ServoBus`] (`--driver sdk`): ROBOTIS `dynamixel_sdk` and Feetech
//! `scservo_sdk`, driven through keypose's Python bridge `sim/sdk_bridge.py`.
//!
//! The bridge moves raw register values; this side owns their meaning: signs through
//! [`PositionEncoding`], units, alarm bits, and the mapping of the SDKs' communication results
//! and status error bytes onto [`BusError`]. Registers and units are each servo's own, from
//! its model's description, as in the native driver. It exists to compare our own drivers with the
//! vendors' code on the same servos, and as a fallback when ours misbehave.
//!
//! Reads are not retried here: the SDKs wait their own packet timeouts, and a caller that
//! wants a retry sees the typed error first.

use super::models::Servos;
use super::protocol::{codec, Codec, Status};
use super::{Alarms, BusError, CorruptAnswer, Health, PingInfo, ServoBus};
use crate::python::{Harness, HarnessError, HarnessOptions, PyConfig};
use crate::robot::{PositionEncoding, Protocol, ServoModel};
use crate::servo::{Register, RegisterTable};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::io;

/// The bridge script, as embedded by [`crate::python`].
pub const BRIDGE_SCRIPT: &str = "sdk_bridge.py";

/// A control-table register as the bridge takes it: address and size in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
struct Reg {
    addr: u16,
    len: u8,
}

impl From<Register> for Reg {
    fn from(register: Register) -> Reg {
        Reg {
            addr: register.address,
            len: register.size,
        }
    }
}

/// A request line of the bridge (`sim/sdk_bridge.py` documents them); the harness adds `seq`.
#[derive(Debug, Serialize)]
#[serde(tag = "op", rename_all = "snake_case")]
enum Request<'a> {
    Open {
        port: &'a str,
        baud: u32,
        protocol: &'static str,
    },
    Ping {
        id: u8,
    },
    Read {
        id: u8,
        #[serde(flatten)]
        reg: Reg,
    },
    Write {
        id: u8,
        #[serde(flatten)]
        reg: Reg,
        value: u32,
    },
    SyncRead {
        #[serde(flatten)]
        reg: Reg,
        ids: &'a [u8],
    },
    SyncWrite {
        #[serde(flatten)]
        reg: Reg,
        values: Vec<(u8, u32)>,
    },
}

/// The reply to a `read`.
#[derive(Debug, Deserialize)]
struct ValueReply {
    value: u32,
}

/// The reply to a `sync_read`.
#[derive(Debug, Deserialize)]
struct ValuesReply {
    values: Vec<u32>,
}

/// The reply to a `ping`: what the servo is.
#[derive(Debug, Deserialize)]
struct PingReply {
    model_number: u16,
    /// Feetech's ping carries none; a number that is no byte is taken as none too.
    firmware: Option<u64>,
}

/// A reply with `"ok": false`, by its `kind`: the members that map it onto [`BusError`].
#[derive(Debug, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
enum Failure {
    /// The SDK's communication result.
    Comm {
        comm: Option<String>,
        comm_kind: Option<CommKind>,
        servo: Option<u8>,
        elapsed_ms: Option<f64>,
    },
    /// The status packet's error byte was not zero.
    Servo {
        servo_error: Option<String>,
        servo_error_code: Option<u8>,
        servo: Option<u8>,
        /// What the answer carried: a read's register value, a ping's model and firmware.
        value: Option<Value>,
    },
    /// The serial port could not be opened.
    Port {
        errno: Option<i32>,
        error: Option<String>,
    },
    /// A malformed request, a state, an unsupported or internal error.
    #[serde(other)]
    Other,
}

/// The SDKs' communication results keypose tells apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
enum CommKind {
    Timeout,
    Corrupt,
    TxFail,
    #[serde(other)]
    Other,
}

/// The bridge's account of a refused request (a reply whose members do not fit its kind is
/// taken for its message alone); `None` when the bridge did not answer.
fn failure(error: &HarnessError) -> Option<Failure> {
    Some(Failure::deserialize(error.reply()?).unwrap_or(Failure::Other))
}

/// A successful reply as the type its request expects; `what` says what it lacks otherwise.
fn parse_reply<R: DeserializeOwned>(
    reply: Value,
    servo: Option<u8>,
    what: impl FnOnce() -> String,
) -> Result<R, BusError> {
    R::deserialize(&reply).map_err(|_| BusError::BridgeReply {
        servo,
        what: what(),
        reply: reply.to_string(),
    })
}

/// Opening a bus through the SDKs: the Python side, or the bus itself.
#[derive(Debug, thiserror::Error)]
pub enum SdkError {
    /// The bridge process did not start or answer.
    #[error(transparent)]
    Harness(#[from] HarnessError),
    /// The SDK could not open the port or reach the servos.
    #[error(transparent)]
    Bus(#[from] BusError),
}

impl From<SdkError> for BusError {
    fn from(error: SdkError) -> BusError {
        match error {
            SdkError::Bus(error) => error,
            SdkError::Harness(error) => BusError::Bridge {
                error: Box::new(error),
            },
        }
    }
}

/// A servo bus driven by the vendor SDK of its protocol, in a Python bridge process of its own.
#[derive(Debug)]
pub struct SdkBus {
    harness: Harness,
    codec: &'static dyn Codec,
    port: String,
    baud: u32,
    /// The robot's servos: each one's values are converted with its own model's table.
    servos: Servos,
}

impl SdkBus {
    /// Opens `port` through the SDK of `protocol` for the given servos (id, model), starting
    /// the bridge with the Python environment from the process's variables (built on first
    /// use). Ids not listed can only be pinged.
    pub fn open(
        port: &str,
        baud: u32,
        protocol: Protocol,
        servos: &[(u8, ServoModel)],
    ) -> Result<SdkBus, SdkError> {
        let harness = Harness::start(BRIDGE_SCRIPT)?;
        SdkBus::with_harness(harness, port, baud, protocol, servos)
    }

    /// As [`SdkBus::open`], with the Python environment of `config`.
    pub fn open_in(
        config: &PyConfig,
        port: &str,
        baud: u32,
        protocol: Protocol,
        servos: &[(u8, ServoModel)],
    ) -> Result<SdkBus, SdkError> {
        let harness = Harness::start_in(config, BRIDGE_SCRIPT, HarnessOptions::default())?;
        SdkBus::with_harness(harness, port, baud, protocol, servos)
    }

    /// Opens `port` through a bridge that is already running (and has no port open).
    pub fn with_harness(
        mut harness: Harness,
        port: &str,
        baud: u32,
        protocol: Protocol,
        servos: &[(u8, ServoModel)],
    ) -> Result<SdkBus, SdkError> {
        let request = Request::Open {
            port,
            baud,
            protocol: protocol.name(),
        };
        if let Err(error) = harness.request(&request) {
            return Err(match failure(&error) {
                Some(Failure::Port { errno, error }) => {
                    SdkError::Bus(port_error(port, errno, error.as_deref()))
                }
                _ => SdkError::Harness(error),
            });
        }
        Ok(SdkBus {
            harness,
            codec: codec(protocol),
            port: port.to_string(),
            baud,
            servos: Servos::new(servos),
        })
    }

    /// The protocol the bridge speaks.
    pub fn protocol(&self) -> Protocol {
        self.codec.protocol()
    }

    /// The bridge, for its ready line (SDK and Python versions) and its stderr.
    pub fn harness(&self) -> &Harness {
        &self.harness
    }

    fn encoding(&self) -> PositionEncoding {
        self.protocol().position_encoding()
    }

    fn sdk_name(&self) -> &'static str {
        self.codec.vendor().sdk_module()
    }

    fn call(&mut self, request: &Request, about: Option<u8>) -> Result<Value, BusError> {
        match self.harness.request(request) {
            Ok(reply) => Ok(reply),
            Err(error) => Err(self.bus_error(error, about, true)),
        }
    }

    /// A register read that still yields the value when the status packet only carried alarm
    /// bits: the data is valid then, and health reports the alarms from their register.
    fn read_reg_despite_alarms(&mut self, id: u8, reg: Reg) -> Result<u32, BusError> {
        match self.harness.request(&Request::Read { id, reg }) {
            Ok(reply) => raw_value(reply, id),
            Err(error) => match self.alarm_only_value(&error) {
                Some(value) => raw_value(Value::from_iter([("value", value)]), id),
                None => Err(self.bus_error(error, Some(id), false)),
            },
        }
    }

    /// Whether the script's refusal is only the servo's alarm bits: the instruction was carried
    /// out. The codec says which status bytes are refusals (none on Feetech, an error number on
    /// Dynamixel).
    fn alarm_only(&self, error: &HarnessError) -> bool {
        match failure(error) {
            Some(Failure::Servo {
                servo_error_code: Some(code),
                ..
            }) => !matches!(self.codec.status(code), Status::Refused(_)),
            _ => false,
        }
    }

    /// The `value` of a reply whose only complaint is the servo's alarm bits.
    fn alarm_only_value(&self, error: &HarnessError) -> Option<Value> {
        if !self.alarm_only(error) {
            return None;
        }
        match failure(error)? {
            Failure::Servo { value, .. } => value.filter(|value| !value.is_null()),
            _ => None,
        }
    }

    /// Maps a failed request onto [`BusError`]. `follow_alert` allows one extra read of the
    /// Dynamixel hardware error register to name the alarms behind an Alert bit.
    fn bus_error(
        &mut self,
        error: HarnessError,
        about: Option<u8>,
        follow_alert: bool,
    ) -> BusError {
        let (Some(failure), HarnessError::Failed { message, .. }) = (failure(&error), &error)
        else {
            return BusError::Bridge {
                error: Box::new(error),
            };
        };
        // The SDK's own words when the reply has them, else the bridge's message.
        let said = |text: Option<String>| text.unwrap_or_else(|| message.clone());
        match failure {
            Failure::Comm {
                comm,
                comm_kind,
                servo,
                elapsed_ms,
            } => match (comm_kind, servo.or(about)) {
                (Some(CommKind::Timeout), Some(id)) => BusError::Timeout {
                    id,
                    timeout_ms: elapsed_ms.map_or(0, |ms| ms.round().max(0.0) as u64),
                },
                (Some(CommKind::Corrupt), Some(id)) => {
                    BusError::corrupt(id, CorruptAnswer::Sdk(said(comm)))
                }
                (Some(CommKind::TxFail), _) => BusError::Port {
                    port: self.port.clone(),
                    source: io::Error::other(said(comm)),
                },
                _ => self.sdk_failed(message),
            },
            Failure::Servo {
                servo_error,
                servo_error_code,
                servo,
                ..
            } => match servo.or(about) {
                Some(id) => self.servo_error(
                    id,
                    servo_error_code.unwrap_or(0),
                    said(servo_error),
                    follow_alert,
                ),
                None => self.sdk_failed(message),
            },
            Failure::Port { errno, error } => port_error(&self.port, errno, error.as_deref()),
            Failure::Other => BusError::Sdk {
                by: "vendor SDK bridge",
                message: message.clone(),
            },
        }
    }

    fn sdk_failed(&self, message: &str) -> BusError {
        BusError::Sdk {
            by: self.sdk_name(),
            message: message.to_string(),
        }
    }

    /// A status packet's error byte `code` from servo `id`, `text` the SDK's words for it.
    fn servo_error(&mut self, id: u8, code: u8, text: String, follow_alert: bool) -> BusError {
        match self.codec.status(code) {
            Status::Refused(_) => return BusError::Refused { id, reason: text },
            Status::Alarms(alarms) => return BusError::Alarm { id, alarms },
            // Only bits that stand for no alarm.
            Status::Done => {
                return BusError::Alarm {
                    id,
                    alarms: Alarms::default(),
                }
            }
            Status::Alert => {}
        }
        let (register, bits) = self.codec.alarm_register();
        let alarms = if follow_alert {
            self.read_reg_despite_alarms(id, register.into())
                .ok()
                .map(|raw| bits.decode(raw as u8))
        } else {
            None
        };
        match alarms {
            Some(alarms) => BusError::Alarm { id, alarms },
            // The alarms could not be named: say what the servo said.
            None => BusError::Refused { id, reason: text },
        }
    }

    /// One register of every servo in `ids`, as a bridge register: the robot's tables must
    /// agree on it for a sync transfer.
    fn common_reg(
        &self,
        ids: &[u8],
        pick: fn(&RegisterTable) -> Register,
    ) -> Result<Reg, BusError> {
        self.servos
            .common_register(ids, |table| Ok(pick(table)))
            .map(|(register, _)| register.into())
    }

    /// The raw value of `register` of servo `id`, decoded with its table's encoding.
    fn read_value(&mut self, id: u8, register: Register) -> Result<i64, BusError> {
        let raw = self.read_reg_despite_alarms(id, register.into())?;
        Ok(register.from_raw(raw))
    }

    /// Health from the model's table: units (an XL330's current differs from an XM430's) and
    /// alarm bits.
    fn read_one_health(&mut self, id: u8) -> Result<Health, BusError> {
        let table = self.servos.table(id)?;
        let bits = self.read_value(id, table.hardware_error)?;
        let load = self.read_value(id, table.present_load)?;
        let voltage = self.read_value(id, table.present_voltage)?;
        let temperature = self.read_value(id, table.present_temperature)?;
        let current = match table.present_current {
            Some((register, _)) => Some(self.read_value(id, register)?),
            None => None,
        };
        Ok(Health {
            id,
            temperature_c: table.temperature_c(temperature),
            voltage_v: table.voltage_v(voltage),
            load_percent: table.load_percent(load),
            current_a: table.current_a(load, current),
            alarms: table.alarms(bits as u8),
        })
    }
}

fn raw_value(reply: Value, id: u8) -> Result<u32, BusError> {
    parse_reply(reply, Some(id), || "reply has no register value".into())
        .map(|reply: ValueReply| reply.value)
}

/// The port that could not be opened: the OS's error when the bridge passed its number on,
/// else the bridge's words.
fn port_error(port: &str, errno: Option<i32>, error: Option<&str>) -> BusError {
    let source = match errno {
        // pyserial passes the OS's errno on; as an io::Error it keeps its kind (NotFound,
        // PermissionDenied, ResourceBusy) for callers that advise on it.
        Some(errno) => io::Error::from_raw_os_error(errno),
        None => io::Error::other(error.unwrap_or("cannot open the port").to_string()),
    };
    BusError::Port {
        port: port.to_string(),
        source,
    }
}

impl ServoBus for SdkBus {
    fn describe(&self) -> String {
        let version = self
            .harness
            .ready()
            .get(self.sdk_name())
            .and_then(Value::as_str)
            .unwrap_or("unknown version");
        format!(
            "{} via {} {version} on {} at {}",
            self.protocol().name(),
            self.sdk_name(),
            self.port,
            self.baud
        )
    }

    fn ping(&mut self, id: u8) -> Result<PingInfo, BusError> {
        // A servo with an alarm still answers a ping with what it is: the alarms go into the
        // answer, so they do not make the servo missing.
        let (found, alarms) = match self.harness.request(&Request::Ping { id }) {
            Ok(reply) => (reply, Alarms::default()),
            Err(error) => match self.alarm_only_value(&error) {
                Some(found) => match self.bus_error(error, Some(id), true) {
                    BusError::Alarm { alarms, .. } => (found, alarms),
                    // The Alert bit whose alarms could not be read.
                    _ => (found, Alarms::default()),
                },
                None => return Err(self.bus_error(error, Some(id), true)),
            },
        };
        let found: PingReply =
            parse_reply(found, Some(id), || "ping reply has no model number".into())?;
        Ok(PingInfo {
            id,
            model_number: found.model_number,
            firmware: found
                .firmware
                .and_then(|firmware| u8::try_from(firmware).ok()),
            alarms,
        })
    }

    fn read_positions(&mut self, ids: &[u8]) -> Result<Vec<i64>, BusError> {
        if ids.is_empty() {
            return Ok(Vec::new());
        }
        let reg = self.common_reg(ids, |t| t.present_position)?;
        let raws: Vec<u32> = if self.codec.instructions().sync_read.is_none() {
            // SCS servos do not answer Sync Read. Alarm bits in the answers are let through, as
            // a sync read (which never sees them) does on the other protocols: the position is
            // valid, and alarms are read_health's to report.
            ids.iter()
                .map(|&id| self.read_reg_despite_alarms(id, reg))
                .collect::<Result<_, _>>()?
        } else {
            let reply = self.call(&Request::SyncRead { reg, ids }, None)?;
            let what = || format!("sync read reply does not hold {} values", ids.len());
            let text = reply.to_string();
            let ValuesReply { values } = parse_reply(reply, None, what)?;
            if values.len() != ids.len() {
                return Err(BusError::BridgeReply {
                    servo: None,
                    what: what(),
                    reply: text,
                });
            }
            values
        };
        let encoding = self.encoding();
        Ok(raws.into_iter().map(|raw| encoding.decode(raw)).collect())
    }

    fn write_goals(&mut self, goals: &[(u8, i64)]) -> Result<(), BusError> {
        if goals.is_empty() {
            return Ok(());
        }
        let ids: Vec<u8> = goals.iter().map(|&(id, _)| id).collect();
        let reg = self.common_reg(&ids, |t| t.goal_position)?;
        let encoding = self.encoding();
        let values = goals
            .iter()
            .map(|&(id, tick)| {
                encoding
                    .encode(tick)
                    .map(|raw| (id, raw))
                    .map_err(|error| BusError::GoalUnencodable { id, error })
            })
            .collect::<Result<Vec<_>, _>>()?;
        self.call(&Request::SyncWrite { reg, values }, None)
            .map(drop)
    }

    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        let mut first_error = None;
        for &id in ids {
            let reg = Reg::from(self.servos.table(id)?.torque_enable);
            // One confirmed write per servo rather than an unanswered sync write: torque is
            // the safety switch, and its failure must name the servo.
            let request = Request::Write {
                id,
                reg,
                value: u32::from(on),
            };
            let error = match self.harness.request(&request) {
                Ok(_) => continue,
                // A servo with an alarm did release: that is what a stop after a fault needs,
                // not an error. Switching on with an alarm is refused below.
                Err(error) if !on && self.alarm_only(&error) => continue,
                Err(error) => self.bus_error(error, Some(id), true),
            };
            if on {
                return Err(error);
            }
            // Releasing goes on past a failing servo: one fault must not leave the others
            // holding the arm.
            first_error.get_or_insert(error);
        }
        first_error.map_or(Ok(()), Err)
    }

    fn read_homing_offsets(&mut self, servos: &[(u8, ServoModel)]) -> Result<Vec<i64>, BusError> {
        // The bridge gives the register as an unsigned number; its sign convention
        // (sign-magnitude on Feetech, two's complement on Dynamixel) is the table's.
        servos
            .iter()
            .map(|&(id, model)| {
                let register = model.spec().table.homing_offset;
                let register = register.ok_or(BusError::MissingRegister {
                    id,
                    register: super::homing::REGISTER,
                })?;
                self.read_value(id, register)
            })
            .collect()
    }

    fn read_health(&mut self, ids: &[u8]) -> Result<Vec<Health>, BusError> {
        ids.iter().map(|&id| self.read_one_health(id)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use serde_json::json;

    /// The system's reason a bridge could not start reaches the person, once.
    #[test]
    fn a_bridge_that_cannot_start_says_why() {
        let error = BusError::Bridge {
            error: Box::new(HarnessError::Spawn {
                python: "python3".into(),
                script: BRIDGE_SCRIPT.into(),
                source: std::io::Error::other("permission denied"),
            }),
        };
        assert_eq!(
            crate::error::Report(&error).to_string(),
            format!("vendor SDK bridge: cannot start python3 {BRIDGE_SCRIPT}: permission denied")
        );
    }

    /// `reply` as the harness hands a refused request over.
    fn refused(reply: Value) -> HarnessError {
        HarnessError::Failed {
            script: BRIDGE_SCRIPT.into(),
            op: "open".into(),
            message: "x".into(),
            reply: Box::new(reply),
        }
    }

    fn port_failure(reply: Value) -> BusError {
        match failure(&refused(reply)) {
            Some(Failure::Port { errno, error }) => {
                port_error("/dev/ttyNOPE", errno, error.as_deref())
            }
            other => panic!("expected a port failure, got {other:?}"),
        }
    }

    #[test]
    fn port_errors_keep_the_os_error_kind() {
        let reply = json!({"ok": false, "kind": "port", "error": "x", "errno": 2});
        let error = port_failure(reply);
        let text = error.to_string();
        assert!(text.contains("/dev/ttyNOPE"), "{text}");
        match error {
            BusError::Port { source, .. } => assert_eq!(source.kind(), io::ErrorKind::NotFound),
            other => panic!("expected a port error, got {other:?}"),
        }
        let reply = json!({"ok": false, "kind": "port", "error": "Could not configure port", "errno": null});
        assert!(port_failure(reply)
            .to_string()
            .contains("Could not configure port"));
    }

    #[test]
    fn raw_values_must_be_unsigned_32_bit() {
        assert_eq!(raw_value(json!({"value": 4095}), 1).ok(), Some(4095));
        assert!(raw_value(json!({"value": -1}), 1).is_err());
        assert!(raw_value(json!({"value": 1u64 << 32}), 1).is_err());
        let missing = raw_value(json!({}), 1).unwrap_err().to_string();
        assert_eq!(
            missing,
            "servo 1: the SDK bridge's reply has no register value: {}"
        );
    }

    #[test]
    fn requests_keep_the_bridge_wire_format() {
        let reg = Reg { addr: 132, len: 4 };
        let line = |request: &Request| serde_json::to_value(request).unwrap();
        assert_eq!(
            line(&Request::Read { id: 3, reg }),
            json!({"op": "read", "id": 3, "addr": 132, "len": 4})
        );
        assert_eq!(
            line(&Request::SyncWrite {
                reg,
                values: vec![(1, 2048), (2, 0)]
            }),
            json!({"op": "sync_write", "addr": 132, "len": 4, "values": [[1, 2048], [2, 0]]})
        );
        assert_eq!(
            line(&Request::SyncRead { reg, ids: &[1, 2] }),
            json!({"op": "sync_read", "addr": 132, "len": 4, "ids": [1, 2]})
        );
    }

    #[test]
    fn unknown_failure_kinds_are_the_bridges_words() {
        let kinds = [
            "request",
            "state",
            "unsupported",
            "internal",
            "a kind to come",
        ];
        for kind in kinds {
            let reply = json!({"ok": false, "kind": kind, "error": "x"});
            assert!(
                matches!(failure(&refused(reply)), Some(Failure::Other)),
                "{kind}"
            );
        }
    }
}
