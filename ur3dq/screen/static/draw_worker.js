// The 3D view's drawing, in a worker of its own: the page hands over its canvas (an OffscreenCanvas) and then only
// posts what changed (the arm's placement, the camera, the cell, the frames, the check). Drawing (WebGL) can take a
// while, above all without a GPU; here it never holds up the page's readouts, buttons or heartbeat.
import * as THREE from "./vendor/three.bundle.min.js";
import { Scene3D } from "./scene3d.js";

const SOFTWARE_PIXEL_RATIO = 0.5;
let renderer = null, software = false, view = null, pending = false, drawn = 0, armReported = false;
let lastPlaced = null;   // placed again on the arm of a new connection
const camera = new THREE.PerspectiveCamera(45, 1, 0.01, 50);
camera.up.set(0, 0, 1);

// True when WebGL is drawn by a software rasteriser (SwiftShader, llvmpipe): a machine without a usable GPU, whose
// every pixel is drawn by the CPU the page and the server share: then half the pixels are drawn.
function softwareRenderer(gl) {
  const info = gl.getExtension("WEBGL_debug_renderer_info");
  const name = info ? String(gl.getParameter(info.UNMASKED_RENDERER_WEBGL)) : "";
  return /swiftshader|llvmpipe|software/i.test(name);
}

const nextFrame = self.requestAnimationFrame ? (draw) => self.requestAnimationFrame(draw)
  : (draw) => setTimeout(draw, 16);

function requestDraw() {
  if (pending || !renderer) return;
  pending = true;
  nextFrame(() => {
    pending = false;
    renderer.render(view.scene, camera);
    drawn += 1;
    const firstArm = view.armPlaced && !armReported;
    armReported = armReported || firstArm;
    self.postMessage({ drawn, firstArm });
  });
}

const handlers = {
  start({ canvas, ratio }) {
    renderer = new THREE.WebGLRenderer({ canvas, antialias: false });
    software = softwareRenderer(renderer.getContext());
    renderer.setPixelRatio(software ? SOFTWARE_PIXEL_RATIO : ratio);
    view = new Scene3D();
    self.postMessage({ software });
  },
  size({ width, height }) { renderer.setSize(width, height, false); },
  camera({ position, quaternion, aspect }) {
    camera.position.fromArray(position);
    camera.quaternion.fromArray(quaternion);
    camera.aspect = aspect;
    camera.updateProjectionMatrix();
  },
  arm({ description }) {
    view.setArm(description);
    armReported = false;
    if (lastPlaced) view.placeArm(lastPlaced);
  },
  place({ placed }) {
    lastPlaced = placed;
    view.placeArm(placed);
  },
  cell({ cell }) { view.setCell(cell); },
  frames({ frames }) { view.setFrames(frames); },
  check({ check }) { view.setCheck(check); },
};

self.onmessage = (event) => {
  handlers[event.data.type](event.data);
  if (event.data.type !== "start") requestDraw();
};
