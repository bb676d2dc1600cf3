// Keyboard and screen-reader use of the page. The page's keys are the terminal's (Space goes
// to the key, arrows pick joints and jog), but a focused control keeps the keys a control
// takes everywhere else: Space and Enter press a focused button (the browser's own press, so
// the page's binding never sees them), and the key list, focused by Tab, moves its selection
// with the arrows. The list is an ARIA listbox whose selected option is the current key, and
// the status line is spoken by a live region.

const $ = id => document.getElementById(id);

// The keys a focused button or checkbox takes as its own press.
const PRESSES = new Set([' ', 'Enter']);

// `send` sends a key to the server as the page's bindings do.
export function installKeyboard(send) {
  const list = $('keys').tBodies[0];
  list.setAttribute('role', 'listbox');
  list.setAttribute('aria-label', 'keys');
  list.setAttribute('aria-multiselectable', 'true');
  list.tabIndex = 0;
  // On the window, in the capture phase: before the page's bindings, which listen on the
  // document; stopping the event there leaves the browser's default (the press) alone.
  window.addEventListener('keydown', e => {
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    const focused = e.target;
    if (focused.tagName === 'BUTTON' && PRESSES.has(e.key)) { e.stopPropagation(); return; }
    if (focused.type === 'checkbox' && PRESSES.has(e.key)) {
      e.stopPropagation();
      // A checkbox toggles on Space by itself; Enter toggles it as well.
      if (e.key === 'Enter') { e.preventDefault(); focused.click(); }
      return;
    }
    if (focused === list) listKey(e, list, send);
  }, true);
  speakStatus();
}

// Arrows move the selection within the list, Home and End to its ends, Enter goes to the
// selected key (the page's Space); other keys are the page's.
function listKey(e, list, send) {
  const count = list.rows.length;
  const selected = list.querySelector('tr.selected');
  const current = selected ? Number(selected.dataset.index) : -1;
  let to = null;
  if (e.shiftKey && (e.key === 'ArrowUp' || e.key === 'ArrowDown')) {
    // Shift+arrows extend the selection from the current key, as in a file list.
    e.stopPropagation();
    e.preventDefault();
    const chosen = [...list.querySelectorAll('tr.selected, tr.chosen')].map(r => Number(r.dataset.index));
    const end = e.key === 'ArrowUp' ? Math.min(...chosen) - 1 : Math.max(...chosen) + 1;
    if (end >= 0 && end < count) send({ key: `range-key:${end}` });
    return;
  }
  switch (e.key) {
    case 'ArrowUp': to = Math.max(current - 1, 0); break;
    case 'ArrowDown': to = Math.min(current + 1, count - 1); break;
    case 'Home': to = 0; break;
    case 'End': to = count - 1; break;
    case 'Enter': e.stopPropagation(); e.preventDefault(); send({ key: 'space' }); return;
    default: return;
  }
  e.stopPropagation();
  e.preventDefault();
  if (count && to !== current) send({ key: `select-key:${to}` });
}

// After the key list is drawn: each row an option, the selected ones selected, the current
// one named as the list's active option (the focus stays on the list, which is not redrawn).
export function showKeyList(s) {
  const list = $('keys').tBodies[0];
  const current = s.current;
  for (const row of list.rows) {
    const index = Number(row.dataset.index);
    row.id = `key-${index}`;
    row.setAttribute('role', 'option');
    row.setAttribute('aria-selected', String(Boolean(s.keys[index] && s.keys[index].selected)));
  }
  const active = current === null ? null : $(`key-${current}`);
  if (active) {
    list.setAttribute('aria-activedescendant', active.id);
    // Only for the keyboard's user: an edit made elsewhere does not scroll the page.
    if (document.activeElement === list) active.scrollIntoView({ block: 'nearest' });
  } else {
    list.removeAttribute('aria-activedescendant');
  }
}

// The status line, spoken: a polite live region that takes the line's text when it changes
// (the line is rewritten on every snapshot; the region only when there is something new).
function speakStatus() {
  const said = document.createElement('div');
  said.id = 'said';
  said.className = 'spoken';
  said.setAttribute('role', 'status');
  said.setAttribute('aria-live', 'polite');
  document.body.append(said);
  const status = $('status');
  new MutationObserver(() => {
    if (said.textContent !== status.textContent) said.textContent = status.textContent;
  }).observe(status, { childList: true, characterData: true, subtree: true });
}
