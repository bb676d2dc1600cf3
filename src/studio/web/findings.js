// The findings, as a list that stays in view over the 3D view: where the limit check finds
// the limits broken (with their units: deg, deg/s, deg/s²) and what the last simulation
// found. A click on one parks the timeline at its time.

export class Findings {
  constructor(box, onPick) {
    this.box = box;
    this.onPick = onPick;
    this.check = [];
    this.simulation = [];
    this.render();
  }

  // The timeline's check findings: { text, peak_time }.
  setCheck(findings) {
    this.check = (findings || []).map(f => ({ source: 'check', text: f.text, at: f.peak_time }));
    this.render();
  }

  // The simulation's findings, at sequence times (null during the approach).
  setSimulation(findings) {
    this.simulation = findings.map(f => ({
      source: 'simulation',
      text: `${f.kind}${f.joint ? ' ' + f.joint : ''} at ${f.time.toFixed(2)} s: ${f.message}`,
      at: f.at,
    }));
    this.render();
  }

  render() {
    const all = [...this.check, ...this.simulation];
    this.box.hidden = all.length === 0;
    this.box.replaceChildren();
    if (!all.length) return;
    const title = document.createElement('h4');
    title.textContent = `findings (${all.length})`;
    const list = document.createElement('ul');
    for (const f of all) {
      const item = document.createElement('li');
      item.className = f.source === 'simulation' ? 'simulation' : 'check';
      item.textContent = `${f.source}: ${f.text}`;
      if (f.at !== null && f.at !== undefined) {
        item.title = 'show this moment on the timeline';
        item.onclick = () => this.onPick(f.at);
      }
      list.append(item);
    }
    this.box.append(title, list);
  }
}
