//! The model descriptions: hand-computed register values and the tables' consistency.

use crate::bus::protocol::codec;
use crate::servo::{
    item, model_from_number, span, ByteOrder, Encoding, ModelSpec, Protocol, Register,
    RegisterError, RegisterTable, ServoModel, Vendor,
};

fn table(model: ServoModel) -> &'static RegisterTable {
    model.spec().table
}

fn model_number(model: ServoModel) -> u16 {
    model.spec().model_number
}

fn is_dynamixel(model: ServoModel) -> bool {
    model.vendor() == Vendor::Dynamixel
}

#[test]
fn sts_present_load_minus_50_percent() {
    let t = table(ServoModel::Sts3215);
    // −50 % = −500 tenths: magnitude 500 with the sign at bit 10, 500 + 1024 = 1524 =
    // 0x05F4, little-endian F4 05.
    let bytes = t.encode(&t.present_load, -500).unwrap();
    assert_eq!(bytes, [0xF4, 0x05]);
    let value = t.decode(&t.present_load, &[0xF4, 0x05]).unwrap();
    assert_eq!(value, -500);
    assert_eq!(t.load_percent(value), -50.0);
    // The same value on a big-endian (SCS) bus.
    assert_eq!(
        t.present_load.encode(-500, ByteOrder::Big).unwrap(),
        [0x05, 0xF4]
    );
    // Beyond the 10-bit magnitude.
    assert!(matches!(
        t.encode(&t.present_load, 1024),
        Err(RegisterError::OutOfRange { max: 1023, .. })
    ));
}

#[test]
fn sts_goal_position_and_homing_offset() {
    let t = table(ServoModel::Sts3215);
    // −100: 0x8064 → 64 80 (`scservo_sdk` SCS_TOSCS(-100, 15)).
    assert_eq!(t.encode(&t.goal_position, -100).unwrap(), [0x64, 0x80]);
    assert_eq!(t.encode(&t.goal_position, 2048).unwrap(), [0x00, 0x08]);
    // Homing offset −2047: 0x7FF | 0x800 = 0x0FFF → FF 0F.
    assert_eq!(
        t.encode(&t.homing_offset.unwrap(), -2047).unwrap(),
        [0xFF, 0x0F]
    );
    assert!(t.encode(&t.homing_offset.unwrap(), 2048).is_err());
    // Present position reading 0x8001 is −1.
    assert_eq!(t.decode(&t.present_position, &[0x01, 0x80]).unwrap(), -1);
}

#[test]
fn dynamixel_values() {
    let t = table(ServoModel::Xl430W250);
    // −131073 = 0xFFFD_FFFF → FF FF FD FF.
    assert_eq!(
        t.encode(&t.goal_position, -131073).unwrap(),
        [0xFF, 0xFF, 0xFD, 0xFF]
    );
    // Homing offset −1024 = 0xFFFF_FC00 → 00 FC FF FF.
    assert_eq!(
        t.encode(&t.homing_offset.unwrap(), -1024).unwrap(),
        [0x00, 0xFC, 0xFF, 0xFF]
    );
    // Present load −1000 (−100 %) = 0xFC18 → 18 FC.
    assert_eq!(t.encode(&t.present_load, -1000).unwrap(), [0x18, 0xFC]);
    assert_eq!(t.decode(&t.present_load, &[0x18, 0xFC]).unwrap(), -1000);
    assert_eq!(t.load_percent(-1000), -100.0);
    // 12.1 V = 121 = 0x0079.
    assert_eq!(t.decode(&t.present_voltage, &[0x79, 0x00]).unwrap(), 121);
    assert!((t.voltage_v(121) - 12.1).abs() < 1e-12);
    assert_eq!(t.temperature_c(41), 41.0);
    assert!(t.encode(&t.torque_enable, 256).is_err());
    assert!(t.encode(&t.torque_enable, -1).is_err());
}

#[test]
fn current_models_report_percent_of_stall_current() {
    let xm = table(ServoModel::Xm430W350);
    assert_eq!(xm.present_load.name, "Present_Current");
    // 855 units × 2.69 mA = 2300 mA (rounded) = the stall current.
    assert!((xm.load_percent(855) - 100.0).abs() < 0.01);
    assert_eq!(xm.current_milliamps(100), Some(269.0));
    let xl = table(ServoModel::Xl330M288);
    assert!((xl.load_percent(-735) + 50.0).abs() < 1e-9);
    assert_eq!(table(ServoModel::Xl430W250).current_milliamps(10), None);
}

#[test]
fn control_table_addresses() {
    for model in ServoModel::ALL.into_iter().filter(|&m| is_dynamixel(m)) {
        let t = table(model);
        let at = |r: Register| (r.address, r.size);
        assert_eq!(at(t.model_number_register), (0, 2));
        assert_eq!(at(t.torque_enable), (64, 1));
        assert_eq!(at(t.hardware_error), (70, 1));
        assert_eq!(at(t.goal_position), (116, 4));
        assert_eq!(at(t.present_load), (126, 2));
        assert_eq!(at(t.present_position), (132, 4));
        assert_eq!(at(t.present_voltage), (144, 2));
        assert_eq!(at(t.present_temperature), (146, 1));
    }
    let sts = table(ServoModel::Sts3215);
    assert_eq!(sts.goal_position.address, 42);
    assert_eq!(sts.present_position.address, 56);
    // Load at 60 to Present_Current at 69…70 (STS3215 memory table).
    assert_eq!(span(&sts.health_registers()), Some((60, 11)));
    assert_eq!(
        span(&table(ServoModel::Xm430W350).health_registers()),
        Some((70, 77))
    );
    assert_eq!(span(&[]), None);
}

#[test]
fn tables_are_consistent() {
    for model in ServoModel::ALL {
        let t = table(model);
        assert_eq!(model.spec().model, model);
        assert_eq!(ServoModel::parse(model.name()), Some(model));
        let registers = t.registers();
        for pair in registers.windows(2) {
            assert!(
                pair[0].end() <= pair[1].address,
                "{}: {} overlaps {}",
                model.name(),
                pair[0].name,
                pair[1].name
            );
        }
        for r in &registers {
            assert!(matches!(r.size, 1 | 2 | 4), "{}", r.name);
            if let Encoding::SignMagnitude { sign_bit } = r.encoding {
                assert!(r.size == 2 && sign_bit < 16, "{}", r.name);
            }
            if !is_dynamixel(model) {
                assert!(r.short_address().is_ok(), "{}", r.name);
            }
            assert_eq!(t.find(r.name), Some(*r));
        }
    }
}

#[test]
fn goal_position_encoding_agrees_with_the_protocol() {
    for model in ServoModel::ALL {
        let protocol = if is_dynamixel(model) {
            Protocol::Dynamixel2
        } else {
            Protocol::FeetechSts
        };
        let t = table(model);
        assert_eq!(
            t.goal_position.position_encoding(),
            Some(protocol.position_encoding())
        );
        assert_eq!(t.byte_order, codec(protocol).byte_order());
    }
    assert_eq!(codec(Protocol::FeetechScs).byte_order(), ByteOrder::Big);
}

#[test]
fn model_numbers() {
    let expected = [
        (ServoModel::Xl330M288, 1200),
        (ServoModel::Xl330M077, 1190),
        (ServoModel::Xl430W250, 1060),
        (ServoModel::Xm430W350, 1020),
        (ServoModel::Sts3215, 777),
    ];
    for (model, number) in expected {
        assert_eq!(model_number(model), number);
        let protocol = if is_dynamixel(model) {
            Protocol::Dynamixel2
        } else {
            Protocol::FeetechSts
        };
        assert_eq!(model_from_number(protocol, number), Some(model));
    }
    assert_eq!(model_from_number(Protocol::Dynamixel2, 777), None);
    assert_eq!(model_from_number(Protocol::FeetechSts, 1060), None);
    assert_eq!(
        model_from_number(Protocol::FeetechScs, 777),
        Some(ServoModel::Sts3215)
    );
    assert_eq!(model_from_number(Protocol::Dynamixel2, 0), None);
}

#[test]
fn alarms_dispatch_by_vendor() {
    // Bit 1 is the angle sensor on Feetech and unused on Dynamixel.
    assert!(table(ServoModel::Sts3215).alarms(0b10).encoder);
    assert!(!table(ServoModel::Xl430W250).alarms(0b10).any());
    assert!(table(ServoModel::Xl430W250).alarms(0b1000).encoder);
}

#[test]
fn block_decoding() {
    let t = table(ServoModel::Sts3215);
    // Load −50 %, 7.4 V, 35 °C, 0, status overheat, 3 more, current 100 × 6.5 mA: read
    // from 60.
    let block = [0xF4, 0x05, 74, 35, 0, 0b100, 0, 0, 0, 100, 0];
    let (start, len) = span(&t.health_registers()).unwrap();
    assert_eq!(usize::from(len), block.len());
    let get = |r: Register| r.decode_in_block(&block, start, t.byte_order).unwrap();
    assert_eq!(get(t.present_load), -500);
    assert_eq!(get(t.present_voltage), 74);
    assert_eq!(get(t.present_temperature), 35);
    assert!(t.alarms(get(t.hardware_error) as u8).overheating);
    let current = t.present_current.map(|(r, _)| get(r));
    assert_eq!(t.current_a(get(t.present_load), current), Some(0.65));
    assert!(matches!(
        t.present_position
            .decode_in_block(&block, start, t.byte_order),
        Err(RegisterError::OutsideBlock { .. })
    ));
    assert!(matches!(
        t.goal_position.decode(&[1], t.byte_order),
        Err(RegisterError::Size { .. })
    ));
}

#[test]
fn the_codecs_find_the_model_number_and_alarms_where_every_table_keeps_them() {
    // A scan reads both from a servo of unknown model, with the codec's registers.
    for model in ServoModel::ALL {
        let spec = model.spec();
        for protocol in Protocol::ALL.into_iter().filter(|&p| spec.model.speaks(p)) {
            let codec = codec(protocol);
            assert_eq!(
                codec.model_number_register(),
                spec.table.model_number_register,
                "{}",
                spec.name()
            );
            let (register, bits) = codec.alarm_register();
            let table = spec.table.hardware_error;
            assert_eq!(
                (register.address, register.size),
                (table.address, table.size)
            );
            assert_eq!(bits, spec.table.alarm_bits, "{}", spec.name());
        }
    }
}

#[test]
fn the_driver_registers_are_items_of_the_full_table() {
    // The registers the drivers use and the full control table cannot disagree: same name,
    // address, size and encoding.
    for model in ServoModel::ALL {
        let spec = model.spec();
        for register in spec.table.registers() {
            let item = spec
                .item(register.name)
                .unwrap_or_else(|| panic!("{}: no item {}", spec.name(), register.name));
            assert_eq!(item.register, register, "{}", spec.name());
        }
    }
}

#[test]
fn full_tables_are_ordered_without_overlaps_and_hold_their_defaults() {
    use item::Default;
    for model in ServoModel::ALL {
        let spec = model.spec();
        let mut items: Vec<_> = spec.all_items().collect();
        items.sort_by_key(|i| i.register.address);
        for pair in items.windows(2) {
            assert!(
                pair[0].register.end() <= pair[1].register.address,
                "{}: {} overlaps {}",
                spec.name(),
                pair[0].name(),
                pair[1].name()
            );
        }
        for item in &items {
            let (min, max) = item.register.range();
            if let Default::Value(value) = item.default {
                assert!((min..=max).contains(&value), "{}", item.name());
            }
            assert!(usize::from(item.register.end()) <= 256, "{}", item.name());
        }
        if let Some(register) = spec.table.operating_mode {
            let mode = spec.item(register.name).unwrap();
            let factory = match mode.default {
                Default::Value(v) => v,
                Default::Live => panic!("operating mode has a factory value"),
            };
            assert!(spec.operating_modes.contains(&factory), "{}", spec.name());
        }
    }
}

/// What a model without Operating_Mode or Homing_Offset cannot claim: modes to switch to, an
/// offset limit, a recalibration (which writes the offset).
fn claims_only_registers_it_has(spec: &ModelSpec) {
    if spec.table.operating_mode.is_none() {
        assert!(spec.operating_modes.is_empty(), "{}", spec.name());
        assert!(spec.modes.extended_position.is_none(), "{}", spec.name());
    }
    if spec.table.homing_offset.is_none() {
        assert!(spec.recalibrate.is_none(), "{}", spec.name());
        assert!(
            spec.modes.position_mode_offset_limit.is_none(),
            "{}",
            spec.name()
        );
    }
}

#[test]
fn models_without_operating_mode_or_homing_offset_claim_nothing_that_needs_them() {
    for model in ServoModel::ALL {
        assert!(model.spec().table.operating_mode.is_some());
        assert!(model.spec().table.homing_offset.is_some());
        claims_only_registers_it_has(model.spec());
    }
    claims_only_registers_it_has(&crate::servo::dynamixel_x::WITHOUT_OFFSET_OR_MODE);
}

#[test]
fn published_factory_values() {
    use item::Default::Value;
    // ROBOTIS e-Manual initial values; FT-MEM for the STS3215.
    let expected = [
        (ServoModel::Xl430W250, "Return_Delay_Time", 250),
        (ServoModel::Xl430W250, "Operating_Mode", 3),
        (ServoModel::Xl430W250, "Max_Position_Limit", 4095),
        (ServoModel::Xl430W250, "Velocity_Limit", 265),
        (ServoModel::Xm430W350, "Position_P_Gain", 800),
        (ServoModel::Xm430W350, "Current_Limit", 1193),
        (ServoModel::Xl330M288, "Current_Limit", 1750),
        (ServoModel::Sts3215, "Max_Position_Limit", 4095),
        (ServoModel::Sts3215, "P_Coefficient", 32),
        (ServoModel::Sts3215, "Max_Torque_Limit", 1000),
        (ServoModel::Sts3215, "Return_Delay_Time", 250),
    ];
    for (model, name, value) in expected {
        let item = model.spec().item(name).unwrap();
        assert_eq!(item.default, Value(value), "{} {name}", model.name());
    }
    assert!(ServoModel::Xl430W250.spec().item("Current_Limit").is_none());
    assert!(!ServoModel::Xl430W250.spec().operating_modes.contains(&5));
    assert!(ServoModel::Xm430W350.spec().operating_modes.contains(&5));
}
