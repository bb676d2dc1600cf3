// What the arm does against what was asked, on the timeline and in 3D: the playhead of a
// playback (the server's, from each snapshot) and of a simulation's replay (the page's, which
// can pause and be scrubbed), the time parked on the timeline (its pose on the ghost, a key
// captured there), and the three poses together — commanded on the ghost (blue), simulated
// on a second copy (purple), measured on the solid arm — with the tracking error (measured or
// simulated against commanded) drawn on the timeline.

const $ = id => document.getElementById(id);

// The first row of `trace` at or after sequence time t (rows of the approach ramp have none).
function rowAt(trace, t) {
  let best = -1;
  for (let i = 0; i < trace.sequence_time.length; i++) {
    const s = trace.sequence_time[i];
    if (s === null || s === undefined) continue;
    if (s >= t - 1e-9) return i;
    best = i;
  }
  return best;
}

// The key reached at sequence time t: the last key at or before it.
function keyAt(keys, t) {
  let k = 0;
  keys.forEach((key, i) => { if (key.time <= t + 1e-9) k = i; });
  return k;
}

// |a − b| per joint, in the screen's units (degrees; millimetres for prismatic joints).
function error(a, b, joints) {
  return joints.map((j, i) => Math.abs(a[i] - b[i]) * (j.value_unit === 'm' ? 1000 : 1));
}

// Per joint, the error series of (time, error per joint) samples, for Timeline.setErrors.
function series(samples, joints) {
  return {
    times: samples.map(s => s.t),
    joints: joints.map((_, j) => samples.map(s => s.error[j])),
    unit: joints.some(j => j.value_unit === 'm') ? '' : '°',
    largest: joints.map((_, j) => Math.max(0, ...samples.map(s => s.error[j]))),
  };
}

export class Playback {
  // `ghost(values)` shows values on the ghost (null: the page's own ghost again); `send(key)`
  // sends a key as the page's buttons do.
  constructor(timeline, view, { ghost, send, snapshot }) {
    this.timeline = timeline;
    this.view = view;
    this.ghost = ghost;
    this.send = send;
    this.snapshot = snapshot;
    this.simulated = view.addCopy(0xce93d8);
    this.trace = null;
    this.replaying = null;
    this.playing = false;
    this.samples = [];
    // For the browser test: every playhead the page drew, and the last tracking errors.
    this.seen = [];
    this.errors = {};
    this.bar();
  }

  // The transport bar above the timeline.
  bar() {
    const bar = document.createElement('div');
    bar.id = 'transport';
    bar.innerHTML = '<span id="playclock"></span>' +
      '<button id="replaypause" hidden>⏸ pause replay</button>' +
      '<button id="replayend" hidden>■ end replay</button>' +
      '<button id="captureat" hidden title="a new key from the present pose at the parked time">capture key here</button>' +
      '<button id="unpark" hidden title="the ghost shows the current key again">× unpark</button>' +
      '<span class="legend"><i class="commanded"></i>commanded (ghost) <i class="simulated"></i>simulated ' +
      '<i class="measured"></i>measured (the arm) <i class="velocity"></i>velocity / limit ' +
      '<i class="torque"></i>torque / line</span>';
    $('timeline').before(bar);
    $('replaypause').onclick = () => this.pause(!this.replaying.paused);
    $('replayend').onclick = () => this.endReplay();
    $('captureat').onclick = () => this.captureHere();
    $('unpark').onclick = () => this.timeline.park(null);
  }

  clock(text) { $('playclock').textContent = text; }

  // ----- a playback on the arm: the server's playhead -----

  follow(s) {
    const head = s.playhead;
    if (head) {
      this.playing = true;
      this.timeline.setPlayhead(head.time, head.key);
      this.ghost(head.commanded);
      this.simulated(this.trace ? this.trace.position[rowAt(this.trace, head.time)] || null : null);
      this.clock(`playing: ${head.time.toFixed(2)} s, key ${head.key} (${head.phase})`);
      this.seen.push({ time: head.time, key: head.key, phase: head.phase, at: performance.now() });
      if (this.seen.length > 2000) this.seen.shift();
      const present = s.joints.map(j => j.present);
      if (head.phase === 'play' && present.every(v => v !== null)) {
        this.samples.push({ t: head.time, error: error(present, head.commanded, s.joints) });
      }
      this.markKey(head.key);
    } else if (this.playing) {
      // The playback is over: what the arm did against what it was sent stays on the timeline.
      this.playing = false;
      this.timeline.setPlayhead(null, null);
      this.ghost(null);
      this.simulated(null);
      this.clock('');
      if (this.samples.length) this.setErrors('measured', series(this.samples, s.joints));
      this.samples = [];
      this.markKey(null);
    } else if (this.replaying) {
      this.markKey(this.timeline.playing);
    }
  }

  setErrors(source, errors) {
    this.errors[source] = errors;
    this.timeline.setErrors(source, errors);
  }

  // The key the playhead has reached, marked in the key list.
  markKey(key) {
    for (const row of document.querySelectorAll('#keys tr[data-index]')) {
      row.classList.toggle('playing', Number(row.dataset.index) === key);
    }
  }

  // ----- the simulation's replay: paused, scrubbed, ended -----

  replay(trace) {
    this.trace = trace;
    const joints = this.snapshot().joints;
    const samples = [];
    trace.position.forEach((p, i) => {
      const t = trace.sequence_time[i];
      if (t !== null && t !== undefined && trace.commanded) samples.push({ t, error: error(p, trace.commanded[i], joints) });
    });
    if (samples.length) this.setErrors('simulated', series(samples, joints));
    const me = this.replaying = { offset: 0, start: performance.now(), paused: false, row: 0 };
    $('replaypause').hidden = $('replayend').hidden = false;
    this.pause(false);
    const step = () => {
      const r = this.replaying;
      // Ended, or a newer replay took over.
      if (r !== me) return;
      if (!r.paused) {
        const t = r.offset + (performance.now() - r.start) / 1000;
        const row = trace.time.findIndex(x => x >= t);
        if (row < 0) { this.endReplay(); return; }
        this.showRow(row);
      }
      requestAnimationFrame(step);
    };
    requestAnimationFrame(step);
  }

  // Replay row `row`: the commanded pose on the ghost, the simulated one beside it.
  showRow(row) {
    const trace = this.trace, r = this.replaying;
    r.row = row;
    const t = trace.sequence_time[row];
    const keys = this.snapshot().keys;
    this.ghost(trace.commanded ? trace.commanded[row] : null);
    this.simulated(trace.position[row]);
    if (t === null || t === undefined) {
      this.timeline.setPlayhead(null, null);
      this.clock(`replay: approach ramp, ${trace.time[row].toFixed(2)} s`);
    } else {
      const key = keyAt(keys, t);
      this.timeline.setPlayhead(t, key);
      this.markKey(key);
      this.clock(`replay${r.paused ? ' (paused)' : ''}: ${t.toFixed(2)} s, key ${key}`);
      this.seen.push({ time: t, key, phase: 'replay', at: performance.now() });
    }
  }

  pause(on) {
    const r = this.replaying;
    if (!r) return;
    if (on && !r.paused) r.offset += (performance.now() - r.start) / 1000;
    if (!on && r.paused) r.start = performance.now();
    r.paused = on;
    $('replaypause').textContent = on ? '▶ resume replay' : '⏸ pause replay';
    if (on) this.showRow(r.row);
  }

  // Scrubbing during a replay: the replay pauses at the row of sequence time t.
  seek(t) {
    const r = this.replaying;
    const row = rowAt(this.trace, t);
    if (!r || row < 0) return;
    r.offset = this.trace.time[row];
    r.start = performance.now();
    this.pause(true);
    this.showRow(row);
  }

  endReplay() {
    this.replaying = null;
    $('replaypause').hidden = $('replayend').hidden = true;
    this.timeline.setPlayhead(null, null);
    this.ghost(null);
    this.simulated(null);
    this.markKey(null);
    this.clock('');
  }

  // ----- the timeline's cursor: scrubbed, parked, a key captured there -----

  // During a drag: a replay follows the cursor; otherwise the ghost shows the curves' pose.
  scrub(pose, t) {
    if (this.replaying) this.seek(t);
    else this.ghost(pose);
  }

  park(t, pose) {
    this.parkedAt = t;
    $('captureat').hidden = $('unpark').hidden = t === null;
    if (t !== null) $('captureat').textContent = `capture key at ${t.toFixed(2)} s`;
    if (this.replaying) { if (t !== null) this.seek(t); return; }
    this.ghost(t === null ? null : pose);
  }

  captureHere() {
    if (this.parkedAt === null || this.parkedAt === undefined) return Promise.resolve(false);
    return this.send(`capture-at:${Math.round(this.parkedAt * 1000)}`);
  }
}
