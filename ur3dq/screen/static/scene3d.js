// The 3D scene (no page, no DOM: it is built in the drawing worker): the arm as the path check's capsules (placed
// by the server), the TCP frame, the floor, the cell's boxes and keep-in volume, the waypoints as small frames, the
// checked path coloured by clearance. The server sends end points and matrices in the robot's base frame (z up,
// metres); this file only draws them. labelsOf gives the names and where they go, for the page to write them.
import * as THREE from "./vendor/three.bundle.min.js";

const BODY_COLOURS = { "base": 0x4a5160, "shoulder": 0x2f6fbf, "upper arm": 0x9aa6b8, "forearm": 0x9aa6b8,
  "wrist 1": 0x2f6fbf, "wrist 2": 0x2f6fbf, "wrist 3": 0x2f6fbf, "tool": 0xc77d1a };
const CLEARANCE_COLOURS = [[0, 0xcf222e], [0.01, 0xe07b00], [0.05, 0xd4a72c], [Infinity, 0x1a7f37]];
const AXIS_COLOURS = [[0.9, 0.1, 0.1], [0.1, 0.7, 0.1], [0.1, 0.3, 0.95]];   // x red, y green, z blue
const Y = new THREE.Vector3(0, 1, 0);

// Empty `group`, its geometries and materials freed.
function emptied(group) {
  group.traverse((object) => {
    if (object.geometry) object.geometry.dispose();
    if (object.material) object.material.dispose();
  });
  group.clear();
}

function clearanceColour(clearance) {
  if (clearance === null || clearance === undefined) return new THREE.Color(0x8a93a3);
  for (const [limit, colour] of CLEARANCE_COLOURS) if (clearance < limit) return new THREE.Color(colour);
  return new THREE.Color(0x1a7f37);
}

// The name labels of `kind` ("cell", "frames", "check") of the data sent for it: [{text, at: [x, y, z], problem}].
export function labelsOf(kind, data) {
  if (!data) return [];
  if (kind === "cell") {
    return [...data.boxes, ...(data.keep_in ? [data.keep_in] : [])].map((box) => ({ text: box.name,
      at: [(box.min[0] + box.max[0]) / 2, (box.min[1] + box.max[1]) / 2, box.max[2]], problem: false }));
  }
  if (kind === "frames") {
    return data.map((frame) => ({ text: frame.name, at: [frame.matrix[12], frame.matrix[13], frame.matrix[14] + 0.012],
      problem: false }));
  }
  return (data.problems || []).filter((problem) => problem.tcp).map((problem) => ({ text: problem.step,
    at: [problem.tcp[0], problem.tcp[1], problem.tcp[2] + 0.02], problem: true }));
}

export class Scene3D {
  constructor() {
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xe9ecf1);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x667080, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.4);
    sun.position.set(2, -3, 4);
    this.scene.add(sun);
    this.arm = new THREE.Group();
    this.cell = new THREE.Group();
    this.frames = new THREE.Group();
    this.path = new THREE.Group();
    this.tcp = new THREE.AxesHelper(0.08);
    this.tcp.matrixAutoUpdate = false;
    this.scene.add(this.arm, this.cell, this.frames, this.path, this.tcp);
    this.capsules = [];
    this.armPlaced = false;
    this.floor(0);
  }

  // The arm's capsules once: a cylinder and two end spheres each, in the body's colour.
  setArm(description) {
    emptied(this.arm);
    this.capsules = [];
    this.armPlaced = false;
    if (!description) return;
    description.radius.forEach((radius, index) => {
      const material = new THREE.MeshLambertMaterial({ color: BODY_COLOURS[description.body[index]] ?? 0x9aa6b8 });
      const tube = new THREE.Mesh(new THREE.CylinderGeometry(radius, radius, 1, 24, 1, true), material);
      const ends = [0, 1].map(() => new THREE.Mesh(new THREE.SphereGeometry(radius, 20, 14), material));
      this.arm.add(tube, ...ends);
      this.capsules.push({ tube, ends });
    });
  }

  // Place the capsules at their end points [ax, ay, az, bx, by, bz] and the TCP frame (column-major 4×4).
  placeArm(placed) {
    if (!placed || !this.capsules.length) return false;
    const a = new THREE.Vector3(), b = new THREE.Vector3(), axis = new THREE.Vector3();
    placed.capsules.forEach((ends, index) => {
      const capsule = this.capsules[index];
      if (!capsule) return;
      a.set(ends[0], ends[1], ends[2]);
      b.set(ends[3], ends[4], ends[5]);
      axis.subVectors(b, a);
      const length = axis.length();
      capsule.tube.visible = length > 1e-6;
      capsule.tube.position.addVectors(a, b).multiplyScalar(0.5);
      if (length > 1e-6) capsule.tube.quaternion.setFromUnitVectors(Y, axis.normalize());
      capsule.tube.scale.set(1, Math.max(length, 1e-6), 1);
      capsule.ends[0].position.copy(a);
      capsule.ends[1].position.copy(b);
    });
    this.tcp.matrix.fromArray(placed.tcp);
    this.tcp.matrixWorldNeedsUpdate = true;
    this.armPlaced = true;
    return true;
  }

  floor(z) {
    if (this.grid) this.scene.remove(this.grid);
    this.grid = new THREE.GridHelper(2, 20, 0x8a93a3, 0xc3c8d1);
    this.grid.rotation.x = Math.PI / 2;
    this.grid.position.z = z;
    this.scene.add(this.grid);
  }

  // The cell file: floor height, keep-out boxes (red, translucent), keep-in box (blue edges).
  setCell(cell) {
    emptied(this.cell);
    this.floor(cell && cell.floor !== null && cell.floor !== undefined ? cell.floor : 0);
    if (!cell) return;
    for (const box of cell.boxes) this.cell.add(this.box(box, 0xcf222e, true));
    if (cell.keep_in) this.cell.add(this.box(cell.keep_in, 0x1f6feb, false));
  }

  box(box, colour, solid) {
    const size = [0, 1, 2].map((i) => Math.max(box.max[i] - box.min[i], 1e-4));
    const geometry = new THREE.BoxGeometry(...size);
    const group = new THREE.Group();
    if (solid) {
      group.add(new THREE.Mesh(geometry, new THREE.MeshLambertMaterial({ color: colour, transparent: true,
        opacity: 0.28, depthWrite: false })));
    }
    group.add(new THREE.LineSegments(new THREE.EdgesGeometry(geometry), new THREE.LineBasicMaterial({ color: colour })));
    group.position.set(...[0, 1, 2].map((i) => (box.max[i] + box.min[i]) / 2));
    return group;
  }

  // Every waypoint as a small frame: all the frames one set of lines (one draw call for a hundred).
  setFrames(frames) {
    emptied(this.frames);
    const positions = [], colours = [], matrix = new THREE.Matrix4(), origin = new THREE.Vector3();
    const end = new THREE.Vector3();
    for (const frame of frames || []) {
      matrix.fromArray(frame.matrix);
      origin.setFromMatrixPosition(matrix);
      const size = frame.relative ? 0.025 : 0.04;
      AXIS_COLOURS.forEach((colour, axis) => {
        end.set(0, 0, 0).setComponent(axis, size).applyMatrix4(matrix);
        positions.push(...origin.toArray(), ...end.toArray());
        colours.push(...colour, ...colour);
      });
    }
    if (positions.length) {
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute("position", new THREE.Float32BufferAttribute(positions, 3));
      geometry.setAttribute("color", new THREE.Float32BufferAttribute(colours, 3));
      this.frames.add(new THREE.LineSegments(geometry, new THREE.LineBasicMaterial({ vertexColors: true })));
    }
  }

  // The checked path: each move's sampled TCP line coloured by its clearance; problems as red marks.
  setCheck(check) {
    emptied(this.path);
    for (const move of (check && check.paths) || []) {
      const geometry = new THREE.BufferGeometry();
      geometry.setAttribute("position", new THREE.Float32BufferAttribute(move.points.flat(), 3));
      geometry.setAttribute("color", new THREE.Float32BufferAttribute(
        move.clearance.flatMap((c) => clearanceColour(c).toArray()), 3));
      this.path.add(new THREE.Line(geometry, new THREE.LineBasicMaterial({ vertexColors: true })));
      this.path.add(new THREE.Points(geometry, new THREE.PointsMaterial({ vertexColors: true, size: 4,
        sizeAttenuation: false })));
    }
    for (const problem of (check && check.problems) || []) {
      if (!problem.tcp) continue;
      const mark = new THREE.Mesh(new THREE.SphereGeometry(0.012, 16, 12),
        new THREE.MeshBasicMaterial({ color: 0xcf222e }));
      mark.position.set(...problem.tcp);
      this.path.add(mark);
    }
  }
}
