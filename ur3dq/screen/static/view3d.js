// The 3D view on the page: the canvas is drawn by a worker (draw_worker.js, the scene in scene3d.js), so drawing
// never holds up the readouts, the buttons or the heartbeat; the page keeps the camera (orbit, zoom and pan with
// mouse and touch: three.js' OrbitControls on the canvas) and the name labels (HTML over the canvas).
import * as THREE from "./vendor/three.bundle.min.js";
import { labelsOf } from "./scene3d.js";

export class View3D {
  // `worker`: draw_worker.js, already started on `canvas` (screen.js starts it before this module loads).
  constructor(canvas, worker) {
    this.canvas = canvas;
    this.worker = worker;
    this.worker.onmessage = (event) => this.fromWorker(event.data);
    this.worker.onerror = (event) => console.error(`the 3D view's worker failed: ${event.message}`);
    this.camera = new THREE.PerspectiveCamera(45, 1, 0.01, 50);
    this.camera.up.set(0, 0, 1);
    this.camera.position.set(1.0, -1.1, 0.8);
    this.labels = new THREE.CSS2DRenderer();
    Object.assign(this.labels.domElement.style, { position: "absolute", top: "0", pointerEvents: "none" });
    canvas.parentElement.appendChild(this.labels.domElement);
    this.labelScene = new THREE.Scene();
    this.labelGroups = { cell: new THREE.Group(), frames: new THREE.Group(), check: new THREE.Group() };
    this.labelScene.add(...Object.values(this.labelGroups));
    this.controls = new THREE.OrbitControls(this.camera, canvas);
    this.controls.target.set(0, 0, 0.2);
    this.controls.enableDamping = false;
    this.controls.addEventListener("change", () => this.cameraMoved());
    this.controls.update();
    this.framesDrawn = 0;      // frames the worker has drawn (the page's own figure)
    this.software = null;      // the worker's renderer is a software one (no GPU)
    this.onArmDrawn = null;
    this.placedKey = null;
    this.framed = false;
    new ResizeObserver(() => this.resize()).observe(canvas.parentElement);
    this.resize();
  }

  post(type, fields = {}) {
    this.worker.postMessage({ type, ...fields });
  }

  fromWorker(message) {
    if ("software" in message) this.software = message.software;
    if ("drawn" in message) this.framesDrawn = message.drawn;
    if (message.firstArm && this.onArmDrawn) this.onArmDrawn();
  }

  resize() {
    const box = this.canvas.parentElement.getBoundingClientRect();
    const width = Math.max(box.width, 50), height = Math.max(box.height, 50);
    this.labels.setSize(width, height);
    this.camera.aspect = width / height;
    this.camera.updateProjectionMatrix();
    this.post("size", { width, height });
    this.cameraMoved();
  }

  cameraMoved() {
    this.post("camera", { position: this.camera.position.toArray(), quaternion: this.camera.quaternion.toArray(),
      aspect: this.camera.aspect });
    this.renderLabels();
  }

  setLabels(kind, data) {
    const group = this.labelGroups[kind];
    group.traverse((object) => { if (object.isCSS2DObject) object.element.remove(); });
    group.clear();
    for (const label of labelsOf(kind, data)) {
      // the renderer places the outer element; the name inside it may be moved up out of another's way
      const element = document.createElement("div");
      const name = element.appendChild(document.createElement("div"));
      name.className = label.problem ? "pose-label problem" : "pose-label";
      name.textContent = label.text;
      const object = new THREE.CSS2DObject(element);
      object.position.set(...label.at);
      group.add(object);
    }
    this.renderLabels();
  }

  renderLabels() {
    this.labels.render(this.labelScene, this.camera);
    const names = [];
    this.labelScene.traverse((object) => {
      if (object.isCSS2DObject && object.element.style.display !== "none") names.push(object.element.firstChild);
    });
    // the problem labels of a check keep their place; the others in the order they were set
    names.sort((a, b) => b.classList.contains("problem") - a.classList.contains("problem"));
    for (const name of names) name.style.transform = "";
    const boxes = names.map((name) => name.getBoundingClientRect());
    const placed = [];
    names.forEach((name, index) => {
      const { left, right, top, height } = boxes[index];
      let shift = 0;
      const covered = () => placed.find((other) => left < other.right && other.left < right &&
        top - shift < other.bottom && other.top < top - shift + height);
      // a name that would cover one already placed goes up, above it, until it covers none
      for (let other = covered(); other && shift < 40 * height; other = covered()) shift = top - other.top + height + 1;
      if (shift) name.style.transform = `translateY(${-shift}px)`;
      placed.push({ left, right, top: top - shift, bottom: top - shift + height });
    });
  }

  setArm(description) {
    this.placedKey = null;
    this.post("arm", { description });
  }

  // The arm at its end points [ax, ay, az, bx, by, bz] per capsule and the TCP frame (column-major 4×4).
  placeArm(placed) {
    if (!placed) return;
    const key = placed.capsules.flat().join(",");
    if (key === this.placedKey) return;   // at rest: nothing to draw again
    this.placedKey = key;
    if (!this.framed) this.frameArm(placed);
    this.post("place", { placed });
  }

  // Look at the arm from the front left, its base and tool in view (once: then the person's own view stays).
  frameArm(placed) {
    this.framed = true;
    const box = new THREE.Box3();
    for (const ends of placed.capsules) {
      box.expandByPoint(new THREE.Vector3(ends[0], ends[1], ends[2]));
      box.expandByPoint(new THREE.Vector3(ends[3], ends[4], ends[5]));
    }
    const centre = box.getCenter(new THREE.Vector3());
    const size = Math.max(box.getSize(new THREE.Vector3()).length(), 0.3);
    this.controls.target.copy(centre);
    this.camera.position.copy(centre).add(new THREE.Vector3(0.55, -1.0, 0.55).multiplyScalar(size * 1.6));
    this.controls.update();
    this.cameraMoved();
  }

  setCell(cell) {
    this.post("cell", { cell });
    this.setLabels("cell", cell);
  }

  setFrames(frames) {
    this.post("frames", { frames });
    this.setLabels("frames", frames);
  }

  setCheck(check) {
    this.post("check", { check });
    this.setLabels("check", check);
  }
}
