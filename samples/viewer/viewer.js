// skelform's web viewer: a skelform-animate file (standard glTF 2.0, roles in node extras,
// frames as morph targets; the contract is in README.md "Web viewer") shown as two synchronized
// views of one scene and one orbit camera: skelform on the left (with the skeletal mesh S'
// as an optional overlay), linear blend skinning on the right.
//
// Frames are applied by this page, not by THREE.AnimationMixer: the weights of frame f
// (fractional while playing) are (1 − a) on target ⌊f⌋ and a on ⌊f⌋ + 1, exactly what the
// file's LINEAR one-hot weight channels give any glTF player, and scrubbing lands on whole
// frames. Mean curvature is computed on the CPU from the current frame's morphed positions.
//
// window.skelformViewer is the small API the browser test and the screenshot script use.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { MeanCurvature, percentile, divergingColour, coolWarmCss } from './curvature.js';

const VIEWS = [
  { role: 'skelform', label: 'skelform', layer: 1 },
  { role: 'lbs', label: 'LBS (linear blend skinning)', layer: 2 },
];
const ROLE_LAYER = { skelform: 1, skeletal: 1, lbs: 2 };

const elements = Object.fromEntries(
  ['canvas', 'message', 'legend', 'legend-bar', 'legend-scale', 'animation', 'play', 'frame', 'frame-label',
   'wireframe', 'skeletal', 'curvature', 'file-input', 'source', 'views'].map((id) => [id, document.getElementById(id)]));

const renderer = new THREE.WebGLRenderer({ canvas: elements.canvas, antialias: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setClearColor(0x30343b);
renderer.setScissorTest(true);
renderer.info.autoReset = false;

const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(35, 1, 0.01, 100);
camera.layers.disableAll();
const hemisphere = new THREE.HemisphereLight(0xffffff, 0x404048, 1.4);
const key = new THREE.DirectionalLight(0xffffff, 2.2);
key.position.set(1, 1.5, 2);
camera.add(key);  // the key light follows the orbit so both views stay lit from the front
scene.add(hemisphere, camera);
for (const light of [hemisphere, key]) light.layers.enableAll();
const controls = new OrbitControls(camera, elements.canvas);
controls.addEventListener('change', () => { state.dirty = true; });

const curvatureMaterial = new THREE.MeshStandardMaterial({ vertexColors: true, roughness: 0.75, metalness: 0 });

const state = {
  root: null,            // the loaded glTF scene
  surfaces: [],          // { mesh, role, original material, MeanCurvature, base/targets as Float32Array }
  skeletal: [],          // skeletal overlay meshes
  morphed: [],           // every mesh whose influences follow the frame
  animations: [],        // [{ name, first_target, frame_count }]
  fps: 30,
  animation: 0,
  time: 0,               // seconds into the current animation
  playing: false,
  wireframe: false,
  showSkeletal: false,
  curvature: false,
  curvatureScale: 1,     // 95th percentile of |H| at rest, shared by both views
  curvatureFrame: -1,    // frame position the colours were computed for
  dirty: true,
  lastViews: [],
  source: '',
};

let resolveReady, rejectReady;
const ready = new Promise((resolve, reject) => { resolveReady = resolve; rejectReady = reject; });
ready.catch(() => {});  // failures are shown in the page; the API caller sees the rejection

function showMessage(text) { elements.message.textContent = text; }

function frameCount() { return state.animations.length ? state.animations[state.animation].frame_count : 0; }
function duration() { return Math.max(0, frameCount() - 1) / state.fps; }
function framePosition() { return Math.min(Math.max(0, frameCount() - 1), state.time * state.fps); }

// --- loading ---

function readContract(gltf) {
  const extras = gltf.parser.json.asset && gltf.parser.json.asset.extras && gltf.parser.json.asset.extras.skelform;
  if (extras && Array.isArray(extras.animations) && extras.animations.length) {
    return { fps: extras.fps || 30, animations: extras.animations, source: extras.source || '' };
  }
  // A file without the asset extras: recover each animation's frame range from its one-hot
  // weight channel (key k is 1 on target first + k).
  const animations = [];
  let fps = 30;
  for (const clip of gltf.animations) {
    const track = clip.tracks.find((t) => t.name.endsWith('.morphTargetInfluences'));
    if (!track) continue;
    const keys = track.times.length, stride = track.values.length / keys;
    let first = 0;
    for (let t = 1; t < stride; ++t) if (track.values[t] > track.values[first]) first = t;
    if (keys > 1) fps = 1 / (track.times[1] - track.times[0]);
    animations.push({ name: clip.name, first_target: first, frame_count: keys });
  }
  return { fps, animations, source: '' };
}

function toFloat32(attribute) {
  const out = new Float32Array(attribute.count * 3);
  for (let i = 0; i < attribute.count; ++i) {
    out[3 * i] = attribute.getX(i);
    out[3 * i + 1] = attribute.getY(i);
    out[3 * i + 2] = attribute.getZ(i);
  }
  return out;
}

function prepareSurface(mesh, role) {
  const geometry = mesh.geometry;
  const base = toFloat32(geometry.attributes.position);
  const targets = (geometry.morphAttributes.position || []).map(toFloat32);
  const index = geometry.index ? geometry.index.array : null;
  const colours = new THREE.BufferAttribute(new Float32Array(base.length), 3);
  colours.setUsage(THREE.DynamicDrawUsage);
  geometry.setAttribute('color', colours);
  return { mesh, role, material: mesh.material, base, targets, relative: geometry.morphTargetsRelative,
           field: new MeanCurvature(base, index), positions: new Float32Array(base.length),
           h: new Float32Array(base.length / 3) };
}

// Positions of the current frame: base + Σ w_k · delta_k (glTF targets are relative).
function morphedPositions(surface) {
  const { base, targets, positions } = surface;
  positions.set(base);
  const influences = surface.mesh.morphTargetInfluences || [];
  for (let k = 0; k < targets.length; ++k) {
    const w = influences[k];
    if (!w) continue;
    const target = targets[k];
    if (surface.relative) for (let i = 0; i < positions.length; ++i) positions[i] += w * target[i];
    else for (let i = 0; i < positions.length; ++i) positions[i] += w * (target[i] - base[i]);
  }
  return positions;
}

function frameBounds() {
  // Every frame of every skelform surface, so the camera fits the whole animation set.
  const box = new THREE.Box3();
  const p = new THREE.Vector3();
  for (const surface of state.surfaces.filter((s) => s.role === 'skelform')) {
    surface.mesh.updateWorldMatrix(true, false);
    const frames = [null, ...surface.targets];
    for (const target of frames) {
      for (let i = 0; i < surface.base.length; i += 3) {
        p.set(surface.base[i], surface.base[i + 1], surface.base[i + 2]);
        if (target) {
          if (surface.relative) p.add(new THREE.Vector3(target[i], target[i + 1], target[i + 2]));
          else p.set(target[i], target[i + 1], target[i + 2]);
        }
        box.expandByPoint(p.applyMatrix4(surface.mesh.matrixWorld));
      }
    }
  }
  return box;
}

function fitCamera() {
  const box = frameBounds();
  if (box.isEmpty()) return;
  const centre = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3());
  state.home = { centre, radius: size.length() / 2, size };
  setView({ target: centre.toArray(), distance: null, azimuth: 20, elevation: 10 });
}

// Camera by orbit parameters (degrees); distance null = fit the whole animation, divided by zoom.
function setView({ target, distance = null, azimuth = 0, elevation = 0, zoom = 1 }) {
  const aspect = camera.aspect || 1;
  const vertical = THREE.MathUtils.degToRad(camera.fov) / 2;
  const horizontal = Math.atan(Math.tan(vertical) * aspect);
  // Fit: the bounds' height in the vertical field of view and their widest horizontal extent
  // (whatever the azimuth) in the horizontal one, from in front of their near side.
  let fit = 3;
  if (state.home) {
    const { size } = state.home, across = Math.hypot(size.x, size.z);
    fit = 1.08 * Math.max(size.y / 2 / Math.tan(vertical), across / 2 / Math.tan(horizontal)) + across / 2;
  }
  const d = distance == null ? fit / zoom : distance;
  const az = THREE.MathUtils.degToRad(azimuth), el = THREE.MathUtils.degToRad(elevation);
  const t = new THREE.Vector3(...target);
  camera.position.set(t.x + d * Math.cos(el) * Math.sin(az), t.y + d * Math.sin(el), t.z + d * Math.cos(el) * Math.cos(az));
  camera.near = Math.max(1e-4, d / 200);
  camera.far = d * 20 + (state.home ? 4 * state.home.radius : 10);
  camera.updateProjectionMatrix();
  controls.target.copy(t);
  controls.update();
  state.dirty = true;
}

function clearScene() {
  if (state.root) scene.remove(state.root);
  state.root = null;
  state.surfaces = [];
  state.skeletal = [];
  state.morphed = [];
  state.animations = [];
}

function install(gltf, sourceName) {
  clearScene();
  const contract = readContract(gltf);
  state.fps = contract.fps;
  state.animations = contract.animations;
  state.source = contract.source || sourceName;
  const root = gltf.scene;
  const roleNodes = [];
  root.traverse((object) => { if (object.userData.skelform && object.userData.skelform.role) roleNodes.push(object); });
  if (roleNodes.length === 0) throw new Error('no skelform roles in this file (node extras.skelform.role): is it a skelform-animate output?');
  for (const node of roleNodes) {
    const role = node.userData.skelform.role;
    // The LBS copy stands beside skelform in the file (translation [offset, 0, 0]); here it
    // gets its own view, so it goes back onto skelform's place and both share one camera.
    if (role === 'lbs') node.position.set(0, 0, 0);
    let primitive = 0;
    node.traverse((object) => {
      object.layers.set(ROLE_LAYER[role] || 1);
      if (!object.isMesh) return;
      object.frustumCulled = false;  // morphing moves vertices outside the rest bounds
      if (object.morphTargetInfluences) state.morphed.push(object);
      if (role === 'skeletal') {
        // Drawn through the surface so the inner skeletal mesh is visible inside it.
        object.material = object.material.clone();
        object.material.depthTest = false;
        object.material.transparent = true;
        object.renderOrder = 10;
        object.visible = state.showSkeletal;
        state.skeletal.push(object);
      } else {
        // Which surface of the other role is the same primitive: deformable and order in the node.
        const surface = prepareSurface(object, role);
        surface.key = `${node.userData.skelform.deformable}:${primitive++}`;
        state.surfaces.push(surface);
      }
    });
  }
  scene.add(root);
  state.root = root;
  root.updateMatrixWorld(true);

  // Robust curvature scale at rest (weights 0), from the skelform surfaces, for both views.
  const magnitudes = [];
  for (const surface of state.surfaces) if (surface.role === 'skelform') magnitudes.push(...surface.field.interiorMagnitudes(surface.base));
  state.curvatureScale = percentile(magnitudes, 0.95) || 1;
  elements['legend-scale'].textContent = `|H| ≤ ${state.curvatureScale.toPrecision(3)} (95% at rest)`;

  elements.animation.replaceChildren(...state.animations.map((a, i) => new Option(`${a.name || `animation ${i}`} (${a.frame_count} frames)`, i)));
  elements.source.textContent = state.source;
  elements.source.title = state.source;
  state.animation = 0;
  state.time = 0;
  state.curvatureFrame = -1;
  applyMaterials();
  applyFrame();
  resize();
  fitCamera();
  showMessage('');
}

async function loadUrl(url) {
  showMessage(`loading ${url} …`);
  const loader = new GLTFLoader();
  const gltf = await loader.loadAsync(url);
  install(gltf, decodeURIComponent(url.split('/').pop()));
}

async function loadFile(file) {
  showMessage(`loading ${file.name} …`);
  const gltf = await new GLTFLoader().parseAsync(await file.arrayBuffer(), '');
  install(gltf, file.name);
}

// --- frame, materials, curvature ---

function applyFrame() {
  const animation = state.animations[state.animation];
  const f = framePosition();
  for (const mesh of state.morphed) mesh.morphTargetInfluences.fill(0);
  if (animation) {
    const k = Math.floor(f), a = f - k;
    for (const mesh of state.morphed) {
      const influences = mesh.morphTargetInfluences;
      const target = animation.first_target + k;
      if (target < influences.length) influences[target] = 1 - a;
      if (a > 0 && target + 1 < influences.length) influences[target + 1] = a;
    }
  }
  elements.frame.max = String(Math.max(0, frameCount() - 1));
  elements.frame.value = String(Math.round(f));
  elements['frame-label'].textContent = `${Math.round(f)} / ${Math.max(0, frameCount() - 1)}`;
  if (state.curvature) updateCurvature();
  state.dirty = true;
}

function updateCurvature() {
  const f = framePosition();
  if (state.curvatureFrame === f) return;
  state.curvatureFrame = f;
  for (const surface of state.surfaces) {
    const h = surface.field.compute(morphedPositions(surface), surface.h);
    const colours = surface.mesh.geometry.attributes.color;
    for (let v = 0; v < h.length; ++v) divergingColour(h[v] / state.curvatureScale, colours.array, 3 * v);
    colours.needsUpdate = true;
  }
}

function applyMaterials() {
  for (const surface of state.surfaces) {
    surface.mesh.material = state.curvature ? curvatureMaterial : surface.material;
    surface.material.wireframe = state.wireframe;
  }
  curvatureMaterial.wireframe = state.wireframe;
  for (const mesh of state.skeletal) mesh.visible = state.showSkeletal;
  elements.legend.hidden = !state.curvature;
  if (state.curvature) updateCurvature();
  state.dirty = true;
}

// --- rendering ---

function resize() {
  const { clientWidth: width, clientHeight: height } = elements.views;
  renderer.setSize(width, height, false);
  camera.aspect = Math.max(1, width / 2) / Math.max(1, height);
  camera.updateProjectionMatrix();
  state.dirty = true;
}

function render() {
  const width = elements.views.clientWidth, height = elements.views.clientHeight;
  const half = Math.floor(width / 2);
  state.lastViews = VIEWS.map((view, i) => {
    const x = i === 0 ? 0 : width - half;
    renderer.setViewport(x, 0, half, height);
    renderer.setScissor(x, 0, half, height);
    camera.layers.set(view.layer);
    renderer.info.reset();
    renderer.render(scene, camera);
    let meshes = 0;
    scene.traverseVisible((o) => { if (o.isMesh && o.layers.test(camera.layers)) ++meshes; });
    return { role: view.role, label: view.label, meshes, triangles: renderer.info.render.triangles,
             viewport: { x, y: 0, width: half, height } };
  });
  state.dirty = false;
}

let lastTime = performance.now();
function tick(now) {
  const dt = Math.min(0.1, (now - lastTime) / 1000);
  lastTime = now;
  if (state.playing && duration() > 0) {
    state.time = (state.time + dt) % duration();
    applyFrame();
  }
  if (state.dirty && state.root) render();
  requestAnimationFrame(tick);
}

// --- UI ---

function setPlaying(playing) {
  state.playing = playing && frameCount() > 1;
  elements.play.textContent = state.playing ? 'pause' : 'play';
}

function setFrame(k) {
  setPlaying(false);
  state.time = Math.min(Math.max(0, Math.round(k)), Math.max(0, frameCount() - 1)) / state.fps;
  applyFrame();
}

function setAnimation(i) {
  if (!(i >= 0 && i < state.animations.length)) throw new RangeError(`animation ${i} of ${state.animations.length}`);
  state.animation = i;
  elements.animation.value = String(i);
  state.time = Math.min(state.time, duration());
  applyFrame();
}

elements.play.addEventListener('click', () => setPlaying(!state.playing));
elements.frame.addEventListener('input', () => setFrame(Number(elements.frame.value)));
elements.animation.addEventListener('change', () => setAnimation(Number(elements.animation.value)));
elements.wireframe.addEventListener('change', () => { state.wireframe = elements.wireframe.checked; applyMaterials(); });
elements.skeletal.addEventListener('change', () => { state.showSkeletal = elements.skeletal.checked; applyMaterials(); });
elements.curvature.addEventListener('change', () => { state.curvature = elements.curvature.checked; applyMaterials(); });
elements['legend-bar'].style.background = coolWarmCss();
elements['file-input'].addEventListener('change', () => {
  const file = elements['file-input'].files[0];
  if (file) loadFile(file).catch((err) => showMessage(`cannot open ${file.name}: ${err.message}`));
});
window.addEventListener('keydown', (event) => {
  if (['INPUT', 'SELECT', 'BUTTON'].includes(event.target.tagName)) return;  // they handle the space bar themselves
  if (event.code === 'Space') { setPlaying(!state.playing); event.preventDefault(); }
});
window.addEventListener('resize', resize);

window.skelformViewer = {
  ready,
  get frameCount() { return frameCount(); },
  get frame() { return framePosition(); },
  get animations() { return state.animations.map((a) => ({ ...a })); },
  get fps() { return state.fps; },
  get playing() { return state.playing; },
  get curvatureScale() { return state.curvatureScale; },
  play() { setPlaying(true); },
  pause() { setPlaying(false); },
  setFrame,
  setAnimation,
  setWireframe(on) { state.wireframe = elements.wireframe.checked = !!on; applyMaterials(); },
  setSkeletal(on) { state.showSkeletal = elements.skeletal.checked = !!on; applyMaterials(); },
  setCurvature(on) { state.curvature = elements.curvature.checked = !!on; applyMaterials(); },
  setView,
  // Renders now and says what each view drew: role, label, visible meshes, triangles, viewport
  // (CSS pixels, origin bottom left).
  renderedViews() { render(); return state.lastViews.map((v) => ({ ...v, viewport: { ...v.viewport } })); },
  // Mean curvature of the current frame, per vertex of each surface: [{ role, h: [...] }].
  curvature() { return state.surfaces.map((s) => ({ role: s.role, h: Array.from(s.field.compute(morphedPositions(s), s.h)) })); },
  // The world-space point where skelform and LBS differ most over all frames (a bent joint),
  // with its frame and animation: what the README's close-up frames.
  largestDifference() {
    let best = { distance: -1 };
    for (const s of state.surfaces.filter((x) => x.role === 'skelform')) {
      const lbs = state.surfaces.find((x) => x.role === 'lbs' && x.key === s.key);
      if (!lbs || lbs.base.length !== s.base.length) continue;
      state.animations.forEach((a, ai) => {
        for (let k = 0; k < a.frame_count; ++k) {
          const ts = s.targets[a.first_target + k], tl = lbs.targets[a.first_target + k];
          if (!ts || !tl) continue;
          for (let i = 0; i < s.base.length; i += 3) {
            const d = Math.hypot(ts[i] - tl[i], ts[i + 1] - tl[i + 1], ts[i + 2] - tl[i + 2]);
            if (d > best.distance) {
              best = { distance: d, animation: ai, frame: k,
                       point: [s.base[i] + ts[i], s.base[i + 1] + ts[i + 1], s.base[i + 2] + ts[i + 2]] };
            }
          }
        }
      });
    }
    return best.distance < 0 ? null : best;
  },
  // The fitted camera: centre of all frames' bounds (for setView) and their bounding radius.
  get home() { return state.home ? { target: state.home.centre.toArray(), distance: null } : null; },
  get radius() { return state.home ? state.home.radius : 0; },
};

const fileParameter = new URLSearchParams(window.location.search).get('file');
if (fileParameter) {
  loadUrl(fileParameter).then(() => { render(); resolveReady(); }, (err) => {
    showMessage(`cannot open ${fileParameter}: ${err.message}`);
    console.error(`skelform viewer: cannot open ${fileParameter}: ${err.message}`);
    rejectReady(err);
  });
} else {
  showMessage('no file: start with ./run.sh viewer FILE.anim.glb, or open one (toolbar)');
}
requestAnimationFrame(tick);
