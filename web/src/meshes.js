// The server's scene data as three.js objects: the colour of each meaning,
// the meshes of its shapes, the gripper's outline and goal labels. Nothing
// here holds page state; app.js places what these build.
// Frames are the server's: world z up, metres; poses [x, y, z, qx, qy, qz, qw].

import * as THREE from 'three';
import { ConvexGeometry } from 'three/examples/jsm/geometries/ConvexGeometry.js';
import { CSS2DObject } from 'three/examples/jsm/renderers/CSS2DRenderer.js';

// One colour per meaning, none reused for another (index.html's legend and
// the axis triad use the same values). Red, green and blue belong to the
// axes; a goal named after a colour (the planar task's "red" and "yellow"
// cylinders) is drawn in it, so the only red outside the triad is a goal
// called red.
export const COLORS = {
  command: 0x1d2430, executed: 0xd81b60, ellipsoid: 0x7e57c2, gripper: 0x37474f,
  robot: 0xe9edf5, shell: 0xc5ced8, obstacle: 0x7d8794, object: 0xb39b77, table: 0xe2e5ea,
};
const NAMED_GOAL_COLORS = { red: 0xc62828, yellow: 0xf2b705, orange: 0xef6c00, purple: 0x6a1b9a, brown: 0x6d4c41 };
const GOAL_PALETTE = [0xef6c00, 0x00838f, 0x6d4c41, 0x9e9d24, 0x5d4037, 0x00695c];
// The colour of goal k: its name's colour when it is named after one, else
// the next palette colour not taken by a named goal.
export function goalColors(goals) {
  const taken = new Set(goals.map((g) => NAMED_GOAL_COLORS[g.name.toLowerCase()]).filter((c) => c !== undefined));
  const free = GOAL_PALETTE.filter((c) => !taken.has(c));
  let next = 0;
  return goals.map((g) => NAMED_GOAL_COLORS[g.name.toLowerCase()] ?? free[next++ % free.length]);
}
export const css = (color) => `#${color.toString(16).padStart(6, '0')}`;

export function setPose(object, p) {
  object.position.set(p[0], p[1], p[2]);
  object.quaternion.set(p[3], p[4], p[5], p[6]);
}

// A three.js mesh of one shape of the server's SceneView.
export function shapeMesh(shape, material) {
  let geometry;
  switch (shape.kind) {
    case 'box': geometry = new THREE.BoxGeometry(...shape.size); break;
    case 'sphere': geometry = new THREE.SphereGeometry(shape.radius, 14, 10); break;
    case 'cylinder':
      geometry = new THREE.CylinderGeometry(shape.radius, shape.radius, shape.length, 24);
      geometry.rotateX(Math.PI / 2); // three's cylinders run along y, ours along z
      break;
    case 'capsule':
      geometry = new THREE.CapsuleGeometry(shape.radius, shape.length, 6, 16);
      geometry.rotateX(Math.PI / 2);
      break;
    case 'mesh':
      geometry = new THREE.BufferGeometry();
      geometry.setAttribute('position', new THREE.Float32BufferAttribute(shape.vertices, 3));
      geometry.setIndex(shape.indices);
      geometry.computeVertexNormals();
      break;
    case 'hull': {
      const points = [];
      for (let i = 0; i + 2 < shape.points.length; i += 3) points.push(new THREE.Vector3(shape.points[i], shape.points[i + 1], shape.points[i + 2]));
      geometry = new ConvexGeometry(points);
      break;
    }
    case 'points': {
      // A cloud's balls as dots of their diameter (in m, shrinking with
      // distance): thousands of spheres would stall the page.
      const cloud = new THREE.BufferGeometry();
      cloud.setAttribute('position', new THREE.Float32BufferAttribute(shape.points, 3));
      const dots = new THREE.PointsMaterial({ color: material.color, size: 2 * shape.radius, sizeAttenuation: true });
      const points = new THREE.Points(cloud, dots);
      setPose(points, shape.pose);
      return points;
    }
    default: return null;
  }
  const mesh = new THREE.Mesh(geometry, material);
  setPose(mesh, shape.pose);
  return mesh;
}

// The gripper's outline (palm and two fingers) in the gripper frame: the
// robots' URDFs here carry collision spheres only (tandem reads no visual
// meshes), and spheres hide where the fingers are. The hand: a Franka Hand
// held open (panda_finger_joint1 = 0.04), its TCP between the fingertips,
// z the approach direction, the fingers along ±y; boxes of about its size
// placed by panda.urdf's offsets (finger joints 45 mm above the TCP, the
// palm face 37 mm above it: problems/robots/panda/README.md). The planar
// gripper: its fingers point down at its TCP, inside its 1.5 cm collision
// cylinder.
const GRIPPERS = {
  hand: { palm: { size: [0.056, 0.2, 0.066], at: [0, 0, -0.0704] }, finger: { size: [0.02, 0.018, 0.054], at: [0, 0.049, -0.018] } },
  planar: { palm: { size: [0.02, 0.028, 0.008], at: [0, 0, 0.054] }, finger: { size: [0.008, 0.005, 0.05], at: [0, 0.0105, 0.025] } },
};

// Drawn twice: solid where it is in sight, and faintly through whatever
// hides it (seen from behind, the arm often stands in front of its hand).
export function gripperOutline(kind) {
  const shape = GRIPPERS[kind];
  const group = new THREE.Group();
  group.name = 'gripper outline';
  const solid = new THREE.MeshStandardMaterial({ color: COLORS.gripper, roughness: 0.6 });
  const ghost = new THREE.MeshBasicMaterial({ color: COLORS.gripper, transparent: true, opacity: 0.4, depthTest: false, depthWrite: false });
  const boxes = [[shape.palm.size, shape.palm.at]];
  for (const side of [1, -1]) boxes.push([shape.finger.size, [shape.finger.at[0], side * shape.finger.at[1], shape.finger.at[2]]]);
  for (const [size, at] of boxes) {
    const geometry = new THREE.BoxGeometry(...size);
    for (const material of [solid, ghost]) {
      const box = new THREE.Mesh(geometry, material);
      box.position.set(...at);
      if (material === ghost) box.renderOrder = 10; // after the see-through robot links
      group.add(box);
    }
  }
  return group;
}

export function label(text, color, position) {
  const div = document.createElement('div');
  div.className = 'label';
  div.textContent = text;
  div.style.borderColor = color; // dark text on a coloured frame: readable in yellow too
  const object = new CSS2DObject(div);
  object.position.set(...position);
  object.center.set(0.5, -0.4); // just below the point: clear of the gripper above
  return object;
}
