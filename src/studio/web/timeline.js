// The timeline: per joint, the position curve between its limits (the band), the velocity
// curve against its limit (dashed) and the servo's torque against its torque-speed line
// (dotted green, red where it is past the line: the band's edges are the line), the keys as
// vertical marks, check findings in red, a time
// axis in seconds. Dragging a key mark moves the key in time (the engine validates it);
// with several keys selected, dragging one of them moves them all (onKeysShift); a click
// selects (with Ctrl or Shift, adds to the selection: onKeyClick gets the event);
// dragging elsewhere scrubs, and letting go parks there (onPark): the ghost shows the pose at
// that time. A playback's playhead and the tracking error (what the arm or the simulation did
// against what was commanded) are drawn on it too. Everything is drawn in CSS pixels on a
// backing store of devicePixelRatio device pixels each, so that it is sharp on dense screens.

const ROW = 44;
const LEFT = 110;
const GRAB = 6;
// Below the rows: the key numbers, then the time axis.
const MARKS = 14;
const AXIS = 16;
// How far a key mark must be dragged before it moves: a plain click (a hand's jitter) only
// selects the key.
const DRAG_PX = 4;

export class Timeline {
  constructor(canvas, { onScrub, onKeyTime, onPark, onKeyClick, onKeysShift }) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.data = null;
    this.keys = [];
    this.onScrub = onScrub;
    this.onKeyTime = onKeyTime;
    this.onPark = onPark || (() => {});
    // Sequence time of the playback or replay, the key it has reached, and the parked time.
    this.playhead = null;
    this.playing = null;
    this.parked = null;
    // Tracking error per source ('measured', 'simulated'): { times, joints: [[error…]…] }.
    this.errors = {};
    this.onKeyClick = onKeyClick || (() => {});
    this.onKeysShift = onKeysShift || (() => {});
    this.drag = null;
    canvas.addEventListener('pointerdown', e => this.down(e));
    canvas.addEventListener('pointermove', e => this.move(e));
    canvas.addEventListener('pointerup', e => this.up(e));
    // A new width (a turned phone, a narrower window) or a new pixel density (a zoom, another
    // screen) needs a new backing store.
    window.addEventListener('resize', () => this.draw());
  }

  // The drawing's width in CSS pixels.
  get width() {
    return this.canvas.clientWidth || 800;
  }

  // The simulation's findings, at sequence times: marked on their joint's row (or all rows).
  setSimFindings(findings) {
    this.simFindings = findings.filter(f => f.at !== null && f.at !== undefined);
    this.draw();
  }

  set(data, keys) {
    this.data = data;
    this.keys = keys;
    // A parked time shows the pose there on the curves as they are now.
    if (this.parked !== null && !this.drag) this.onPark(this.parked, this.poseAt(this.parked));
    this.draw();
  }

  span() {
    const d = this.data;
    if (!d || d.empty) return [0, Math.max(1, ...this.keys.map(k => k.time))];
    return [Math.min(d.start, ...this.keys.map(k => k.time)), Math.max(d.end, ...this.keys.map(k => k.time), d.start + 0.1)];
  }

  x(t) {
    const [a, b] = this.span();
    return LEFT + (t - a) / (b - a) * (this.width - LEFT - 10);
  }

  time(x) {
    const [a, b] = this.span();
    return a + (x - LEFT) / (this.width - LEFT - 10) * (b - a);
  }

  // Joint values at time t, sampled from the curves (linear between samples).
  poseAt(t) {
    const d = this.data;
    if (!d || d.empty) return null;
    const times = d.times;
    let i = times.findIndex(s => s >= t);
    if (i < 0) i = times.length - 1;
    const i0 = Math.max(0, i - 1);
    const f = times[i] === times[i0] ? 0 : (t - times[i0]) / (times[i] - times[i0]);
    return d.joints.map(j => j.positions[i0] + Math.min(Math.max(f, 0), 1) * (j.positions[i] - j.positions[i0]));
  }

  down(e) {
    const x = e.offsetX;
    const key = this.keys.findIndex(k => Math.abs(this.x(k.time) - x) < GRAB);
    this.canvas.setPointerCapture(e.pointerId);
    const { ctrlKey, metaKey, shiftKey } = e;
    this.drag = key >= 0 ? { key, x, from: x, moved: false, click: { ctrlKey, metaKey, shiftKey } } : { scrub: true };
    if (this.drag.scrub) this.scrub(x);
  }

  move(e) {
    if (!this.drag) return;
    const x = e.offsetX;
    if (this.drag.scrub) this.scrub(x);
    else {
      this.drag.moved = this.drag.moved || Math.abs(x - this.drag.from) >= DRAG_PX;
      if (this.drag.moved) { this.drag.x = x; this.draw(); }
    }
  }

  up() {
    const drag = this.drag;
    this.drag = null;
    if (!drag) return;
    if (drag.scrub) { this.park(this.cursor); return; }
    if (!drag.moved) { this.draw(); this.onKeyClick(drag.key, drag.click); return; }
    if (this.together(drag.key)) {
      const shift = this.time(drag.x) - this.time(drag.from);
      this.onKeysShift(Math.round(shift * 1000));
      return;
    }
    const t = Math.max(0, this.time(drag.x));
    this.onKeyTime(drag.key, Math.round(t * 1000));
  }

  // Whether a drag of key `index` moves several keys: it is one of several selected.
  together(index) {
    return Boolean(this.keys[index] && this.keys[index].selected) && this.keys.filter(k => k.selected).length > 1;
  }

  scrub(x) {
    const [a, b] = this.span();
    this.cursor = Math.min(Math.max(this.time(x), a), b);
    this.onScrub(this.poseAt(this.cursor), this.cursor);
    this.draw();
  }

  // Parks the cursor at sequence time t (null: unparks); the ghost shows the pose there.
  park(t) {
    this.parked = t === null || t === undefined ? null : t;
    this.cursor = this.parked;
    this.onPark(this.parked, this.parked === null ? null : this.poseAt(this.parked));
    this.draw();
  }

  // The playback's (or replay's) sequence time and the key it has reached; null: none.
  setPlayhead(t, key) {
    if (t === this.playhead && key === this.playing) return;
    this.playhead = t;
    this.playing = key;
    this.draw();
  }

  // The tracking error of `source` ('measured', 'simulated'), per joint at `times`; null
  // removes it.
  setErrors(source, errors) {
    if (errors) this.errors[source] = errors; else delete this.errors[source];
    this.draw();
  }

  draw() {
    const c = this.canvas, g = this.ctx, d = this.data;
    const rows = d && !d.empty ? d.joints.length : 1;
    const height = rows * ROW + 6 + MARKS + AXIS;
    const ratio = window.devicePixelRatio || 1;
    c.style.height = `${height}px`;
    // Setting the size clears the canvas and its transform, even to the same size.
    c.width = Math.round(this.width * ratio);
    c.height = Math.round(height * ratio);
    this.height = height;
    g.setTransform(ratio, 0, 0, ratio, 0, 0);
    g.clearRect(0, 0, this.width, height);
    g.font = '11px sans-serif';
    g.fillStyle = '#9aa4ae';
    if (!d || d.empty) {
      g.fillText(d ? d.reason : 'loading…', LEFT, 24);
    } else {
      d.joints.forEach((j, r) => this.row(j, r));
    }
    this.marks();
  }

  row(j, r) {
    const g = this.ctx, d = this.data, top = r * ROW + 4, h = ROW - 8;
    const pad = 0.1 * (j.max - j.min || 1);
    const lo = j.min - pad, hi = j.max + pad;
    const y = v => top + h - (v - lo) / (hi - lo) * h;
    g.fillStyle = '#9aa4ae';
    g.fillText(j.name, 4, top + h / 2 + 4);
    // The band between the limits.
    g.fillStyle = 'rgba(120,160,200,0.10)';
    g.fillRect(LEFT, y(j.max), this.width - LEFT - 10, y(j.min) - y(j.max));
    // A limit finding on its joint's row; a contact (no joint) on every row.
    for (const f of d.findings.filter(f => !f.joint || f.joint === j.name)) {
      g.fillStyle = 'rgba(255,60,60,0.35)';
      const x0 = this.x(f.from), x1 = Math.max(this.x(f.to), x0 + 2);
      g.fillRect(x0, top, x1 - x0, h);
    }
    for (const f of (this.simFindings || []).filter(f => !f.joint || f.joint === j.name)) {
      const x = this.x(f.at);
      g.fillStyle = '#ff7043';
      g.beginPath(); g.moveTo(x - 5, top); g.lineTo(x + 5, top); g.lineTo(x, top + 8); g.fill();
    }
    this.curve(d.times, j.velocities.map(v => (v / (j.velocity_limit || 1)) * (hi - lo) / 2 + (hi + lo) / 2), y, '#c0a060', [3, 3]);
    this.torqueCurve(r, lo, hi, y);
    this.curve(d.times, j.positions, y, '#4fc3f7', []);
    g.fillStyle = '#ffffff';
    for (const [t, v] of j.keys) g.fillRect(this.x(t) - 2, y(v) - 2, 4, 4);
    this.trackingError(r, top, h);
  }

  // Each source's tracking error of row r's joint, from the row's foot upwards (the row's
  // height is the larger of 5° and the largest error), with its largest value written.
  trackingError(r, top, h) {
    const g = this.ctx;
    const colours = { measured: '#ffca28', simulated: '#ce93d8' };
    let label = 0;
    for (const [source, e] of Object.entries(this.errors)) {
      const values = e.joints[r];
      if (!values || !values.length) continue;
      const largest = Math.max(...values);
      const scale = Math.max(5, largest);
      g.strokeStyle = colours[source] || '#ffffff';
      g.beginPath();
      e.times.forEach((t, i) => {
        const x = this.x(t), y = top + h - values[i] / scale * h;
        if (i) g.lineTo(x, y); else g.moveTo(x, y);
      });
      g.stroke();
      g.fillStyle = g.strokeStyle;
      g.fillText(`${source} error ≤ ${largest.toFixed(1)}${e.unit || '°'}`, this.width - 200, top + 10 + 11 * label++);
    }
  }

  // Ticks in seconds along the foot: a step of 1, 2 or 5 × 10^n giving ticks ~80 px apart.
  axis() {
    const g = this.ctx, [a, b] = this.span();
    const y = this.height - AXIS;
    const width = this.width - LEFT - 10;
    const raw = (b - a) * 80 / Math.max(width, 1);
    const power = 10 ** Math.floor(Math.log10(raw));
    const step = [1, 2, 5, 10].map(m => m * power).find(s => s >= raw);
    g.strokeStyle = '#5a646e';
    g.fillStyle = '#9aa4ae';
    g.beginPath(); g.moveTo(LEFT, y); g.lineTo(LEFT + width, y); g.stroke();
    const digits = step < 1 ? Math.ceil(-Math.log10(step)) : 0;
    for (let t = Math.ceil(a / step) * step; t <= b + 1e-9; t += step) {
      const x = this.x(t);
      g.beginPath(); g.moveTo(x, y); g.lineTo(x, y + 4); g.stroke();
      g.fillText(t.toFixed(digits), x - 6, y + 14);
    }
    g.fillText('time s', 4, y + 14);
  }

  // Row r's servo torque as a share of its line, ±1 at the band's edges, in green where the
  // servo can give it and red where it cannot (the check's torque finding).
  torqueCurve(r, lo, hi, y) {
    const t = this.data.torque, shares = t && t.joints[r];
    if (!shares) return;
    const g = this.ctx, mid = (hi + lo) / 2, half = (hi - lo) / 2;
    const at = i => y(mid + Math.max(-1.5, Math.min(1.5, shares[i])) * half);
    g.setLineDash([2, 2]);
    g.lineWidth = 1.5;
    // Two paths, one per colour: one stroke each however long the sequence.
    for (const [colour, over] of [['#81c784', false], ['#ff5252', true]]) {
      g.strokeStyle = colour;
      g.beginPath();
      for (let i = 1; i < shares.length; i++) {
        if ((Math.abs(shares[i]) > 1) !== over) continue;
        g.moveTo(this.x(t.times[i - 1]), at(i - 1));
        g.lineTo(this.x(t.times[i]), at(i));
      }
      g.stroke();
    }
    g.setLineDash([]);
    g.lineWidth = 1;
  }

  curve(times, values, y, colour, dash) {
    const g = this.ctx;
    g.strokeStyle = colour;
    g.setLineDash(dash);
    g.beginPath();
    times.forEach((t, i) => (i ? g.lineTo(this.x(t), y(values[i])) : g.moveTo(this.x(t), y(values[i]))));
    g.stroke();
    g.setLineDash([]);
  }

  marks() {
    const g = this.ctx, h = this.height - AXIS;
    const drag = this.drag && this.drag.key !== undefined ? this.drag : null;
    const dragged = i => drag && (drag.key === i || (this.together(drag.key) && this.keys[i].selected));
    this.keys.forEach((k, i) => {
      // A key dragged alone lands where the pointer lets go; several keep their spacing.
      const alone = drag && drag.key === i && !this.together(i);
      const x = alone ? drag.x : dragged(i) ? this.x(k.time) + drag.x - drag.from : this.x(k.time);
      g.strokeStyle = i === this.playing ? '#66bb6a' : k.current ? '#ffd54f' : k.selected ? '#ffe9a8' : 'rgba(255,255,255,0.35)';
      g.lineWidth = i === this.playing ? 2 : 1;
      g.beginPath(); g.moveTo(x, 0); g.lineTo(x, h - MARKS); g.stroke();
      g.fillStyle = g.strokeStyle;
      g.fillText(String(i), x - 3, h - 3);
    });
    g.lineWidth = 1;
    this.axis();
    const line = (t, colour, label, y) => {
      const x = this.x(t);
      g.strokeStyle = colour;
      g.beginPath(); g.moveTo(x, 0); g.lineTo(x, h); g.stroke();
      g.fillStyle = colour;
      g.fillText(label, x + 3, y);
    };
    if (this.cursor !== null && this.cursor !== undefined) {
      line(this.cursor, '#4fc3f7', this.cursor.toFixed(2) + ' s' + (this.drag ? '' : ' (parked)'), 10);
    }
    if (this.playhead !== null && this.playhead !== undefined) {
      g.lineWidth = 2;
      line(this.playhead, '#66bb6a', '▶ ' + this.playhead.toFixed(2) + ' s', 22);
      g.lineWidth = 1;
    }
  }
}
