// The tool handle: a ball at the tool point with a translate gizmo (three's TransformControls).
// Dragging it reports where the tool should go; the server solves the joints and refuses what
// the arm cannot do (the ball turns red then). Between drags the ball sits on the drawn tool.
import * as THREE from 'three';
import { TransformControls } from '/vendor/three/TransformControls.js';

const COLOUR = { ok: 0xffd54f, refused: 0xef5350 };

export class ToolHandle {
  // `onMove(position)`: the ball was dragged to `position` (the tool's arm's base frame,
  // metres; the ball itself lives in the scene, the cell's frame).
  constructor(view, onMove) {
    this.view = view;
    this.dragging = false;
    this.refused = false;
    this.ball = new THREE.Mesh(new THREE.SphereGeometry(0.012, 16, 10),
      new THREE.MeshBasicMaterial({ color: COLOUR.ok, transparent: true, opacity: 0.55 }));
    view.scene.add(this.ball);
    this.gizmo = new TransformControls(view.camera, view.canvas);
    this.gizmo.setSize(0.7);
    this.gizmo.attach(this.ball);
    view.scene.add(this.gizmo.getHelper());
    this.gizmo.addEventListener('dragging-changed', e => {
      this.dragging = e.value;
      // The camera stays still while the handle moves.
      view.controls.enabled = !e.value;
      if (!e.value) this.follow();
    });
    this.gizmo.addEventListener('objectChange', () => onMove(view.toToolFrame(this.ball.position)));
    this.gizmo.addEventListener('change', () => { view.dirty = true; });
    this.setEnabled(false);
  }

  // Only the controlling page may drag; watchers see no handle.
  setEnabled(on) {
    this.gizmo.enabled = on;
    this.gizmo.getHelper().visible = on;
    this.ball.visible = on;
    this.view.dirty = true;
  }

  setRefused(refused) {
    this.refused = refused;
    this.ball.material.color.setHex(refused ? COLOUR.refused : COLOUR.ok);
    this.view.dirty = true;
  }

  // Back on the drawn tool, unless the user holds the handle.
  follow() {
    const tool = this.view.toolWorld();
    if (this.dragging || !tool) return;
    this.ball.position.copy(tool);
    this.view.dirty = true;
  }

  // Where the ball is on the page, in CSS pixels (for the browser test's mouse).
  screenPosition() {
    const p = this.ball.position.clone().project(this.view.camera);
    const r = this.view.canvas.getBoundingClientRect();
    return { x: r.left + (p.x + 1) / 2 * r.width, y: r.top + (1 - p.y) / 2 * r.height };
  }
}
