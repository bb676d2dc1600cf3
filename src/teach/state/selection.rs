//! Several keys at once (the studio's Ctrl- and Shift-clicks): the selection, copy and paste,
//! delete, and a move in time of all of them. The rules of what may move where are the list's
//! ([`KeyframeList`]'s selection); here they become status lines and undoable edits.

use super::*;

impl TeachState {
    /// Adds key `index` to the selection or takes it out.
    pub(super) fn toggle_key(&mut self, index: usize) -> Vec<Command> {
        if !self.list.toggle_selected(index) {
            return self.no_such_key(index);
        }
        self.say_selection()
    }

    /// Selects the keys from the current one to `index`.
    pub(super) fn select_range(&mut self, index: usize) -> Vec<Command> {
        if !self.list.select_range(index) {
            return self.no_such_key(index);
        }
        self.say_selection()
    }

    fn no_such_key(&mut self, index: usize) -> Vec<Command> {
        self.fail(format!(
            "there is no key {index} ({})",
            format::count(self.list.len())
        ))
    }

    fn say_selection(&mut self) -> Vec<Command> {
        let selected = self.list.selection();
        let label = format::keys_label(self.list.sequence(), &selected);
        self.info(format!(
            "{label} selected (copy, delete or drag them in time together)"
        ));
        Vec::new()
    }

    /// Copies the selected keys (the list does not change).
    pub(super) fn copy_keys(&mut self) -> Vec<Command> {
        if self.list.is_empty() {
            return self.fail("no key to copy: n adds one from the present pose");
        }
        self.clipboard = self.list.copy_selected();
        let label = format::keys_label(self.list.sequence(), &self.list.selection());
        self.info(format!(
            "copied {label} (paste puts them after the current key)"
        ));
        Vec::new()
    }

    /// Inserts the copied keys after the current one.
    pub(super) fn paste_keys(&mut self) -> Vec<Command> {
        if self.clipboard.is_empty() {
            return self.fail("nothing copied yet: select keys and copy them first");
        }
        let keys = self.clipboard.clone();
        if let Err(why) = self.list.paste_after(&keys) {
            return self.fail(format!("nothing pasted: {why}"));
        }
        let label = format::keys_label(self.list.sequence(), &self.list.selection());
        self.info(format!(
            "pasted {} as {label} ({})",
            format::count(keys.len()),
            format::count(self.list.len())
        ));
        self.edited()
    }

    /// Deletes every selected key (one step of undo).
    pub(super) fn delete_keys(&mut self) -> Vec<Command> {
        let label = format::keys_label(self.list.sequence(), &self.list.selection());
        self.list.delete_selected();
        self.info(format!(
            "deleted {label} ({} left)",
            format::count(self.list.len())
        ));
        self.edited()
    }

    /// Moves every selected key `millis` ms in time, together.
    pub(super) fn shift_keys(&mut self, millis: i64) -> Vec<Command> {
        let selected = self.list.selection();
        let label = format::keys_label(self.list.sequence(), &selected);
        let delta = millis as f64 / 1000.0;
        if let Err(why) = self.list.shift_selected(delta) {
            return self.fail(format!("{label} stay where they were: {why}"));
        }
        self.info(format!("{label} moved {delta:+.3} s"));
        self.edited()
    }
}
