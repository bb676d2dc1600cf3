//! What the page shows, as JSON: the joints as the terminal shows them (through
//! [`crate::teach::format`]), the key list, the activity, the status line and the pending
//! question. Built from a [`TeachState`] after every change; the page holds no state of its
//! own beyond what it last received.

use crate::teach::format;
use crate::teach::Prompt;
use crate::teach::{selected_tool, Activity, MotionKind, TeachState};
use serde_json::{json, Value};

/// The snapshot of `state`; `controlled` says whether a page holds control now.
pub(crate) fn snapshot(state: &TeachState, bus: &str, controlled: bool) -> Value {
    let robot = state.robot();
    // The tool the handle and the readout act on: on a cell the selected joint's arm's, in
    // its base frame.
    let (tool_arm, tcp) = selected_tool(robot, state.selected(), state.present());
    json!({
        "robot": robot.name,
        "bus": bus,
        "output": state.output().display().to_string(),
        "dirty": state.is_dirty(),
        "joints": joints(state),
        "selected": state.selected(),
        "keys": keys(state),
        "current": (!state.list().is_empty()).then(|| state.list().current_index()),
        "interval": state.list().sequence().key_interval,
        "interpolation": state.list().sequence().interpolation.name(),
        "speed": state.speed(),
        "activity": activity(state.activity()),
        "status": {"text": state.status().text, "error": state.status().error},
        "prompt": prompt(state),
        "controlled": controlled,
        "tcp": [tcp.x, tcp.y, tcp.z],
        "tool_arm": tool_arm,
        "journal": state.journal().map(|j| j.path().display().to_string()),
        "quit": state.should_quit(),
        // What the next undo and redo would take back or make again (null: nothing).
        "undo": state.history().next_undo(),
        "redo": state.history().next_redo(),
    })
}

fn joints(state: &TeachState) -> Vec<Value> {
    let robot = state.robot();
    let key = state.list().show();
    let bearing = state.weight_bearing();
    robot
        .joints
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let present = state.present().get(j).copied().unwrap_or(f64::NAN);
            let key_value = key.and_then(|k| k.value(&joint.name));
            json!({
                "name": joint.name,
                "present": present.is_finite().then_some(present),
                "present_text": format::value_and_percent(joint, present),
                "goal": state.goals()[j],
                "key": key_value.and_then(|v| format::key_number(joint, v)),
                "key_text": key_value.map_or("·".into(), |v| format::key_text(joint, v)),
                "torque": state.torque()[j],
                "load": bearing[j],
                "min": joint.limits.min,
                "max": joint.limits.max,
                "limits_text": format::limits(joint),
                "unit": format::unit(joint).trim(),
                "value_unit": joint.kind.unit(),
            })
        })
        .collect()
}

fn keys(state: &TeachState) -> Vec<Value> {
    let robot = state.robot();
    let sequence = state.list().sequence();
    let n = sequence.keyframes.len();
    sequence
        .keyframes
        .iter()
        .enumerate()
        .map(|(i, key)| {
            let values: Vec<Option<f64>> = robot
                .joints
                .iter()
                .map(|joint| {
                    key.value(&joint.name)
                        .and_then(|v| format::key_number(joint, v))
                })
                .collect();
            json!({
                "label": format::key_label(sequence, i),
                "name": key.name,
                "time": sequence.key_time(i),
                "hold": key.hold,
                // The mode of the segment from this key; none after the last.
                "interp": (i + 1 < n).then(|| format::segment_interp(sequence, i).name()),
                "own_interp": key.interp.is_some(),
                "values": values,
            })
        })
        .collect()
}

fn activity(activity: &Activity) -> Value {
    match activity {
        Activity::Idle => json!({"kind": "idle", "text": "idle"}),
        Activity::Moving { kind, stops, .. } => {
            let (what, text) = match kind {
                MotionKind::ToKey(i) => ("to_key", format!("moving to key {i}")),
                MotionKind::Play { from } => ("play", format!("playing from key {from}")),
                MotionKind::Jog => ("jog", "jogging".to_string()),
            };
            let text = if *stops > 0 {
                format!("{text}, stopping")
            } else {
                text
            };
            json!({"kind": what, "text": text, "stopping": *stops > 0})
        }
    }
}

/// The pending question, and whether it wants a line of text or a yes/no.
fn prompt(state: &TeachState) -> Value {
    let Some(question) = format::question(state) else {
        return Value::Null;
    };
    match state.prompt() {
        Some(Prompt::Text { text, .. }) => {
            json!({"kind": "text", "question": question, "text": text})
        }
        _ => json!({"kind": "yesno", "question": question}),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::Robot;
    use crate::sequence::{KeyframeList, Sequence};
    use crate::teach::Key;

    #[test]
    fn the_snapshot_shows_what_the_terminal_shows() {
        let robot = Robot::builtin("so101").unwrap();
        let present = robot.home.clone();
        let list = KeyframeList::new(Sequence::new("so101"));
        let mut state = TeachState::new(robot, list, "taught.json".into(), None, present);
        // Two keys at home (no journal: the keys ask for no command), then N opens a prompt.
        for key in [Key::Char('n'), Key::Char('n'), Key::Char('N')] {
            let _ = state.handle_key(key);
        }
        let s = snapshot(&state, "virtual", false);
        // A new list is spaced 2 s apart and interpolated monotone; the last key has no
        // segment after it.
        assert_eq!(s["keys"][0]["time"], json!(0.0));
        assert_eq!(s["keys"][1]["time"], json!(2.0));
        assert_eq!(s["keys"][0]["interp"], json!("monotone"));
        assert!(s["keys"][1]["interp"].is_null());
        assert_eq!(s["current"], json!(1));
        assert_eq!(s["joints"][0]["present_text"], json!("0.0°"));
        // Torque is off until the start's hold is confirmed.
        assert_eq!(s["joints"][0]["torque"], json!(false));
        assert_eq!(s["dirty"], json!(true));
        assert_eq!(s["prompt"]["kind"], json!("text"));
        assert!(s["prompt"]["question"]
            .as_str()
            .unwrap()
            .starts_with("name of key 1"));
        assert_eq!(s["activity"]["kind"], json!("idle"));
    }
}
