// The easing of the segment from the current key, drawn as a curve with two handles: the
// share of the way (vertical) reached by each share of the segment's time (horizontal). A
// steady segment is the diagonal; an eased one starts and ends flat (at rest). The left handle
// is where speeding up ends, the right one where slowing down begins; dragging one sideways
// asks the server for `ease:OUT,IN` (percent of the path, in steps of 5), which it applies to
// linear segments only — elsewhere the curve is drawn without handles and says why. The
// curve comes from the shares alone (a trapezoidal velocity profile), the same rule the server
// times the segment by (SegmentTiming::eased).

const SIZE = { width: 220, height: 110, pad: 12 };
const GRAB = 9;
const STEP = 5;

// The time share at which a trapezoid of path shares a (up) and b (down) ends speeding up and
// begins slowing down: steady speed 1 + a + b over a unit of time.
export function breaks(a, b) {
  const v = 1 + a + b;
  return { up: (2 * a) / v, down: 1 - (2 * b) / v };
}

// Path share at time share t.
export function pathAt(a, b, t) {
  const v = 1 + a + b, { up, down } = breaks(a, b);
  if (t <= up) return a === 0 ? v * t : (v * v * t * t) / (4 * a);
  if (t >= down) { const r = 1 - t; return 1 - (b === 0 ? v * r : (v * v * r * r) / (4 * b)); }
  return a + v * (t - up);
}

// The path share `a` that puts the end of speeding up at time share `t`, `b` kept (the
// inverse of breaks().up), rounded to the server's steps.
function shareUp(t, b) {
  const a = (t * (1 + b)) / Math.max(2 - t, 1e-9);
  return Math.round(Math.min(Math.max(a, 0), 1 - b) * 100 / STEP) * STEP;
}

export class Easing {
  constructor(canvas, label, send) {
    this.canvas = canvas;
    this.label = label;
    this.send = send;
    this.state = null;
    this.drag = null;
    canvas.addEventListener('pointerdown', e => this.down(e));
    canvas.addEventListener('pointermove', e => this.move(e));
    canvas.addEventListener('pointerup', () => this.up());
  }

  // The snapshot's `easing` (null: no segment follows the current key).
  show(easing) {
    if (this.drag) return;
    const seen = JSON.stringify(easing);
    if (seen === this.seen) return;
    this.seen = seen;
    this.state = easing;
    this.canvas.hidden = !easing;
    if (!easing) { this.label.textContent = ''; return; }
    const pct = v => Math.round(v * 100);
    this.label.textContent = `key ${easing.from} → ${easing.to}: ` + (easing.allowed
      ? `speeds up over ${pct(easing.out)} %, slows down over ${pct(easing.in)} % of the way (drag the handles)`
      : easing.why);
    this.draw(easing.out, easing.in);
  }

  x(t) { return SIZE.pad + t * (SIZE.width - 2 * SIZE.pad); }
  y(s) { return SIZE.height - SIZE.pad - s * (SIZE.height - 2 * SIZE.pad); }

  handles(a, b) {
    const { up, down } = breaks(a, b);
    return [{ which: 'out', t: up, s: a }, { which: 'in', t: down, s: 1 - b }];
  }

  draw(a, b) {
    const c = this.canvas, g = c.getContext('2d'), ratio = window.devicePixelRatio || 1;
    c.style.width = `${SIZE.width}px`;
    c.style.height = `${SIZE.height}px`;
    c.width = SIZE.width * ratio;
    c.height = SIZE.height * ratio;
    g.setTransform(ratio, 0, 0, ratio, 0, 0);
    g.clearRect(0, 0, SIZE.width, SIZE.height);
    g.strokeStyle = '#333a42';
    g.strokeRect(this.x(0), this.y(1), this.x(1) - this.x(0), this.y(0) - this.y(1));
    g.setLineDash([3, 3]);
    g.beginPath(); g.moveTo(this.x(0), this.y(0)); g.lineTo(this.x(1), this.y(1)); g.stroke();
    g.setLineDash([]);
    g.strokeStyle = this.state && this.state.allowed ? '#4fc3f7' : '#7a848e';
    g.beginPath();
    for (let i = 0; i <= 100; i++) {
      const t = i / 100, s = pathAt(a, b, t);
      if (i) g.lineTo(this.x(t), this.y(s)); else g.moveTo(this.x(t), this.y(s));
    }
    g.stroke();
    if (!this.state || !this.state.allowed) return;
    for (const h of this.handles(a, b)) {
      g.fillStyle = '#ffd54f';
      g.beginPath(); g.arc(this.x(h.t), this.y(h.s), 5, 0, 2 * Math.PI); g.fill();
    }
  }

  down(e) {
    const s = this.state;
    if (!s || !s.allowed) return;
    const near = this.handles(s.out, s.in)
      .find(h => Math.hypot(this.x(h.t) - e.offsetX, this.y(h.s) - e.offsetY) < GRAB);
    if (!near) return;
    this.canvas.setPointerCapture(e.pointerId);
    this.drag = { which: near.which, out: Math.round(s.out * 100), in: Math.round(s.in * 100) };
  }

  move(e) {
    const d = this.drag;
    if (!d) return;
    const t = Math.min(Math.max((e.offsetX - SIZE.pad) / (SIZE.width - 2 * SIZE.pad), 0), 1);
    if (d.which === 'out') d.out = shareUp(t, d.in / 100);
    else d.in = shareUp(1 - t, d.out / 100);
    this.draw(d.out / 100, d.in / 100);
  }

  up() {
    const d = this.drag;
    this.drag = null;
    if (!d) return;
    this.send({ key: `ease:${d.out},${d.in}` });
  }
}
