// The studio page: shows the snapshots the server streams and sends keys, the same keys
// `keypose teach` takes. Every rule is the server's; this page only draws and asks.
import { ArmView } from '/view3d.js';
import { Timeline } from '/timeline.js';
import { ToolHandle } from '/handle.js';
import { Playback } from '/playhead.js';
import { Findings } from '/findings.js';
import { showContacts } from '/collision.js';
import { installUndo, showUndo } from '/undo.js';
import { installKeyboard, showKeyList } from '/a11y.js';
import { installUnsaved, showUnsaved } from '/unsaved.js';
import { installSelection, clickToken } from '/selection.js';
import { Easing } from '/easing.js';
import { request, watchStream, NO_ANSWER, SIMULATE_MS } from '/connection.js';

const token = new URLSearchParams(location.search).get('token') || '';
// The token was in the URL only to bring the page here: it leaves the address bar (and this
// history entry) at once, so that it is not on the screen, in a screenshot or a shared screen,
// nor taken along with a copied URL. (A reload then needs the URL the studio printed.)
history.replaceState(null, '', location.pathname);
const client = Array.from(crypto.getRandomValues(new Uint8Array(12)), b => b.toString(16).padStart(2, '0')).join('');
const $ = id => document.getElementById(id);
const headers = { 'X-Keypose-Token': token, 'X-Keypose-Client': client, 'Content-Type': 'application/json' };
const HEARTBEAT_MS = 700;

// What the page knows; exposed for the browser test and the latency figures.
const studio = window.studio = {
  snapshot: null, controller: false, refusals: [], latencies: [], arrivals: [], frames: [], loadMs: null, view: null,
  handle: null, targets: [],
  send, press: key => send({ key }), moveTool,
  // Resolves once the tool targets asked for so far have been answered.
  targetsDone: () => targeting || Promise.resolve(),
  // Resolves once every key sent so far has been answered.
  sent: () => pumping || Promise.resolve(),
  stop: () => stopNow(), stops: [],
};

function api(path, body, ms) {
  return request(path, { method: body ? 'POST' : 'GET', headers, body: body && JSON.stringify(body) }, ms);
}

// Keys go one after another, as typed: each waits for the answer to the one before, so
// that two quick presses never overtake each other on their way to the server. Two
// exceptions keep the arm answerable: a jog that has not left yet gives way to a newer one
// (a held key's repeats never pile up behind the arm), and a stop goes at once, dropping
// every key not yet sent (stopNow).
const waiting = [];
let pumping = null;
const isJog = body => typeof body.key === 'string' &&
  (/^(left|right|shift-left|shift-right|[xXcCzZ])$/.test(body.key) || body.key.startsWith('tool-target:'));
// The answer a key gets when it never left.
const notSent = why => ({ ok: false, status: 0, answer: { error: why }, dropped: true });

// `repeat`: the key is held (the keyboard's auto-repeat), so letting it go drops it.
function post(body, repeat = false) {
  return new Promise(resolve => {
    const last = waiting.at(-1);
    if (last && isJog(body) && isJog(last.body)) {
      last.resolve(notSent('replaced by a newer jog'));
      waiting[waiting.length - 1] = { body, resolve, repeat };
    } else {
      waiting.push({ body, resolve, repeat });
    }
    pumping = pumping || pump();
  });
}

async function pump() {
  try {
    while (waiting.length) {
      const { body, resolve } = waiting.shift();
      resolve(await postNow(body));
    }
  } finally {
    pumping = null;
  }
}

// Drops the keys not yet sent: all of them, or the repeats of a held key only.
function dropWaiting(why, repeatsOnly) {
  for (let i = waiting.length - 1; i >= 0; i--) {
    if (repeatsOnly && !waiting[i].repeat) continue;
    waiting[i].resolve(notSent(why));
    waiting.splice(i, 1);
  }
}

// The Stop button and Esc while the arm moves: sent at once, beside whatever key is on its
// way, never behind the queue; any page may stop, a watching one too.
async function stopNow() {
  dropWaiting('dropped: Stop came after it', false);
  studio.stops.push(performance.now());
  const reply = await api('/api/key', { key: 'stop' });
  if (!reply.ok) showStatus(reply.answer.error || 'the stop was refused', true);
  return reply.ok;
}

// Whether the server took the key.
function send(body, repeat = false) {
  return post(body, repeat).then(r => r.ok);
}

async function postNow(body) {
  const reply = await api('/api/key', body);
  if (!reply.ok) {
    studio.refusals.push(reply.answer.error);
    showStatus(reply.answer.error || 'refused', true);
    if (reply.lost) setController(false, NO_ANSWER, true);
  } else if (reply.answer.status && !studio.snapshot?.prompt) {
    // The answer's status replaces whatever the page said before (a stale refusal too).
    showStatus(reply.answer.status.text, reply.answer.status.error);
  }
  return reply;
}

function showStatus(text, error) {
  $('status').textContent = text;
  $('status').className = error ? 'error' : '';
}

// ----- control: the first page to ask controls; the heartbeat keeps it -----

async function claim() {
  const { ok, answer } = await api('/api/control', {});
  setController(ok, ok ? '' : answer.error);
  return ok;
}

// Whether this page asks to control: while it does, the heartbeat goes on. A studio that
// does not answer for a moment (a busy machine) leaves the page watching, but still asking:
// the first answered beat (or key) takes control back, unless another page took it.
let asking = false;

function setController(on, reason, stillAsking = false) {
  studio.controller = on;
  asking = on || stillAsking;
  beating();
  $('control').textContent = on ? 'in control' : 'watching';
  $('control').className = 'badge ' + (on ? 'controller' : 'watcher');
  $('control').title = reason || '';
  $('take').hidden = on;
  if (studio.handle) studio.handle.setEnabled(on);
  if (!on && reason) showStatus(reason, true);
}

// The heartbeat beats on a worker's thread, so that drawing never starves it; only while
// this page controls and is seen. A hidden page lets its lease lapse (and a playback stop,
// since nobody sees the Stop button); back in view, it asks again, unless another one took it.
const heart = new Worker('/heartbeat.js');
heart.onmessage = ({ data }) => {
  if (data.ok !== studio.controller) {
    setController(data.ok, data.ok ? '' : data.answer.error, data.lost);
  } else if (!data.ok && !data.lost) {
    // Still asking after a moment without answers, and now refused: another page has it.
    setController(false, data.answer.error);
  }
};
let beats = false;
function beating() {
  const on = asking && !document.hidden;
  if (on !== beats) heart.postMessage({ beat: on, headers, ms: HEARTBEAT_MS });
  beats = on;
}
let hadControl = false;
document.addEventListener('visibilitychange', () => {
  if (document.hidden) hadControl = asking;
  else if (hadControl && !studio.controller) claim();
  beating();
});
$('take').onclick = claim;
window.addEventListener('pagehide', () => {
  if (studio.controller) fetch('/api/release', { method: 'POST', headers, keepalive: true });
});

// ----- keys: the terminal's bindings -----

function keyToken(e) {
  if (e.ctrlKey || e.metaKey || e.altKey) return null;
  switch (e.key) {
    case ' ': return 'space';
    case 'ArrowUp': return 'up';
    case 'ArrowDown': return 'down';
    case 'ArrowLeft': return e.shiftKey ? 'shift-left' : 'left';
    case 'ArrowRight': return e.shiftKey ? 'shift-right' : 'right';
    case 'Escape': return 'esc';
    case 'Enter': return 'enter';
    case 'Backspace': return 'backspace';
    default: return e.key.length === 1 ? e.key : null;
  }
}

const moving = () => studio.snapshot && studio.snapshot.activity.kind !== 'idle';

document.addEventListener('keydown', e => {
  if (e.target === $('answer')) return;
  if (e.target.tagName === 'INPUT') return;
  const token = keyToken(e);
  if (!token) return;
  e.preventDefault();
  if (token === 'esc' && (moving() || waiting.length)) stopNow();
  else send({ key: token }, e.repeat);
});
// A held key let go: its repeats not yet sent go (the server runs at most one more jog).
document.addEventListener('keyup', () => dropWaiting('the key was let go', true));

document.addEventListener('click', e => {
  const key = e.target.closest('button[data-key]');
  // A click blurs the button (the page's keys are the terminal's again); a keyboard press
  // (detail 0) keeps the focus where the keyboard put it.
  if (key) { send({ key: key.dataset.key }); if (e.detail) key.blur(); }
});
$('stop').onclick = () => stopNow();
installUndo(send);
installKeyboard(send);
installUnsaved(() => studio.snapshot);
installSelection(send, () => studio.snapshot);
$('ok').onclick = () => send({ line: $('answer').value });
$('answer').addEventListener('keydown', e => {
  if (e.key === 'Enter') { e.preventDefault(); send({ line: $('answer').value }); }
  if (e.key === 'Escape') { e.preventDefault(); send({ key: 'esc' }); }
});

// ----- drawing a snapshot -----

let lastJoints = '', lastKeys = '', lastPrompt = '', ghostOverride = null;

function render(s) {
  $('title').textContent = `${s.robot} on ${s.bus} · ${s.output}${s.dirty ? ' (unsaved)' : ''} · ` +
    (s.interval !== null ? `${s.interval.toFixed(1)} s between keys` : `timed keys, speed ×${s.speed.toFixed(1)}`);
  const joints = JSON.stringify([s.joints, s.selected]);
  if (joints !== lastJoints) { lastJoints = joints; renderJoints(s); }
  const keys = JSON.stringify([s.keys, s.current]);
  if (keys !== lastKeys) { lastKeys = keys; renderKeys(s); showKeyList(s); refreshTimeline(s); }
  const prompt = JSON.stringify(s.prompt);
  if (prompt !== lastPrompt) { lastPrompt = prompt; renderPrompt(s.prompt); }
  if (!s.prompt) showStatus(s.status.text, s.status.error);
  showUndo(s);
  showUnsaved(s);
  easing.show(s.easing);
  $('activity').textContent = `${s.activity.text} · ${s.journal ? 'journal ' + s.journal : 'no journal'}`;
  $('tcp').textContent = 'tool ' + (s.tool_arm ? `(${s.tool_arm}) ` : '') +
    // Rounded first, so a coordinate a hair below zero shows as 0, not −0.
    s.tcp.map(v => (Math.round(v * 1000) + 0).toFixed(0)).join(', ') + ' mm';
  if (studio.view) {
    studio.view.setToolJoint(s.selected);
    studio.view.setPose(s.joints.map(j => j.present));
    showGhost(ghostOverride);
    showContacts(studio.view, s.contacts || []);
    if (studio.handle) studio.handle.follow();
  }
  if (studio.playback) studio.playback.follow(s);
}

// The current key's ghost: its pose on the trajectory (where space goes; its own values
// when the list builds none).
function keyGhost(s) {
  const key = s && s.current !== null ? s.keys[s.current] : null;
  return key && $('ghost').checked ? key.pose || key.values : null;
}

// What the current key's pose touches (its ghost is drawn red), or null.
function keyContact(s) {
  const key = s && s.current !== null ? s.keys[s.current] : null;
  return (key && key.contact) || null;
}

// What the timeline or a playback shows on the ghost instead (null: the key's again, red
// where the key's pose touches something).
function showGhost(values) {
  ghostOverride = values;
  if (!studio.view) return;
  const s = studio.snapshot;
  studio.view.setGhost(ghostOverride || keyGhost(s), !ghostOverride && keyContact(s));
}

// Where the present value and the key's sit between the limits, in percent; placed by
// script after the row is built (the page's policy allows no inline styles).
function bar(j) {
  const at = v => (v === null ? null : Math.min(Math.max((v - j.min) / (j.max - j.min), 0), 1) * 100);
  const p = at(j.present), k = at(j.key);
  return `<span class="bar">${k === null ? '' : `<i class="key" data-at="${k}"></i>`}` +
    `${p === null ? '' : `<i class="present" data-at="${p}"></i>`}</span>`;
}

function text(value) {
  return String(value ?? '').replace(/[&<>"']/g, c => `&#${c.charCodeAt(0)};`);
}

function renderJoints(s) {
  $('joints').tBodies[0].innerHTML = s.joints.map((j, i) =>
    `<tr data-joint="${i}" class="${i === s.selected ? 'selected' : ''}"><td>${i === s.selected ? '▶ ' : ''}${text(j.name)}</td>` +
    `<td>${text(j.present_text)}</td><td>${text(j.key_text)}</td><td>${bar(j)}</td>` +
    `<td class="${j.torque ? 'hold' : 'limp'}">${j.torque ? 'hold' : 'limp'}${j.load ? ' · load' : ''}</td></tr>`).join('');
  for (const mark of $('joints').querySelectorAll('i[data-at]')) mark.style.left = `${mark.dataset.at}%`;
}

function renderKeys(s) {
  $('keyinfo').textContent = `(${s.keys.length}), default ${s.interpolation}`;
  $('keys').tBodies[0].innerHTML = s.keys.map((k, i) =>
    `<tr data-index="${i}" class="${i === s.current ? 'selected' : k.selected ? 'chosen' : ''}"><td>${i}</td><td>${text(k.name)}</td>` +
    `<td>${k.time.toFixed(2)}</td><td>${k.hold > 0 ? k.hold.toFixed(2) : ''}</td>` +
    `<td>${k.interp ? text(k.interp) + (k.own_interp ? '*' : '') : ''}</td></tr>`).join('');
}

$('keys').addEventListener('click', e => {
  const row = e.target.closest('tr[data-index]');
  if (row) send({ key: clickToken(e, row.dataset.index) });
});
$('joints').addEventListener('click', e => {
  const row = e.target.closest('tr[data-joint]');
  if (row) send({ key: `select-joint:${row.dataset.joint}` });
});

function renderPrompt(prompt) {
  $('prompt').hidden = !prompt;
  if (!prompt) {
    // The keys are the page's again, not the closed box's.
    if (document.activeElement === $('answer')) $('answer').blur();
    return;
  }
  $('question').textContent = prompt.kind === 'text' ? prompt.question.replace(/:[^:]*▏.*$/, '') : prompt.question;
  $('textanswer').hidden = prompt.kind !== 'text';
  $('yesno').hidden = prompt.kind !== 'yesno';
  $('direction').hidden = prompt.kind !== 'direction';
  if (prompt.kind === 'text') {
    $('answer').value = prompt.text;
    $('answer').focus();
  }
}

// ----- the timeline -----

// The snapshot whose timeline is still to fetch, and the fetch on its way.
let timelineTimer = null, timelineFetch = null;
const easing = studio.easing = new Easing($('easing'), $('easinginfo'), body => send(body));
const findings = studio.findings = new Findings($('findings'), t => timeline.park(t));
const timeline = new Timeline($('timeline'), {
  onScrub: (values, t) => (studio.playback ? studio.playback.scrub(values, t) : showGhost(values)),
  onPark: (t, values) => studio.playback && studio.playback.park(t, values),
  onKeyClick: (index, e) => send({ key: clickToken(e, index) }),
  // A drag of one of several selected keys moves all of them by the same time.
  onKeysShift: millis => send({ key: `shift-keys:${millis}` }),
  onKeyTime: async (index, millis) => {
    if (await send({ key: `select-key:${index}` })) send({ key: `key-time:${millis}` });
  },
});

studio.timelineView = timeline;

// At once, one request at a time: edits made while one is on its way are fetched together
// when it is back (a drag sends many), so an edit is redrawn without a wait of its own.
function refreshTimeline(s) {
  timelineTimer = s;
  if (!timelineFetch) timelineFetch = fetchTimeline();
}

async function fetchTimeline() {
  try {
    while (timelineTimer) {
      const s = timelineTimer;
      timelineTimer = null;
      const { answer } = await api('/api/timeline');
      const keys = s.keys.map((k, i) => ({ time: k.time, current: i === s.current, selected: k.selected }));
      timeline.set(answer, keys);
      findings.setCheck(answer.findings);
      studio.timeline = answer;
      // Which list the drawn timeline is of (its keys, as `render` compares them): a test that
      // points at a key's mark waits for the list shown now, not for any timeline with as many
      // keys.
      studio.timelineKeys = JSON.stringify([s.keys, s.current]);
    }
  } finally {
    timelineFetch = null;
  }
}

// ----- simulation: the list played in MuJoCo, the trace replayed on the ghost -----

$('simulate').onclick = async () => {
  $('simulation').textContent = 'simulating in MuJoCo…';
  const { ok, answer } = await api('/api/simulate', {}, SIMULATE_MS);
  if (!ok) { $('simulation').textContent = answer.error || 'the simulation failed'; return; }
  studio.simulation = answer;
  const report = answer.report, trace = answer.trace;
  // A finding's run time, as the sequence time the timeline shows (none during the ramp).
  const sequenceTime = t => {
    const i = trace.time.findIndex(x => x >= t);
    return i < 0 ? null : trace.sequence_time[i];
  };
  const findings = report.findings.map(f => ({ ...f, at: sequenceTime(f.time) }));
  timeline.setSimFindings(findings);
  studio.findings.setSimulation(findings);
  $('simulation').textContent = `simulation (${report.model}): ${report.passed ? 'passes' : 'FAILS'}, ` +
    `${findings.length} finding(s)`;
  // The trace replayed at its own pace: commanded on the ghost, simulated beside it.
  studio.playback.replay(trace);
};

// ----- the tool handle: dragged, the joints follow (solved and checked in Rust) -----

// At most 20 targets a second, one at a time: a target not yet sent gives way to a newer one,
// so a fast drag never queues up moves the arm would make long after the mouse stopped.
const TARGET_MS = 50;
let nextTarget = null, targeting = null;

function moveTool(position) {
  nextTarget = position;
  targeting = targeting || sendTargets();
}

async function sendTargets() {
  try {
    while (nextTarget) {
      const mm = nextTarget.map(v => (v * 1000).toFixed(1)).join(',');
      nextTarget = null;
      const started = performance.now();
      const { ok, answer } = await post({ key: `tool-target:${mm}` });
      const refused = !ok || answer.status.error;
      // How long the server took to solve, check and ramp it (for the documented figures).
      const ms = performance.now() - started;
      studio.targets.push({ mm, refused, ms, text: ok ? answer.status.text : answer.error });
      if (studio.targets.length > 200) studio.targets.shift();
      if (studio.handle) studio.handle.setRefused(refused);
      if (ms < TARGET_MS) await new Promise(resolve => setTimeout(resolve, TARGET_MS - ms));
    }
  } finally {
    // No await since the loop's test: a target asked for from here on starts a new loop.
    targeting = null;
  }
}

// ----- start: the robot, then the stream -----

async function start() {
  const { ok, answer: model } = await api('/api/robot');
  if (!ok) { showStatus(model.error || 'cannot load the robot', true); return; }
  studio.model = model;
  studio.view = new ArmView($('view'), model);
  studio.playback = new Playback(timeline, studio.view,
    { ghost: showGhost, send: key => send({ key }), snapshot: () => studio.snapshot });
  $('axes').onchange = e => studio.view.showAxes(e.target.checked);
  if (model.tcp || (model.arms || []).some(arm => arm.model.tcp)) {
    studio.handle = new ToolHandle(studio.view, moveTool);
  }
  await claim();
  const events = new EventSource(`/api/events?token=${encodeURIComponent(token)}&client=${client}`);
  events.onmessage = e => {
    const s = JSON.parse(e.data);
    studio.snapshot = s;
    // When each snapshot left the server and how long it took to arrive here.
    studio.arrivals.push({ seq: s.seq, at: s.at_ms, delay: Date.now() - s.at_ms });
    if (studio.arrivals.length > 1000) studio.arrivals.shift();
    render(s);
    // How long from the server's snapshot to the frame that shows it.
    studio.view.onFrame = () => {
      studio.view.onFrame = null;
      studio.latencies.push(Date.now() - s.at_ms);
      if (studio.latencies.length > 500) studio.latencies.shift();
      // When each pose read from the arm was drawn (the wall clock, which the emulated
      // servos' hand shares): the measured time from a servo's move to the screen.
      studio.frames.push({ at: Date.now(), present: s.joints.map(j => j.present) });
      if (studio.frames.length > 1000) studio.frames.shift();
      // From the navigation's start (performance's time origin) to the first drawn arm.
      if (studio.loadMs === null) studio.loadMs = performance.now();
    };
  };
  watchStream(events, () => setController(false, NO_ANSWER, asking), claim);
  events.addEventListener('end', () => {
    events.close();
    showStatus('the studio session has ended (keypose studio quit)', true);
    setController(false, 'session ended');
  });
}

start();
