// The arm in 3D: built from GET /api/robot (the chain, and the simulation model's bodies and
// shapes when there is one), posed by joint values in the robot's units (degrees; metres for
// prismatic joints). A second, translucent copy is the ghost. A cell is several arms, each
// drawn from its own model at its base and posed by its part of the cell's values; the tool is
// the one of the selected joint's arm, in that arm's base frame.
import * as THREE from 'three';
import { OrbitControls } from '/vendor/three/OrbitControls.js';
import { dress } from '/meshes.js';
import { frame } from '/framing.js';

const DEG = Math.PI / 180;
// The ghost's colours: the key's pose, and the key's pose in a contact.
const GHOST = 0x4fc3f7;
const GHOST_CONTACT = 0xff3b30;

function quat(q) { return new THREE.Quaternion(q[0], q[1], q[2], q[3]); }
function vec(t) { return new THREE.Vector3(t[0], t[1], t[2]); }

function place(object, origin) {
  object.position.copy(vec(origin.t));
  object.quaternion.copy(quat(origin.q));
}

// A mesh along the segment a → b (three's capsules and cylinders run along +Y).
function alongSegment(mesh, a, b) {
  const dir = new THREE.Vector3().subVectors(b, a);
  mesh.position.copy(a).addScaledVector(dir, 0.5);
  mesh.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), dir.clone().normalize());
  return mesh;
}

function geomMesh(g, material) {
  const [s0, s1 = s0, s2 = s1] = g.size;
  let geometry;
  let length = 2 * s1;
  if (g.fromto) length = vec(g.fromto.slice(0, 3)).distanceTo(vec(g.fromto.slice(3)));
  switch (g.type) {
    case 'box': geometry = new THREE.BoxGeometry(2 * s0, 2 * s1, 2 * s2); break;
    case 'sphere': geometry = new THREE.SphereGeometry(s0, 20, 14); break;
    case 'capsule': geometry = new THREE.CapsuleGeometry(s0, length, 6, 16); break;
    case 'cylinder': geometry = new THREE.CylinderGeometry(s0, s0, length, 20); break;
    default: return null;
  }
  const mesh = new THREE.Mesh(geometry, material(g.rgba));
  if (g.fromto) return alongSegment(mesh, vec(g.fromto.slice(0, 3)), vec(g.fromto.slice(3)));
  place(mesh, g.origin);
  // MJCF capsules and cylinders without fromto run along their frame's Z.
  if (g.type === 'capsule' || g.type === 'cylinder') {
    mesh.quaternion.multiply(new THREE.Quaternion().setFromUnitVectors(
      new THREE.Vector3(0, 1, 0), new THREE.Vector3(0, 0, 1)));
  }
  return mesh;
}

// One copy of the arm: a node per body (or per joint, without a model), each jointed node
// turned or slid by its joint.
class Arm {
  constructor(model, material) {
    this.root = new THREE.Group();
    this.joints = new Map();
    this.axes = [];
    // The drawn shapes: the model's boxes and capsules, or the official meshes once loaded.
    this.shapes = [];
    this.model = model;
    if (model.bodies) {
      for (const body of model.bodies) this.root.add(this.body(body, material));
    } else {
      this.chain(model.joints, material);
    }
    const tcpParent = model.tcp && this.joints.get(model.tcp.parent);
    if (tcpParent) {
      this.tcp = new THREE.Mesh(new THREE.SphereGeometry(0.006, 12, 8), material([1, 0.1, 0.1, 1]));
      place(this.tcp, model.tcp.origin);
      tcpParent.moving.add(this.tcp);
    }
  }

  addJoint(name, kind, axis, frame) {
    const moving = new THREE.Group();
    frame.add(moving);
    const a = vec(axis).normalize();
    const arrow = new THREE.ArrowHelper(a, new THREE.Vector3(), 0.06, 0xff00ff, 0.015, 0.01);
    arrow.visible = false;
    frame.add(arrow);
    this.axes.push(arrow);
    this.joints.set(name, { moving, kind, axis: a });
    return moving;
  }

  body(body, material, parentLink = '') {
    const link = body.joint ? body.joint.name : parentLink;
    const frame = new THREE.Group();
    frame.name = body.name;
    place(frame, body.origin);
    const inner = body.joint
      ? this.addJoint(body.joint.name, body.joint.kind, body.joint.axis, frame)
      : frame;
    for (const g of body.geoms) {
      const mesh = geomMesh(g, material);
      if (!mesh) continue;
      mesh.userData.link = link;
      inner.add(mesh);
      this.shapes.push(mesh);
    }
    for (const child of body.children) inner.add(this.body(child, material, link));
    return frame;
  }

  // Without a model: a sphere at each joint and a rod to the next.
  chain(joints, material) {
    let parent = this.root;
    const grey = material([0.7, 0.7, 0.72, 1]);
    for (const j of joints) {
      const frame = new THREE.Group();
      place(frame, j.origin);
      parent.add(frame);
      const rod = vec(j.origin.t);
      if (rod.length() > 1e-6) {
        parent.add(alongSegment(new THREE.Mesh(new THREE.CylinderGeometry(0.008, 0.008, rod.length(), 12), grey),
          new THREE.Vector3(), rod));
      }
      frame.add(new THREE.Mesh(new THREE.SphereGeometry(0.014, 16, 10), material([0.1, 0.1, 0.1, 1])));
      parent = this.addJoint(j.name, j.kind, j.axis, frame);
    }
  }

  // Joint values in robot order and units.
  pose(values) {
    const byName = new Map();
    this.model.joints.forEach((j, i) => {
      const v = values[i];
      if (v === null || v === undefined || !Number.isFinite(v)) return;
      byName.set(j.name, j.kind === 'prismatic' ? v : v * DEG);
    });
    for (const m of this.model.mimics || []) {
      if (byName.has(m.follows)) byName.set(m.joint, m.offset + m.scale * byName.get(m.follows));
    }
    for (const [name, value] of byName) {
      const joint = this.joints.get(name);
      if (!joint) continue;
      if (joint.kind === 'prismatic') {
        joint.moving.position.copy(joint.axis).multiplyScalar(value);
      } else {
        joint.moving.quaternion.setFromAxisAngle(joint.axis, value);
      }
    }
  }
}

export class ArmView {
  constructor(canvas, model) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x20252b);
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.01, 10);
    this.camera.up.set(0, 0, 1);
    this.controls = new OrbitControls(this.camera, canvas);
    // On every arm's reach, whatever its pose (framing.js).
    frame(this.camera, this.controls, model, canvas.clientWidth / Math.max(canvas.clientHeight, 1));
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(1, -1, 2);
    this.scene.add(sun);
    const grid = new THREE.GridHelper(1, 20, 0x667080, 0x3a4048);
    grid.rotation.x = Math.PI / 2; // three's grid lies in XZ; the robot's floor is XY.
    this.scene.add(grid);
    this.scene.add(new THREE.AxesHelper(0.1));
    const solid = rgba => new THREE.MeshStandardMaterial({
      color: new THREE.Color(rgba[0], rgba[1], rgba[2]), roughness: 0.6, metalness: 0.1 });
    const ghostMaterial = this.ghostMaterial = new THREE.MeshBasicMaterial({
      color: GHOST, transparent: true, opacity: 0.25, depthWrite: false });
    // One part per arm: the arm and its ghost, each under a node at the arm's base.
    const parts = model.arms || [{ name: null, base: null, first: 0, model }];
    this.parts = parts.map(p => {
      const part = { name: p.name, first: p.first, count: p.model.joints.length,
        arm: new Arm(p.model, solid), ghost: new Arm(p.model, () => ghostMaterial),
        root: new THREE.Group(), ghostRoot: new THREE.Group() };
      if (p.base) { place(part.root, p.base); place(part.ghostRoot, p.base); }
      part.root.add(part.arm.root);
      part.ghostRoot.add(part.ghost.root);
      part.ghostRoot.visible = false;
      this.scene.add(part.root, part.ghostRoot);
      return part;
    });
    // The official meshes, when the robot has them: 'none', 'loading', 'loaded' or 'failed'
    // (the boxes and capsules stay).
    const dressed = parts.filter(p => p.model.meshes);
    this.meshes = dressed.length ? 'loading' : 'none';
    Promise.all(dressed.flatMap(p => {
      const part = this.parts.find(q => q.first === p.first);
      return [dress(part.arm, p.model.meshes, solid), dress(part.ghost, p.model.meshes, () => ghostMaterial)];
    })).then(() => { if (dressed.length) this.meshes = 'loaded'; this.hotKey = null; this.dirty = true; },
      () => { this.meshes = 'failed'; this.dirty = true; });
    this.toolPart = this.parts[0];
    this.onFrame = null;
    // Drawn only when something changed: software GL (and a laptop's battery) cannot afford
    // sixty identical frames a second.
    this.dirty = true;
    this.controls.addEventListener('change', () => { this.dirty = true; });
    window.addEventListener('resize', () => { this.dirty = true; });
    const loop = () => {
      if (this.dirty) {
        this.dirty = false;
        this.resize();
        this.renderer.render(this.scene, this.camera);
        if (this.onFrame) this.onFrame();
      }
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  resize() {
    const { clientWidth: w, clientHeight: h } = this.canvas;
    if (this.canvas.width !== Math.floor(w * this.renderer.getPixelRatio()) || this.lastH !== h) {
      this.renderer.setSize(w, h, false);
      this.camera.aspect = w / Math.max(h, 1);
      this.camera.updateProjectionMatrix();
      this.lastH = h;
    }
  }

  // Each arm's part of `values` (robot order).
  static slice(part, values) { return values.slice(part.first, part.first + part.count); }

  setPose(values) {
    for (const part of this.parts) part.arm.pose(ArmView.slice(part, values));
    this.dirty = true;
  }

  // The ghost at `values` (robot order and units), or hidden with null; red where `contact`
  // (the pose touches the desk, the arm itself or another arm: `space` would refuse it).
  setGhost(values, contact) {
    this.dirty = true;
    this.ghostMaterial.color.setHex(contact ? GHOST_CONTACT : GHOST);
    this.ghostContact = !!(values && contact);
    for (const part of this.parts) {
      part.ghostRoot.visible = !!values;
      if (values) part.ghost.pose(ArmView.slice(part, values));
    }
  }

  // Another translucent copy of every arm in `colour` (the commanded pose beside the
  // simulated or measured one); returns its setter: values (robot order and units), or null
  // to hide it.
  addCopy(colour) {
    const material = new THREE.MeshBasicMaterial({ color: colour, transparent: true, opacity: 0.3, depthWrite: false });
    const copies = this.parts.map(part => {
      const arm = new Arm(part.arm.model, () => material), root = new THREE.Group();
      root.position.copy(part.root.position);
      root.quaternion.copy(part.root.quaternion);
      root.add(arm.root);
      root.visible = false;
      this.scene.add(root);
      return { part, arm, root };
    });
    return values => {
      this.dirty = true;
      for (const c of copies) {
        c.root.visible = !!values;
        if (values) c.arm.pose(ArmView.slice(c.part, values));
      }
    };
  }

  showAxes(on) {
    for (const part of this.parts) for (const a of part.arm.axes) a.visible = on;
    this.dirty = true;
  }

  // The tool is the arm's that joint `index` (robot order) belongs to.
  setToolJoint(index) {
    this.toolPart = this.parts.find(p => index >= p.first && index < p.first + p.count) || this.parts[0];
  }

  // Where the tool's arm draws its tool centre point, in the scene (the cell's frame).
  toolWorld() {
    const tcp = this.toolPart.arm.tcp;
    if (!tcp) return null;
    this.scene.updateMatrixWorld(true);
    return tcp.getWorldPosition(new THREE.Vector3());
  }

  // A point of the scene in the tool's arm's base frame (metres).
  toToolFrame(world) {
    this.scene.updateMatrixWorld(true);
    return this.toolPart.root.worldToLocal(world.clone()).toArray();
  }

  // Where the drawn tool centre point is, in its arm's base frame (metres).
  tcpPosition() {
    const world = this.toolWorld();
    return world ? this.toToolFrame(world) : null;
  }

  // The drawn rotation of a joint (a cell's as ARM/JOINT) on the arm or (`copy` 'ghost') its
  // ghost, for tests and the latency figure.
  jointAngle(name, copy = 'arm') {
    const [armName, jointName] = name.includes('/') ? name.split('/', 2) : [null, name];
    const part = this.parts.find(p => p.name === armName);
    const joint = part && part[copy].joints.get(jointName);
    if (!joint) return null;
    if (joint.kind === 'prismatic') return joint.moving.position.dot(joint.axis);
    const q = joint.moving.quaternion;
    return 2 * Math.atan2(new THREE.Vector3(q.x, q.y, q.z).dot(joint.axis), q.w) / DEG;
  }
}
