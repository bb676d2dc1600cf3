// Edits not yet written: a mark in the header while the list differs from its file (the
// snapshot's `dirty`, the server's word), and the browser's "leave the page?" question while
// it does, so that a reload or a closed tab does not lose them unasked. (The edits are also in
// the journal; the question is for the user who did not know that.)

const mark = document.createElement('span');
mark.id = 'unsaved';
mark.className = 'badge unsaved';
mark.textContent = '● unsaved';
mark.title = 'the key list has edits not written to its file (w saves)';
mark.hidden = true;

// `snapshot` gives the latest snapshot (null before the first).
export function installUnsaved(snapshot) {
  document.getElementById('title').after(mark);
  window.addEventListener('beforeunload', e => {
    if (!snapshot()?.dirty) return;
    e.preventDefault();
    // Older browsers ask only when returnValue is set.
    e.returnValue = '';
  });
}

export function showUnsaved(s) {
  mark.hidden = !s.dirty;
}
