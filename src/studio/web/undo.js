// Undo and redo: the editors' keys (Ctrl+Z; Ctrl+Shift+Z or Ctrl+Y; ⌘ on a Mac) and the two
// buttons send the session's `undo` and `redo` keys. The history is the server's (the teach
// state keeps it and journals it, the terminal shares it); the page only shows what the next
// undo or redo would do, from the snapshot.

// The key a press asks for, or null for any other press.
export function undoToken(e) {
  if (!(e.ctrlKey || e.metaKey) || e.altKey) return null;
  const key = e.key.toLowerCase();
  if (key === 'z') return e.shiftKey ? 'redo' : 'undo';
  if (key === 'y' && !e.shiftKey) return 'redo';
  return null;
}

// Sends undo and redo presses with `send` (outside the prompt's text box, whose own undo is
// the browser's).
export function installUndo(send) {
  document.addEventListener('keydown', e => {
    if (e.target.tagName === 'INPUT') return;
    const token = undoToken(e);
    if (!token) return;
    e.preventDefault();
    send({ key: token });
  });
}

// The buttons say what they would undo or redo, and are off when there is nothing.
export function showUndo(snapshot) {
  for (const which of ['undo', 'redo']) {
    const button = document.getElementById(which);
    const what = snapshot[which];
    button.disabled = !what;
    button.title = what ? `${which}: ${what} (${which === 'undo' ? 'Ctrl+Z' : 'Ctrl+Shift+Z'})` : `nothing to ${which}`;
  }
}
