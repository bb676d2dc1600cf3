// Parts of the arm near a contact, or in one, drawn red: the snapshot's `contacts` (the server's
// collision check at the present pose, the same that refuses a jog or a tool move into contact)
// name the links, `""` for the base (a cell's as `ARM/JOINT` and `ARM/`); a part touching the
// floor has no second link. The meshes or boxes of those links glow red until they are clear.
const RED = [1, 0, 0];

function linkOf(part, shape) {
  return part.name ? `${part.name}/${shape.userData.link}` : shape.userData.link;
}

export function showContacts(view, contacts) {
  const hot = new Set();
  for (const c of contacts) {
    hot.add(c.links[0]);
    if (c.links[1] !== null) hot.add(c.links[1]);
  }
  const key = [...hot].sort().join('|');
  if (key === view.hotKey) return;
  view.hotKey = key;
  view.hotLinks = [...hot].sort();
  for (const part of view.parts) {
    for (const shape of part.arm.shapes) {
      const on = hot.has(linkOf(part, shape));
      if (shape.material.emissive) shape.material.emissive.setRGB(...(on ? RED : [0, 0, 0]));
    }
  }
  view.dirty = true;
}
