// The timeline: per joint, the position curve between its limits (the band) and the velocity
// curve against its limit (dashed), the keys as vertical marks, check findings in red.
// Dragging a key mark moves the key in time (the engine validates it); dragging elsewhere
// scrubs, showing the pose at that time on the ghost.

const ROW = 44;
const LEFT = 110;
const GRAB = 6;
// How far a key mark must be dragged before it moves: a plain click (a hand's jitter) only
// selects the key.
const DRAG_PX = 4;

export class Timeline {
  constructor(canvas, { onScrub, onKeyTime, onKeyClick }) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d');
    this.data = null;
    this.keys = [];
    this.onScrub = onScrub;
    this.onKeyTime = onKeyTime;
    this.onKeyClick = onKeyClick || (() => {});
    this.drag = null;
    canvas.addEventListener('pointerdown', e => this.down(e));
    canvas.addEventListener('pointermove', e => this.move(e));
    canvas.addEventListener('pointerup', e => this.up(e));
  }

  // The simulation's findings, at sequence times: marked on their joint's row (or all rows).
  setSimFindings(findings) {
    this.simFindings = findings.filter(f => f.at !== null && f.at !== undefined);
    this.draw();
  }

  set(data, keys) {
    this.data = data;
    this.keys = keys;
    this.draw();
  }

  span() {
    const d = this.data;
    if (!d || d.empty) return [0, Math.max(1, ...this.keys.map(k => k.time))];
    return [Math.min(d.start, ...this.keys.map(k => k.time)), Math.max(d.end, ...this.keys.map(k => k.time), d.start + 0.1)];
  }

  x(t) {
    const [a, b] = this.span();
    return LEFT + (t - a) / (b - a) * (this.canvas.width - LEFT - 10);
  }

  time(x) {
    const [a, b] = this.span();
    return a + (x - LEFT) / (this.canvas.width - LEFT - 10) * (b - a);
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
    const x = e.offsetX * this.canvas.width / this.canvas.clientWidth;
    const key = this.keys.findIndex(k => Math.abs(this.x(k.time) - x) < GRAB);
    this.canvas.setPointerCapture(e.pointerId);
    this.drag = key >= 0 ? { key, x, from: x, moved: false } : { scrub: true };
    if (this.drag.scrub) this.scrub(x);
  }

  move(e) {
    if (!this.drag) return;
    const x = e.offsetX * this.canvas.width / this.canvas.clientWidth;
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
    if (drag.scrub) { this.cursor = null; this.onScrub(null); this.draw(); return; }
    if (!drag.moved) { this.draw(); this.onKeyClick(drag.key); return; }
    const t = Math.max(0, this.time(drag.x));
    this.onKeyTime(drag.key, Math.round(t * 1000));
  }

  scrub(x) {
    this.cursor = this.time(x);
    this.onScrub(this.poseAt(this.cursor), this.cursor);
    this.draw();
  }

  draw() {
    const c = this.canvas, g = this.ctx, d = this.data;
    const rows = d && !d.empty ? d.joints.length : 1;
    const height = rows * ROW + 20;
    if (c.height !== height) c.height = height;
    c.width = c.clientWidth || 800;
    g.clearRect(0, 0, c.width, c.height);
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
    g.fillRect(LEFT, y(j.max), this.canvas.width - LEFT - 10, y(j.min) - y(j.max));
    for (const f of d.findings.filter(f => f.joint === j.name)) {
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
    this.curve(d.times, j.positions, y, '#4fc3f7', []);
    g.fillStyle = '#ffffff';
    for (const [t, v] of j.keys) g.fillRect(this.x(t) - 2, y(v) - 2, 4, 4);
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
    const g = this.ctx, h = this.canvas.height;
    this.keys.forEach((k, i) => {
      const x = this.drag && this.drag.key === i ? this.drag.x : this.x(k.time);
      g.strokeStyle = k.current ? '#ffd54f' : 'rgba(255,255,255,0.35)';
      g.beginPath(); g.moveTo(x, 0); g.lineTo(x, h - 14); g.stroke();
      g.fillStyle = g.strokeStyle;
      g.fillText(String(i), x - 3, h - 3);
    });
    if (this.cursor !== null && this.cursor !== undefined) {
      const x = this.x(this.cursor);
      g.strokeStyle = '#4fc3f7';
      g.beginPath(); g.moveTo(x, 0); g.lineTo(x, h); g.stroke();
      g.fillStyle = '#4fc3f7';
      g.fillText(this.cursor.toFixed(2) + ' s', x + 3, 10);
    }
  }
}
