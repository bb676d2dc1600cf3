// Where the camera starts: looking at the arms from the front right and above, far enough back
// that everything each arm can reach is in view (a sphere about each arm's first joint whose
// radius is the chain's length to the tool), whatever pose it is in now.
import * as THREE from 'three';

// From the target towards the camera.
const FROM = new THREE.Vector3(0.35, -0.55, 0.28).normalize();

function vec(t) { return new THREE.Vector3(t[0], t[1], t[2]); }

// Each arm's reach sphere in the scene: centre and radius, metres.
export function reachSpheres(model) {
  const arms = model.arms || [{ base: null, model }];
  return arms.map(({ base, model: m }) => {
    const origins = m.joints.map(j => vec(j.origin.t));
    const first = origins[0] || new THREE.Vector3();
    let radius = origins.slice(1).reduce((r, o) => r + o.length(), 0);
    if (m.tcp) radius += vec(m.tcp.origin.t).length();
    const centre = first.clone();
    if (base) centre.applyQuaternion(new THREE.Quaternion().fromArray(base.q)).add(vec(base.t));
    return { centre, radius: Math.max(radius, 0.1) };
  });
}

// Points the camera (and the orbit controls' target) at the reach of `model`'s arms for a view
// `aspect` wide per unit of height.
export function frame(camera, controls, model, aspect) {
  const spheres = reachSpheres(model);
  const box = new THREE.Box3();
  for (const s of spheres) {
    // The desk bounds the reach from below: nothing is drawn under the floor.
    box.expandByPoint(s.centre.clone().addScalar(-s.radius).setZ(0));
    box.expandByPoint(s.centre.clone().addScalar(s.radius));
  }
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  // The reach is a hemisphere above the desk, not the box's corners: 0.65 of the box's sphere
  // keeps an outstretched arm in view with little empty floor around it.
  const radius = 0.65 * sphere.radius;
  const half = THREE.MathUtils.degToRad(camera.fov / 2);
  const fit = Math.min(half, Math.atan(Math.tan(half) * aspect));
  camera.position.copy(sphere.center).addScaledVector(FROM, radius / Math.sin(fit));
  camera.near = radius / 50;
  camera.far = radius * 20;
  camera.updateProjectionMatrix();
  controls.target.copy(sphere.center);
  controls.update();
}
