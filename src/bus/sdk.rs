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
use super::registers::{Register, RegisterTable};
use super::{Alarms, BusError, CorruptAnswer, Health, PingInfo, ServoBus};
use crate::python::{Harness, HarnessError, HarnessOptions, PyConfig};
use crate::robot::{PositionEncoding, Protocol, ServoModel};
use serde_json::{json, Value};
use std::io;

/// The bridge script, as embedded by [`crate::python`].
pub const BRIDGE_SCRIPT: &str = "sdk_bridge.py";

/// A control-table register as the bridge takes it: address and size in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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

/// Opening a bus through the SDKs: the Python side, or the bus itself.
#[derive(Debug, thiserror::Error)]
pub enum SdkError {
    #[error(transparent)]
    Harness(#[from] HarnessError),
    #[error(transparent)]
    Bus(#[from] BusError),
}

impl From<SdkError> for BusError {
    fn from(error: SdkError) -> BusError {
        match error {
            SdkError::Bus(error) => error,
            SdkError::Harness(error) => BusError::Protocol(format!("vendor SDK bridge: {error}")),
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
        let request = json!({
            "op": "open",
            "port": port,
            "baud": baud,
            "protocol": protocol.name(),
        });
        match harness.request(&request) {
            Ok(_) => {}
            Err(HarnessError::Failed { reply, .. })
                if reply.get("kind").and_then(Value::as_str) == Some("port") =>
            {
                return Err(SdkError::Bus(port_error(port, &reply)));
            }
            Err(error) => return Err(SdkError::Harness(error)),
        }
        Ok(SdkBus {
            harness,
            codec: codec(protocol),
            port: port.to_string(),
            baud,
            servos: Servos::new(servos),
        })
    }

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

    fn call(&mut self, request: Value, about: Option<u8>) -> Result<Value, BusError> {
        match self.harness.request(&request) {
            Ok(reply) => Ok(reply),
            Err(error) => Err(self.bus_error(error, about, true)),
        }
    }

    /// A register read that still yields the value when the status packet only carried alarm
    /// bits: the data is valid then, and health reports the alarms from their register.
    fn read_reg_despite_alarms(&mut self, id: u8, reg: Reg) -> Result<u32, BusError> {
        match self.harness.request(&read_request(id, reg)) {
            Ok(reply) => raw_value(&reply, id),
            Err(error) => match self.alarm_only_value(&error) {
                Some(value) => raw_value(&json!({ "value": value }), id),
                None => Err(self.bus_error(error, Some(id), false)),
            },
        }
    }

    /// Whether the script's refusal is only the servo's alarm bits: the instruction was carried
    /// out. The codec says which status bytes are refusals (none on Feetech, an error number on
    /// Dynamixel).
    fn alarm_only(&self, error: &HarnessError) -> bool {
        let Some(reply) = error.reply() else {
            return false;
        };
        if reply.get("kind").and_then(Value::as_str) != Some("servo") {
            return false;
        }
        match servo_error_code(reply) {
            Some(code) => !matches!(self.codec.status(code), Status::Refused(_)),
            None => false,
        }
    }

    /// The `value` of a reply whose only complaint is the servo's alarm bits.
    fn alarm_only_value(&self, error: &HarnessError) -> Option<Value> {
        if !self.alarm_only(error) {
            return None;
        }
        error
            .reply()?
            .get("value")
            .filter(|value| !value.is_null())
            .cloned()
    }

    /// Maps a failed request onto [`BusError`]. `follow_alert` allows one extra read of the
    /// Dynamixel hardware error register to name the alarms behind an Alert bit.
    fn bus_error(
        &mut self,
        error: HarnessError,
        about: Option<u8>,
        follow_alert: bool,
    ) -> BusError {
        let HarnessError::Failed { reply, message, .. } = &error else {
            return BusError::Protocol(format!("vendor SDK bridge: {error}"));
        };
        let servo = reply
            .get("servo")
            .and_then(Value::as_u64)
            .and_then(|id| u8::try_from(id).ok())
            .or(about);
        let text = |key: &str| {
            reply
                .get(key)
                .and_then(Value::as_str)
                .unwrap_or(message)
                .to_string()
        };
        match reply.get("kind").and_then(Value::as_str) {
            Some("comm") => {
                let comm_kind = reply.get("comm_kind").and_then(Value::as_str);
                match (comm_kind, servo) {
                    (Some("timeout"), Some(id)) => BusError::Timeout {
                        id,
                        timeout_ms: reply
                            .get("elapsed_ms")
                            .and_then(Value::as_f64)
                            .map(|ms| ms.round().max(0.0) as u64)
                            .unwrap_or(0),
                    },
                    (Some("corrupt"), Some(id)) => {
                        BusError::corrupt(id, CorruptAnswer::Sdk(text("comm")))
                    }
                    (Some("tx_fail"), _) => BusError::Port {
                        port: self.port.clone(),
                        source: io::Error::other(text("comm")),
                    },
                    _ => BusError::Protocol(format!("{}: {message}", self.sdk_name())),
                }
            }
            Some("servo") => {
                let code = servo_error_code(reply).unwrap_or(0);
                let Some(id) = servo else {
                    return BusError::Protocol(format!("{}: {message}", self.sdk_name()));
                };
                match self.codec.status(code) {
                    Status::Refused(_) => {
                        return BusError::Refused {
                            id,
                            reason: text("servo_error"),
                        }
                    }
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
                    None => BusError::Refused {
                        id,
                        reason: text("servo_error"),
                    },
                }
            }
            Some("port") => port_error(&self.port, reply),
            _ => BusError::Protocol(format!("vendor SDK bridge: {message}")),
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
            .common_register(ids, pick)
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
        Ok(Health {
            id,
            temperature_c: table.temperature_c(temperature),
            voltage_v: table.voltage_v(voltage),
            load_percent: table.load_percent(load),
            alarms: table.alarms(bits as u8),
        })
    }
}

/// The servo's status error byte in a failed reply.
fn servo_error_code(reply: &Value) -> Option<u8> {
    reply
        .get("servo_error_code")
        .and_then(Value::as_u64)
        .and_then(|code| u8::try_from(code).ok())
}

fn read_request(id: u8, reg: Reg) -> Value {
    json!({ "op": "read", "id": id, "addr": reg.addr, "len": reg.len })
}

fn raw_value(reply: &Value, id: u8) -> Result<u32, BusError> {
    reply
        .get("value")
        .and_then(Value::as_u64)
        .and_then(|value| u32::try_from(value).ok())
        .ok_or_else(|| {
            BusError::Protocol(format!(
                "servo {id}: the SDK bridge's reply has no register value: {reply}"
            ))
        })
}

fn port_error(port: &str, reply: &Value) -> BusError {
    let source = match reply
        .get("errno")
        .and_then(Value::as_i64)
        .and_then(|errno| i32::try_from(errno).ok())
    {
        // pyserial passes the OS's errno on; as an io::Error it keeps its kind (NotFound,
        // PermissionDenied, ResourceBusy) for callers that advise on it.
        Some(errno) => io::Error::from_raw_os_error(errno),
        None => io::Error::other(
            reply
                .get("error")
                .and_then(Value::as_str)
                .unwrap_or("cannot open the port")
                .to_string(),
        ),
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
        let request = json!({ "op": "ping", "id": id });
        // A servo with an alarm still answers a ping with what it is: the alarms go into the
        // answer, so they do not make the servo missing.
        let (found, alarms) = match self.harness.request(&request) {
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
        let model_number = found
            .get("model_number")
            .and_then(Value::as_u64)
            .and_then(|model| u16::try_from(model).ok())
            .ok_or_else(|| {
                BusError::Protocol(format!(
                    "servo {id}: the SDK bridge's ping reply has no model number: {found}"
                ))
            })?;
        let firmware = found
            .get("firmware")
            .and_then(Value::as_u64)
            .and_then(|firmware| u8::try_from(firmware).ok());
        Ok(PingInfo {
            id,
            model_number,
            firmware,
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
            let request =
                json!({ "op": "sync_read", "addr": reg.addr, "len": reg.len, "ids": ids });
            let reply = self.call(request, None)?;
            let values = reply
                .get("values")
                .and_then(Value::as_array)
                .filter(|values| values.len() == ids.len())
                .ok_or_else(|| {
                    BusError::Protocol(format!(
                        "the SDK bridge's sync read reply does not hold {} values: {reply}",
                        ids.len()
                    ))
                })?;
            ids.iter()
                .zip(values)
                .map(|(&id, value)| raw_value(&json!({ "value": value }), id))
                .collect::<Result<_, _>>()?
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
                    .map(|raw| json!([id, raw]))
                    .map_err(|error| {
                        BusError::Protocol(format!("servo {id}: goal not sent: {error}"))
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let request =
            json!({ "op": "sync_write", "addr": reg.addr, "len": reg.len, "values": values });
        self.call(request, None).map(drop)
    }

    fn set_torque(&mut self, ids: &[u8], on: bool) -> Result<(), BusError> {
        let mut first_error = None;
        for &id in ids {
            let reg = Reg::from(self.servos.table(id)?.torque_enable);
            // One confirmed write per servo rather than an unanswered sync write: torque is
            // the safety switch, and its failure must name the servo.
            let request = json!({
                "op": "write", "id": id, "addr": reg.addr, "len": reg.len, "value": u32::from(on),
            });
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
            .map(|&(id, model)| self.read_value(id, model.spec().table.homing_offset))
            .collect()
    }

    fn read_health(&mut self, ids: &[u8]) -> Result<Vec<Health>, BusError> {
        ids.iter().map(|&id| self.read_one_health(id)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn port_errors_keep_the_os_error_kind() {
        let reply = json!({"ok": false, "kind": "port", "error": "x", "errno": 2});
        let error = port_error("/dev/ttyNOPE", &reply);
        let text = error.to_string();
        assert!(text.contains("/dev/ttyNOPE"), "{text}");
        match error {
            BusError::Port { source, .. } => assert_eq!(source.kind(), io::ErrorKind::NotFound),
            other => panic!("expected a port error, got {other:?}"),
        }
        let reply = json!({"ok": false, "kind": "port", "error": "Could not configure port", "errno": null});
        assert!(port_error("/dev/null", &reply)
            .to_string()
            .contains("Could not configure port"));
    }

    #[test]
    fn raw_values_must_be_unsigned_32_bit() {
        assert_eq!(raw_value(&json!({"value": 4095}), 1).ok(), Some(4095));
        assert!(raw_value(&json!({"value": -1}), 1).is_err());
        assert!(raw_value(&json!({"value": 1u64 << 32}), 1).is_err());
        assert!(raw_value(&json!({}), 1).is_err());
    }
}
