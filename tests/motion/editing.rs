//! The keyframe-list editing API that the teach pendant drives, and the file round trip.

use keypose::curve::Interp;
use keypose::sequence::{KeyValue, KeyframeList, Sequence};
use serde_json::json;

fn pose(deg: f64) -> Vec<(String, KeyValue)> {
    vec![("elbow_flex".to_string(), KeyValue::Joint(deg))]
}

fn elbow(list: &KeyframeList, index: usize) -> f64 {
    match list.sequence().keyframes[index].value("elbow_flex") {
        Some(KeyValue::Joint(v)) => *v,
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn build_navigate_reorder_and_delete_in_a_uniform_list() {
    let mut list = KeyframeList::new(Sequence::new("so101"));
    assert!(list.is_empty() && !list.is_dirty());
    for deg in [10.0, 20.0, 30.0] {
        list.insert_after(pose(deg));
    }
    assert_eq!(list.len(), 3);
    assert_eq!(list.current_index(), 2);
    assert!(list.is_dirty());
    assert!(!list.next_key(), "moved past the last key");
    assert!(list.previous_key());
    assert!(list.previous_key());
    assert!(!list.previous_key(), "moved before the first key");
    // Insert after the first: 10, 15, 20, 30.
    list.insert_after(pose(15.0));
    assert_eq!(list.current_index(), 1);
    assert_eq!(
        (0..4).map(|i| elbow(&list, i)).collect::<Vec<_>>(),
        [10.0, 15.0, 20.0, 30.0]
    );
    // Move 15 to the end: 10, 20, 30, 15; it stays current.
    assert!(list.move_by(2));
    assert_eq!(list.current_index(), 3);
    assert_eq!(elbow(&list, 3), 15.0);
    assert!(!list.move_by(1));
    // Update the current key from a new pose, then delete it: the one before becomes current.
    assert!(list.update(pose(16.0)));
    assert_eq!(elbow(&list, 3), 16.0);
    assert_eq!(list.delete().map(|k| k.values), Some(pose(16.0)));
    assert_eq!(list.current_index(), 2);
    // Uniform spacing: key 2 sits at 2 × 2 s.
    assert_eq!(list.current_time(), Some(4.0));
    assert!(list.set_key_interval(1.5));
    assert_eq!(list.current_time(), Some(3.0));
    assert!(
        !list.set_key_interval(0.05),
        "accepted an interval below 0.1 s"
    );
    // The last key holds at most the interval (less 1 ms): a key added after it comes one
    // interval later (found by the journal fuzz target: a 5 s hold on the last key, then a new
    // key 2 s later, was journaled and did not load).
    assert!(!list.set_hold(1.5));
    assert!(list.set_hold(1.499));
    list.insert_after(pose(40.0));
    let saved = list.sequence().to_json();
    Sequence::from_json("t.json", &saved).unwrap();
}

#[test]
fn inserting_into_a_timed_list_goes_halfway_or_one_gap_on() {
    let text = r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
        {"name":"a","time":0,"hold":1,"joints":{"elbow_flex":0}},
        {"name":"b","time":3,"joints":{"elbow_flex":10}}]}"#;
    let mut list = KeyframeList::new(Sequence::from_json("t.json", text).unwrap());
    // After a (hold 1 s) and before b: halfway through the moving part, 1 + (3 − 1)/2 = 2.
    list.insert_after(pose(5.0));
    assert_eq!(list.current_time(), Some(2.0));
    // After the last key: one previous gap (3 − 2 = 1 s) later.
    assert!(list.next_key());
    list.insert_after(pose(20.0));
    assert_eq!(list.current_time(), Some(4.0));
    // Moving a key keeps the times where they were: the rhythm does not change. So a's 1 s
    // hold, moved to 2 s with b at 3 s, would end where b begins: refused until it is shorter
    // (found by the journal fuzz target: such a list was journaled and did not load).
    assert!(list.select(0));
    assert!(!list.move_by(1));
    assert_eq!(list.current_index(), 0);
    assert!(list.set_hold(0.5));
    assert!(list.move_by(1));
    let times: Vec<f64> = list.sequence().key_times();
    assert_eq!(times, [0.0, 2.0, 3.0, 4.0]);
    assert_eq!(list.sequence().keyframes[1].name.as_deref(), Some("a"));
    // A hold that would overrun the next key is refused.
    assert!(!list.set_hold(1.0));
    assert!(list.set_hold(0.5));
}

#[test]
fn a_key_added_after_a_long_final_hold_comes_after_the_hold() {
    // A file may hold its last key as long as it likes; uniformly spaced, a key added after it
    // one interval (2 s) later would be inside the 5 s hold.
    let text = r#"{"format":"keypose-sequence/1","robot":"so101","key_interval":2,"keyframes":[
        {"joints":{"elbow_flex":0}}, {"hold":5,"joints":{"elbow_flex":10}}]}"#;
    let mut list = KeyframeList::new(Sequence::from_json("t.json", text).unwrap());
    assert!(list.select(1));
    list.insert_after(pose(20.0));
    // The spacing made explicit, and the new key one interval after the hold: 2 + 5 + 2.
    assert_eq!(list.sequence().key_times(), [0.0, 2.0, 9.0]);
    Sequence::from_json("t.json", &list.sequence().to_json()).unwrap();
}

#[test]
fn save_is_atomic_and_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("taught.json");
    let mut list = KeyframeList::new(Sequence::new("so101"));
    list.insert_after(pose(0.0));
    list.insert_after(pose(45.5));
    assert!(list.set_name(Some("reach".into())));
    list.save(&path).unwrap();
    assert!(!list.is_dirty());
    // Nothing but the file itself is left in the directory: the temporary was renamed.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["taught.json"]);

    let loaded = KeyframeList::load(&path).unwrap();
    assert_eq!(loaded.len(), 2);
    assert_eq!(elbow(&loaded, 1), 45.5);
    assert_eq!(
        loaded.sequence().keyframes[1].name.as_deref(),
        Some("reach")
    );
    assert_eq!(loaded.sequence().key_interval, Some(2.0));
}

#[test]
fn saving_an_empty_list_is_refused_and_leaves_the_old_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("keep.json");
    let mut list = KeyframeList::new(Sequence::new("so101"));
    list.insert_after(pose(1.0));
    list.save(&path).unwrap();
    let before = std::fs::read_to_string(&path).unwrap();
    list.delete();
    assert!(list.save(&path).is_err());
    assert_eq!(std::fs::read_to_string(&path).unwrap(), before);
    assert!(list.is_dirty());
}

#[test]
fn keys_written_out_of_order_load_sorted_and_save_sorted() {
    let text = r#"{"format":"keypose-sequence/1","robot":"so101","keyframes":[
        {"name":"late","time":2,"joints":{"elbow_flex":20}},
        {"name":"early","time":0,"joints":{"elbow_flex":0}},
        {"name":"mid","time":1,"transforms":{"wrist_roll":{"r":{"w":0.7071068,"x":0,"y":0,"z":0.7071068}}}}]}"#;
    let sequence = Sequence::from_json("shuffled.json", text).unwrap();
    let names: Vec<_> = sequence
        .keyframes
        .iter()
        .map(|k| k.name.clone().unwrap())
        .collect();
    assert_eq!(names, ["early", "mid", "late"]);
    // The path of a key in errors still points into the file as written.
    assert_eq!(sequence.key_path(0), "$.keyframes[1]");
    let again = Sequence::from_json("again.json", &sequence.to_json()).unwrap();
    assert_eq!(again.keyframes.len(), 3);
    for (a, b) in again.keyframes.iter().zip(&sequence.keyframes) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.time, b.time);
        assert_eq!(a.values, b.values);
    }
}

#[test]
fn a_segment_mode_and_a_joint_value_are_set_on_the_current_key_and_written() {
    let mut list = KeyframeList::new(Sequence::new("so101"));
    assert!(!list.set_interp(Some(Interp::Step)), "no key yet");
    assert!(!list.set_value("gripper", KeyValue::Joint(5.0)));
    list.insert_after(pose(10.0));
    list.insert_after(pose(20.0));
    list.previous_key();
    assert!(list.set_interp(Some(Interp::Linear)));
    // Replaces the elbow, adds the gripper after it.
    assert!(list.set_value("elbow_flex", KeyValue::Joint(-5.5)));
    assert!(list.set_value("gripper", KeyValue::Joint(30.0)));
    let written: serde_json::Value = serde_json::from_str(&list.sequence().to_json()).unwrap();
    assert_eq!(
        written,
        json!({
            "format": "keypose-sequence/1",
            "robot": "so101",
            "interpolation": "monotone",
            "key_interval": 2.0,
            "keyframes": [
                {"interp": "linear", "joints": {"elbow_flex": -5.5, "gripper": 30.0}},
                {"joints": {"elbow_flex": 20.0}}
            ]
        })
    );
}

/// A timing profile belongs to the segment it was made for: inserting a key into that segment
/// splits it and drops its profile (the halves move at the pace of their key times), while the
/// other segments keep theirs; deleting a key joins two segments and drops the profile of the
/// one before it; a step segment keeps none. Saved, the list loads again.
#[test]
fn edits_drop_the_timing_profiles_of_the_segments_they_change() {
    let text = r#"{"format": "keypose-sequence/1", "robot": "so101", "keyframes": [
        {"time": 0, "timing": {"path_time": 1, "speeds": [0, 1, 0]}, "joints": {"elbow_flex": 0}},
        {"time": 2, "timing": {"path_time": 1, "speeds": [0, 2, 0]}, "joints": {"elbow_flex": 40}},
        {"time": 3, "joints": {"elbow_flex": 0}}]}"#;
    let timed = |list: &KeyframeList| -> Vec<bool> {
        list.sequence()
            .keyframes
            .iter()
            .map(|k| k.timing.is_some())
            .collect()
    };
    let mut list = KeyframeList::new(Sequence::from_json("t.json", text).unwrap());
    list.insert_at(pose(20.0), 1.0).unwrap();
    assert_eq!(timed(&list), [false, false, true, false]);
    let mut list = KeyframeList::new(Sequence::from_json("t.json", text).unwrap());
    assert!(list.select(2));
    list.delete();
    assert_eq!(timed(&list), [true, false]);
    let mut list = KeyframeList::new(Sequence::from_json("t.json", text).unwrap());
    assert!(list.select(1));
    assert!(list.set_interp(Some(Interp::Step)));
    assert_eq!(timed(&list), [true, false, false]);
    let again = Sequence::from_json("again.json", &list.sequence().to_json()).unwrap();
    assert_eq!(timed(&KeyframeList::new(again)), [true, false, false]);
    // Saved in the file's own layout, the profile left is kept as written, word for word.
    let kept = list.sequence().to_text();
    assert!(
        kept.contains(r#""timing": {"path_time": 1, "speeds": [0, 1, 0]}"#),
        "{kept}"
    );
    let again = Sequence::from_json("kept.json", &kept).unwrap();
    assert!(again.same_content(list.sequence()));
}

/// A hold's timing (`"hold"` in the key's timing, which `retime --fastest` writes under jerk
/// limits) times the key's hold: a key without a hold may not have one (refused, naming the
/// field), and setting a key's hold to 0 drops it, so the list still loads; another hold keeps
/// it (its S-curve is scaled to the new seconds).
#[test]
fn a_holds_timing_needs_a_hold_and_goes_when_the_hold_does() {
    let text = |hold: f64| {
        format!(
            r#"{{"format": "keypose-sequence/1", "robot": "so101", "keyframes": [
            {{"time": 0, "hold": {hold}, "timing": {{"path_time": 1, "scurve": [0.1, 0, 0.2],
              "hold": {{"path_time": 0.3, "scurve": [0.05, 0, 0]}}}}, "joints": {{"elbow_flex": 0}}}},
            {{"time": 2, "joints": {{"elbow_flex": 40}}}}]}}"#
        )
    };
    let err = Sequence::from_json("t.json", &text(0.0))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("$.keyframes[0].timing.hold") && err.contains("expected a \"hold\""),
        "{err}"
    );
    let sequence = Sequence::from_json("t.json", &text(0.4)).unwrap();
    assert_eq!(sequence.keyframes[0].hold_path_time(), 0.3);
    assert_eq!(sequence.path_times(), [0.0, 1.3]);
    let mut list = KeyframeList::new(sequence);
    assert!(list.set_hold(0.5));
    let hold = |list: &KeyframeList| list.sequence().keyframes[0].timing.as_ref().unwrap().hold;
    assert_eq!(hold(&list).unwrap().path_time, 0.3);
    assert!(list.set_hold(0.0));
    assert_eq!(hold(&list), None);
    let again = Sequence::from_json("again.json", &list.sequence().to_json()).unwrap();
    assert_eq!(again.path_times(), [0.0, 1.0]);
}

/// A timed list of keys at `times` (elbow 0, 10, 20, …), `hold` on key 1.
fn timed(times: &[f64], hold: f64) -> KeyframeList {
    let keys: Vec<serde_json::Value> = times
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let h = if i == 1 { hold } else { 0.0 };
            json!({"time": t, "hold": h, "joints": {"elbow_flex": 10.0 * i as f64}})
        })
        .collect();
    let text = json!({"format": "keypose-sequence/1", "robot": "so101", "keyframes": keys});
    KeyframeList::new(Sequence::from_json("t.json", &text.to_string()).unwrap())
}

#[test]
fn a_selection_grows_by_toggles_and_ranges_and_any_move_of_the_current_key_ends_it() {
    let mut list = timed(&[0.0, 1.0, 2.0, 3.0, 4.0], 0.0);
    assert_eq!(list.selection(), [0]);
    assert!(list.toggle_selected(3));
    assert!(list.toggle_selected(1));
    assert_eq!(list.selection(), [0, 1, 3]);
    assert!(list.toggle_selected(1), "a second toggle takes it out");
    assert_eq!(list.selection(), [0, 3]);
    // Taking the current key out makes the nearest selected one current.
    assert!(list.toggle_selected(0));
    assert_eq!((list.current_index(), list.selection()), (3, vec![3]));
    assert!(!list.toggle_selected(5), "no key 5");
    // A range runs from the current key, which stays current.
    assert!(list.select_range(1));
    assert_eq!((list.current_index(), list.selection()), (3, vec![1, 2, 3]));
    assert!(list.next_key());
    assert_eq!(
        list.selection(),
        [4],
        "stepping on leaves the current key alone"
    );
}

#[test]
fn selected_keys_move_in_time_together_or_not_at_all() {
    // Keys at 0, 1 (hold 0.5), 2, 3, 4; select 2 and 3.
    let mut list = timed(&[0.0, 1.0, 2.0, 3.0, 4.0], 0.5);
    assert!(list.select(2) && list.select_range(3));
    list.shift_selected(0.4).unwrap();
    assert_eq!(list.sequence().key_times(), [0.0, 1.0, 2.4, 3.4, 4.0]);
    // Key 4 is at 4.0: key 3 may reach 4.0 − 1 ms, so 0.6 s more is too far; the refusal
    // names that latest time for the first selected key (2.4 + 0.599 = 2.999).
    match list.shift_selected(0.6) {
        Err(keypose::sequence::TimeRefusal::Next { latest }) => {
            assert!((latest - 2.999).abs() < 1e-9, "{latest}")
        }
        other => panic!("expected a refusal at the next key, got {other:?}"),
    }
    assert_eq!(
        list.sequence().key_times(),
        [0.0, 1.0, 2.4, 3.4, 4.0],
        "moved"
    );
    // Back: key 1 holds until 1.5, so key 2 may come at 1.501 at the earliest.
    match list.shift_selected(-1.0) {
        Err(keypose::sequence::TimeRefusal::Previous { earliest }) => {
            assert!((earliest - 1.501).abs() < 1e-9, "{earliest}")
        }
        other => panic!("expected a refusal at the previous hold, got {other:?}"),
    }
    assert!(list.shift_selected(-5.0).is_err(), "before 0 s");
    Sequence::from_json("t.json", &list.sequence().to_json()).expect("still a valid file");
}

#[test]
fn pasted_keys_keep_their_spacing_after_the_current_key_and_push_the_rest_later() {
    // Keys at 0, 1, 3, 6; copy keys 1 and 2 (2 s apart) and paste them after key 0. The gap
    // after key 0 was 1 s, so the copies come at 1 and 3; the old key 1 keeps its 1 s gap to
    // what precedes it (now the copy at 3), so it and every later key move 3 s later.
    let mut list = timed(&[0.0, 1.0, 3.0, 6.0], 0.0);
    assert!(list.select(1) && list.select_range(2));
    let copied = list.copy_selected();
    assert_eq!(copied.len(), 2);
    assert!(list.select(0));
    list.paste_after(&copied).unwrap();
    assert_eq!(list.sequence().key_times(), [0.0, 1.0, 3.0, 4.0, 6.0, 9.0]);
    assert_eq!(
        (0..6).map(|i| elbow(&list, i)).collect::<Vec<_>>(),
        [0.0, 10.0, 20.0, 10.0, 20.0, 30.0]
    );
    assert_eq!((list.current_index(), list.selection()), (1, vec![1, 2]));
    // Deleting the pasted pair leaves the later keys where the paste put them.
    assert_eq!(list.delete_selected(), 2);
    assert_eq!(list.current_index(), 0);
    assert_eq!(list.sequence().key_times(), [0.0, 4.0, 6.0, 9.0]);
}

#[test]
fn pasting_into_a_uniform_list_takes_the_next_places() {
    let mut list = KeyframeList::new(Sequence::new("so101"));
    for deg in [10.0, 20.0, 30.0] {
        list.insert_after(pose(deg));
    }
    assert!(list.select(0));
    let copied = list.copy_selected();
    assert!(list.select(2));
    list.paste_after(&copied).unwrap();
    assert_eq!(list.sequence().key_interval, Some(2.0), "still uniform");
    assert_eq!(
        (0..4).map(|i| elbow(&list, i)).collect::<Vec<_>>(),
        [10.0, 20.0, 30.0, 10.0]
    );
    assert_eq!(list.current_time(), Some(6.0));
}
