// The official meshes of a built-in robot (GET /api/robot's `meshes`: URL, joint, origin in the
// joint's moving frame, colour), each file loaded once and shared by every arm and ghost that
// shows it. They replace the simulation model's boxes and capsules once all have arrived; until
// then, or if any fails to load, the boxes and capsules stay (and robot files without meshes
// only ever have those).
import * as THREE from 'three';
import { STLLoader } from '/vendor/three/STLLoader.js';

const loader = new STLLoader();
const files = new Map();

function load(url) {
  if (!files.has(url)) files.set(url, loader.loadAsync(url));
  return files.get(url);
}

// Puts `parts` on `arm` (an Arm of view3d.js: its root and joints' moving frames), each mesh
// with `material(rgba)`, and hides the arm's primitive shapes. Resolves to the meshes added.
export async function dress(arm, parts, material) {
  const geometries = await Promise.all(parts.map(p => load(p.url)));
  const added = [];
  parts.forEach((p, i) => {
    const joint = p.joint ? arm.joints.get(p.joint) : null;
    const parent = p.joint ? joint && joint.moving : arm.root;
    if (!parent) return;
    const mesh = new THREE.Mesh(geometries[i], material(p.rgba));
    mesh.position.fromArray(p.origin.t);
    mesh.quaternion.fromArray(p.origin.q);
    mesh.userData.link = p.joint || '';
    parent.add(mesh);
    added.push(mesh);
  });
  for (const shape of arm.shapes) shape.visible = false;
  arm.shapes = added;
  return added;
}
