// Several keys at once, as keyframe editors select them: a click on a key (in the list or on
// the timeline) makes it current, Ctrl-click (⌘ on a Mac) adds or removes it, Shift-click
// selects the keys from the current one to it; Shift+↑/↓ in the focused list extends the
// selection. Ctrl+C copies the selected keys, Ctrl+V pastes them after the current key, Ctrl+A
// selects every key. Delete (`d`), and a drag of one of them on the timeline, act on all of
// them. The selection is the server's (the snapshot's `selected`); the page only asks.

// The key a click on key `index` sends, by its modifiers.
export function clickToken(e, index) {
  if (e.ctrlKey || e.metaKey) return `toggle-key:${index}`;
  if (e.shiftKey) return `range-key:${index}`;
  return `select-key:${index}`;
}

// The keys Ctrl+C, Ctrl+V and Ctrl+A send, outside text boxes, and only when no text of the
// page is selected (then Ctrl+C copies that text, as everywhere).
export function installSelection(send, snapshot) {
  document.addEventListener('keydown', e => {
    if (!(e.ctrlKey || e.metaKey) || e.altKey || e.shiftKey) return;
    if (e.target.tagName === 'INPUT') return;
    if (!window.getSelection().isCollapsed) return;
    const key = e.key.toLowerCase();
    const s = snapshot();
    if (key === 'c') { e.preventDefault(); send({ key: 'copy' }); }
    else if (key === 'v') { e.preventDefault(); send({ key: 'paste' }); }
    else if (key === 'a' && s && s.keys.length) {
      e.preventDefault();
      send({ key: 'select-key:0' }).then(ok => ok && send({ key: `range-key:${s.keys.length - 1}` }));
    }
  });
}
