//! What the page shows, as JSON: the joints as the terminal shows them (through
//! [`crate::teach::format`]), the key list, the activity, the status line and the pending
//! question. Built from a [`TeachState`] after every change; the page holds no state of its
//! own beyond what it last received.
//!
//! What the screen shows of a key is what the arm will do there: each key's pose is the
//! trajectory's at the key's time ([`KeyPoses`]: joints the key leaves out on their tracks,
//! tool keys solved), the pose `space` moves to; and while a playback runs, where it is
//! ([`Planned::playhead`]).

use crate::kinematics;
use crate::player::PlayheadAt;
use crate::robot::Robot;
use crate::sequence::{Keyframe, Sequence};
use crate::teach::format;
use crate::teach::Prompt;
use crate::teach::{selected_tool, Activity, MotionKind, TeachState};
use serde_json::{json, Value};

/// What the snapshot shows besides the state: the plan's poses and the playback's position.
#[derive(Debug, Default)]
pub(crate) struct Planned<'a> {
    /// Every key's pose on the trajectory (`None`: the list does not build into one).
    pub poses: Option<&'a [Vec<f64>]>,
    /// What each key's pose touches, in words (`None`: clear), as `poses` has them.
    pub contacts: &'a [Option<String>],
    /// Where the running playback is.
    pub playhead: Option<&'a PlayheadAt>,
}

/// Every key's pose as playback passes through it ([`crate::teach::key_poses`]), built again
/// only when the list changes: the snapshot is built at 50 Hz, the list changes by edits.
#[derive(Debug, Default)]
pub(crate) struct KeyPoses {
    of: Option<Sequence>,
    poses: Option<Vec<Vec<f64>>>,
    contacts: Vec<Option<String>>,
}

impl KeyPoses {
    /// The poses of `sequence`'s keys on `robot` (`None` when it builds no trajectory), and
    /// what each touches.
    pub(crate) fn of(
        &mut self,
        robot: &Robot,
        sequence: &Sequence,
    ) -> (Option<&[Vec<f64>]>, &[Option<String>]) {
        if self.of.as_ref() != Some(sequence) {
            self.poses = crate::teach::key_poses(robot, sequence).ok();
            self.contacts = self
                .poses
                .as_deref()
                .map_or_else(Vec::new, |p| crate::teach::pose_contacts(robot, p));
            self.of = Some(sequence.clone());
        }
        (self.poses.as_deref(), &self.contacts)
    }
}

/// The snapshot of `state`; `controlled` says whether a page holds control now.
pub(crate) fn snapshot(
    state: &TeachState,
    bus: &str,
    controlled: bool,
    planned: &Planned,
) -> Value {
    let robot = state.robot();
    // The tool the handle and the readout act on: on a cell the selected joint's arm's, in
    // its base frame.
    let (tool_arm, tcp) = selected_tool(robot, state.selected(), state.present());
    json!({
        "robot": robot.name,
        "bus": bus,
        "output": state.output().display().to_string(),
        "dirty": state.is_dirty(),
        "joints": joints(state, planned.poses),
        "selected": state.selected(),
        "keys": keys(state, planned.poses, planned.contacts),
        "playhead": planned.playhead.map(|at| playhead(state.list().sequence(), at)),
        "current": (!state.list().is_empty()).then(|| state.list().current_index()),
        "interval": state.list().sequence().key_interval,
        "interpolation": state.list().sequence().interpolation.name(),
        "speed": state.speed(),
        "activity": activity(state.activity()),
        "easing": easing(state),
        "status": {"text": state.status().text, "error": state.status().error},
        "prompt": prompt(state),
        "controlled": controlled,
        "tcp": [tcp.x, tcp.y, tcp.z],
        "tool_arm": tool_arm,
        "contacts": contacts(state),
        "journal": state.journal().map(|j| j.path().display().to_string()),
        "quit": state.should_quit(),
        // What the next undo and redo would take back or make again (null: nothing).
        "undo": state.history().next_undo(),
        "redo": state.history().next_redo(),
    })
}

/// The easing of the segment from the current key, for the page's curve and handles: the
/// shares of its path spent speeding up (`out`) and slowing down (`in`), whether the handles
/// may change them (a linear segment that is no tool line) and why not; null after the last key.
fn easing(state: &TeachState) -> Value {
    let list = state.list();
    let index = list.current_index();
    if index + 1 >= list.len() {
        return Value::Null;
    }
    let sequence = list.sequence();
    let key = &sequence.keyframes[index];
    let mode = format::segment_interp(sequence, index);
    let why = if key.line {
        Some("a straight tool line is timed by its own ease".to_string())
    } else if mode != crate::curve::Interp::Linear {
        Some(format!(
            "easing is for linear segments; this one is {} (p changes it)",
            mode.name()
        ))
    } else {
        None
    };
    let (out, into) = key.timing.as_ref().map_or((0.0, 0.0), |t| t.ease_shares());
    json!({
        "from": index,
        "to": index + 1,
        "allowed": why.is_none(),
        "why": why,
        "out": out,
        "in": into,
        "profiled": key.timing.is_some(),
    })
}

/// The parts near a contact or in one (`TeachState::near_contacts`), for the page to colour.
fn contacts(state: &TeachState) -> Vec<Value> {
    state
        .near_contacts()
        .iter()
        .map(|t| {
            json!({
                "kind": format!("{:?}", t.kind),
                "bodies": [t.bodies.0, t.bodies.1],
                "links": [t.links.0, t.links.1],
                "mm": t.distance * 1000.0,
                "text": t.describe(),
            })
        })
        .collect()
}

fn joints(state: &TeachState, poses: Option<&[Vec<f64>]>) -> Vec<Value> {
    let robot = state.robot();
    let key = state.list().show();
    let planned = poses.and_then(|p| p.get(state.list().current_index()));
    let solved = key.map(|k| solved_by_tool(robot, k));
    let bearing = state.weight_bearing();
    robot
        .joints
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            let present = state.present().get(j).copied().unwrap_or(f64::NAN);
            let key_value = key.and_then(|k| k.value(&joint.name));
            let on_plan = planned.map(|p| p[j]);
            let by_tool = solved.as_ref().is_some_and(|s| s[j]);
            json!({
                "name": joint.name,
                "present": present.is_finite().then_some(present),
                "present_text": format::value_and_percent(joint, present),
                "goal": state.goals()[j],
                // Where the arm is at the key (what `space` goes to): the key's own value,
                // or for a joint it leaves out, its track's (solved for a tool key).
                "key": on_plan.or_else(|| key_value.and_then(|v| format::key_number(joint, v))),
                "key_text": key_text(joint, key_value, on_plan, by_tool),
                "key_from": match (key_value, on_plan) {
                    (Some(_), _) => Some("key"),
                    (None, Some(_)) if by_tool => Some("tool"),
                    (None, Some(_)) => Some("curve"),
                    (None, None) => None,
                },
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

/// The key column: the key's value as written; a value the key leaves out, where the arm
/// will be there, said to come from the tool key's solution or from the joint's curve.
fn key_text(
    joint: &crate::robot::Joint,
    written: Option<&crate::sequence::KeyValue>,
    planned: Option<f64>,
    by_tool: bool,
) -> String {
    match (written, planned) {
        (Some(v), _) => format::key_text(joint, v),
        (None, Some(v)) if by_tool => format!("{} (tool)", format::value_and_percent(joint, v)),
        (None, Some(v)) => format!("{} (curve)", format::value_and_percent(joint, v)),
        (None, None) => "·".into(),
    }
}

/// By joint: whether `key`'s tool target gives its value (a joint on the chain to the tool of
/// an arm whose tool the key names, which the key does not set itself).
fn solved_by_tool(robot: &Robot, key: &Keyframe) -> Vec<bool> {
    let mut solved = vec![false; robot.joints.len()];
    let mut mark = |arm: &Robot, first: usize| {
        for (i, on) in kinematics::tool_joints(arm).into_iter().enumerate() {
            solved[first + i] |= on;
        }
    };
    if key.tool.is_some() && !robot.is_cell() {
        mark(robot, 0);
    }
    for arm in &robot.arms {
        if key.arm_tools.iter().any(|(name, _)| *name == arm.name) {
            mark(&arm.robot, arm.joints.start);
        }
    }
    for (j, joint) in robot.joints.iter().enumerate() {
        solved[j] &= key.value(&joint.name).is_none();
    }
    solved
}

/// Where the playback is: its sequence time, the key it has reached, the phase and the pose
/// it commands.
fn playhead(sequence: &Sequence, at: &PlayheadAt) -> Value {
    let reached = sequence
        .key_times()
        .partition_point(|&k| k <= at.sequence_time)
        .saturating_sub(1);
    json!({
        "time": at.sequence_time,
        "key": reached,
        "phase": at.phase,
        "commanded": at.commanded,
    })
}

fn keys(state: &TeachState, poses: Option<&[Vec<f64>]>, contacts: &[Option<String>]) -> Vec<Value> {
    let robot = state.robot();
    let sequence = state.list().sequence();
    let n = sequence.keyframes.len();
    let selection = state.list().selection();
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
                // Among the keys copy, delete and a drag in time act on (the current one too).
                "selected": selection.binary_search(&i).is_ok(),
                "hold": key.hold,
                // The mode of the segment from this key; none after the last.
                "interp": (i + 1 < n).then(|| format::segment_interp(sequence, i).name()),
                "own_interp": key.interp.is_some(),
                "values": values,
                "tool": key.tool.is_some() || !key.arm_tools.is_empty(),
                // Where the arm is at this key: the ghost and `space` show the same pose.
                "pose": poses.and_then(|p| p.get(i)),
                // What the arm touches there (the ghost is drawn red, `space` is refused).
                "contact": contacts.get(i).cloned().flatten(),
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

/// The pending question, and whether it wants a line of text, a yes/no, or the direction
/// check's answer for a joint (moved as drawn, or reversed).
fn prompt(state: &TeachState) -> Value {
    let Some(question) = format::question(state) else {
        return Value::Null;
    };
    match state.prompt() {
        Some(Prompt::Text { text, .. }) => {
            json!({"kind": "text", "question": question, "text": text})
        }
        Some(Prompt::Direction { joint }) => {
            json!({"kind": "direction", "question": question, "joint": joint})
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
        let s = snapshot(&state, "virtual", false, &Planned::default());
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
