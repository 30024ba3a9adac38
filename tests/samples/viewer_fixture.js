#!/usr/bin/env node
// A small file of skelform-animate's animation contract (docs/runtime-api.md, issue 6), made
// without the runtime, so the web viewer's browser test does not depend on the C++ tools:
//   node viewer_fixture.js OUT.glb
//
// One deformable "tube": a capped cylinder of height 2 bending about a joint at y = 1.
//  - role skelform: every vertex rotated by its blended angle (volume kept at the joint);
//  - role lbs: the two bone transforms blended linearly (the joint collapses as in LBS);
//  - role skeletal: a thin inner tube following the skelform motion (POSITION targets only).
// Two animations ("bend" 1 s, "wave" 0.5 s) sampled at 30 fps, concatenated as morph targets
// and driven by one-hot LINEAR weight channels; asset.extras.skelform as in the contract.
'use strict';

const fs = require('fs');

const FPS = 30;
const JOINT_Y = 1.0;

function tube(radius, rings, segments, height) {
  const positions = [], indices = [];
  for (let r = 0; r <= rings; ++r) {
    const y = (height * r) / rings;
    for (let s = 0; s < segments; ++s) {
      const a = (2 * Math.PI * s) / segments;
      positions.push([radius * Math.cos(a), y, -radius * Math.sin(a)]);
    }
  }
  const ring = (r, s) => r * segments + (s % segments);
  for (let r = 0; r < rings; ++r) {
    for (let s = 0; s < segments; ++s) {
      indices.push(ring(r, s), ring(r, s + 1), ring(r + 1, s + 1));
      indices.push(ring(r, s), ring(r + 1, s + 1), ring(r + 1, s));
    }
  }
  const bottom = positions.length, top = bottom + 1;
  positions.push([0, 0, 0], [0, height, 0]);
  for (let s = 0; s < segments; ++s) {
    indices.push(bottom, ring(0, s + 1), ring(0, s));
    indices.push(top, ring(rings, s), ring(rings, s + 1));
  }
  return { positions, indices };
}

function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
function cross(a, b) { return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]; }
function normalize(a) { const l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; }

function vertexNormals(positions, indices) {
  const normals = positions.map(() => [0, 0, 0]);
  for (let t = 0; t < indices.length; t += 3) {
    const [a, b, c] = [indices[t], indices[t + 1], indices[t + 2]];
    const n = cross(sub(positions[b], positions[a]), sub(positions[c], positions[a]));
    for (const v of [a, b, c]) for (let i = 0; i < 3; ++i) normals[v][i] += n[i];
  }
  return normals.map(normalize);
}

// Rotation about z through (0, JOINT_Y, 0).
function rotate(p, angle, isDirection) {
  const c = Math.cos(angle), s = Math.sin(angle);
  const y = isDirection ? p[1] : p[1] - JOINT_Y;
  return [c * p[0] - s * y, s * p[0] + c * y + (isDirection ? 0 : JOINT_Y), p[2]];
}

function upperWeight(y) {
  const t = Math.min(1, Math.max(0, (y - (JOINT_Y - 0.25)) / 0.5));
  return t * t * (3 - 2 * t);
}

function blendedAngle(p, angle) { return rotate(p, upperWeight(p[1]) * angle, false); }
function blendedAngleNormal(n, p, angle) { return rotate(n, upperWeight(p[1]) * angle, true); }
function linearBlend(p, angle) {
  const w = upperWeight(p[1]), q = rotate(p, angle, false);
  return [0, 1, 2].map((i) => (1 - w) * p[i] + w * q[i]);
}

const animations = [
  { name: 'bend', duration: 1.0, angle: (t) => (110 * Math.PI / 180) * t },
  { name: 'wave', duration: 0.5, angle: (t) => (70 * Math.PI / 180) * Math.sin(2 * Math.PI * t / 0.5) },
];

function build() {
  const surface = tube(0.25, 40, 32, 2.0);
  const skeletal = tube(0.06, 20, 8, 2.0);
  const surfaceNormals = vertexNormals(surface.positions, surface.indices);
  const frames = [];  // {skelform: {p, n}, lbs: {p, n}, skeletal: p}
  const animationInfo = [];
  for (const animation of animations) {
    const count = Math.round(animation.duration * FPS) + 1;
    animationInfo.push({ name: animation.name, first_target: frames.length, frame_count: count });
    for (let k = 0; k < count; ++k) {
      const angle = animation.angle(k / FPS);
      const skelformPositions = surface.positions.map((p) => blendedAngle(p, angle));
      const skelformNormals = surface.positions.map((p, i) => blendedAngleNormal(surfaceNormals[i], p, angle));
      const lbsPositions = surface.positions.map((p) => linearBlend(p, angle));
      frames.push({
        skelform: { p: skelformPositions, n: skelformNormals },
        lbs: { p: lbsPositions, n: vertexNormals(lbsPositions, surface.indices) },
        skeletal: skeletal.positions.map((p) => blendedAngle(p, angle)),
      });
    }
  }
  let minX = Infinity, maxX = -Infinity;
  for (const f of frames) for (const p of f.skelform.p.concat(f.lbs.p)) { minX = Math.min(minX, p[0]); maxX = Math.max(maxX, p[0]); }
  const offset = 1.3 * (maxX - minX);
  return { surface, surfaceNormals, skeletal, frames, animationInfo, offset };
}

// --- GLB writing ---
class Writer {
  constructor() { this.chunks = []; this.length = 0; this.gltf = { bufferViews: [], accessors: [] }; }
  view(bytes, target) {
    const pad = (4 - (this.length % 4)) % 4;
    if (pad) { this.chunks.push(Buffer.alloc(pad)); this.length += pad; }
    const view = { buffer: 0, byteOffset: this.length, byteLength: bytes.length };
    if (target) view.target = target;
    this.chunks.push(bytes);
    this.length += bytes.length;
    this.gltf.bufferViews.push(view);
    return this.gltf.bufferViews.length - 1;
  }
  vec3(list, withBounds) {
    const data = new Float32Array(list.length * 3);
    list.forEach((v, i) => data.set(v, 3 * i));
    const accessor = { bufferView: this.view(Buffer.from(data.buffer), 34962), componentType: 5126, count: list.length, type: 'VEC3' };
    if (withBounds) {
      accessor.min = [0, 1, 2].map((c) => Math.min(...list.map((v) => Math.fround(v[c]))));
      accessor.max = [0, 1, 2].map((c) => Math.max(...list.map((v) => Math.fround(v[c]))));
    }
    this.gltf.accessors.push(accessor);
    return this.gltf.accessors.length - 1;
  }
  scalars(values, withBounds) {
    const data = new Float32Array(values);
    const accessor = { bufferView: this.view(Buffer.from(data.buffer)), componentType: 5126, count: values.length, type: 'SCALAR' };
    if (withBounds) { accessor.min = [Math.min(...data)]; accessor.max = [Math.max(...data)]; }
    this.gltf.accessors.push(accessor);
    return this.gltf.accessors.length - 1;
  }
  indices(list) {
    const data = new Uint32Array(list);
    this.gltf.accessors.push({ bufferView: this.view(Buffer.from(data.buffer), 34963), componentType: 5125, count: list.length, type: 'SCALAR' });
    return this.gltf.accessors.length - 1;
  }
  glb() {
    const bin = Buffer.concat(this.chunks);
    const binPadded = Buffer.concat([bin, Buffer.alloc((4 - (bin.length % 4)) % 4)]);
    this.gltf.buffers = [{ byteLength: binPadded.length }];
    let json = Buffer.from(JSON.stringify(this.gltf));
    json = Buffer.concat([json, Buffer.alloc((4 - (json.length % 4)) % 4, 0x20)]);
    const header = Buffer.alloc(12);
    header.writeUInt32LE(0x46546c67, 0);
    header.writeUInt32LE(2, 4);
    header.writeUInt32LE(12 + 8 + json.length + 8 + binPadded.length, 8);
    const chunkHeader = (length, type) => { const b = Buffer.alloc(8); b.writeUInt32LE(length, 0); b.writeUInt32LE(type, 4); return b; };
    return Buffer.concat([header, chunkHeader(json.length, 0x4e4f534a), json, chunkHeader(binPadded.length, 0x004e4942), binPadded]);
  }
}

function write(file) {
  const model = build();
  const w = new Writer();
  const g = w.gltf;
  g.asset = { version: '2.0', generator: 'skelform viewer test fixture',
              extras: { skelform: { fps: FPS, source: 'tube (test fixture)', animations: model.animationInfo, offset: [model.offset, 0, 0] } } };
  g.materials = [
    { name: 'surface', pbrMetallicRoughness: { baseColorFactor: [0.8, 0.78, 0.72, 1], metallicFactor: 0, roughnessFactor: 0.7 } },
    { name: 'skeletal', pbrMetallicRoughness: { baseColorFactor: [0.9, 0.1, 0.1, 0.5], metallicFactor: 0, roughnessFactor: 0.8 },
      alphaMode: 'BLEND', doubleSided: true },
  ];
  const targetCount = model.frames.length;
  const zeros = new Array(targetCount).fill(0);
  const surfaceIndices = w.indices(model.surface.indices);
  const surfaceMesh = (role) => {
    const base = model.surface.positions, baseNormals = model.surfaceNormals;
    const targets = model.frames.map((f) => ({
      POSITION: w.vec3(f[role].p.map((p, i) => sub(p, base[i])), true),
      NORMAL: w.vec3(f[role].n.map((n, i) => sub(n, baseNormals[i])), false),
    }));
    return { name: `${role}:tube`, weights: zeros,
             primitives: [{ attributes: { POSITION: w.vec3(base, true), NORMAL: w.vec3(baseNormals, false) },
                            indices: surfaceIndices, material: 0, targets }] };
  };
  const skeletalBase = model.skeletal.positions;
  g.meshes = [surfaceMesh('skelform'), surfaceMesh('lbs'), {
    name: 'skeletal:tube', weights: zeros,
    primitives: [{ attributes: { POSITION: w.vec3(skeletalBase, true) }, indices: w.indices(model.skeletal.indices), material: 1,
                   targets: model.frames.map((f) => ({ POSITION: w.vec3(f.skeletal.map((p, i) => sub(p, skeletalBase[i])), true) })) }],
  }];
  g.nodes = ['skelform', 'lbs', 'skeletal'].map((role, i) => ({
    name: `${role}:tube`, mesh: i, translation: [role === 'lbs' ? model.offset : 0, 0, 0],
    extras: { skelform: { role, deformable: 0 } },
  }));
  g.scenes = [{ nodes: [0, 1, 2] }];
  g.scene = 0;
  g.animations = model.animationInfo.map((a) => {
    const times = [], weights = [];
    for (let k = 0; k < a.frame_count; ++k) {
      times.push(k / FPS);
      for (let t = 0; t < targetCount; ++t) weights.push(t === a.first_target + k ? 1 : 0);
    }
    const sampler = { input: w.scalars(times, true), output: w.scalars(weights, false), interpolation: 'LINEAR' };
    return { name: a.name, samplers: [0, 1, 2].map(() => ({ ...sampler })),
             channels: [0, 1, 2].map((node) => ({ sampler: node, target: { node, path: 'weights' } })) };
  });
  fs.writeFileSync(file, w.glb());
}

if (process.argv.length !== 3) {
  console.error('usage: node viewer_fixture.js OUT.glb');
  process.exit(2);
}
write(process.argv[2]);
