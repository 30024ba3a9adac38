#!/usr/bin/env node
// Checks a skelform-animate output against the file contract (samples/animate/animation_glb.h)
// and prints what it measured. Standard library only (no npm package needed).
//
//   node animate_check.js OUT.glb [--animations name1,name2,...] [--frames n1,n2,...]
//                                 [--source NAME] [--fps F] [--expect-from SOURCE.glb]
//   node animate_check.js --strip animations|skins IN.glb OUT.glb
//
// --expect-from derives the expected names and frame counts from the source model itself:
// its animations' names (or "animation N") and durations (the extent of their samplers'
// inputs), ceil(duration × fps) + 1 frames each (at most 300), or one "rest pose" frame when
// it has none. --strip writes a copy of a GLB without its animations, or without skins,
// joint attributes and animations (an unskinned model): inputs for the error-path tests.
//
// Checks: GLB container; asset.extras.skelform (fps, source, offset, animation ranges that
// tile the targets in order); per deformable three root nodes with the roles skelform, lbs,
// skeletal, their extras, translations (lbs at the offset) and meshes whose every primitive
// has exactly one morph target per frame (POSITION with min/max, NORMAL except skeletal) and
// mesh.weights all 0; one glTF animation per range, same name, whose channels drive the
// weights of every node with LINEAR samplers, input = frame count times from 0, output =
// one-hot weights on the frame's own target. With --animations / --frames: the expected
// names and frame counts. It then prints, per deformable, the enclosed volume of the
// skelform and LBS meshes over all frames relative to the rest mesh (min and max): LBS loses
// volume in bends, which is what the side-by-side view shows.
// Exit status: 0 when every check passes, 1 otherwise (each failure printed), 2 bad usage.
'use strict';

const fs = require('fs');

function parseArgs(argv) {
  const args = { file: null };
  for (let i = 0; i < argv.length; ++i) {
    const a = argv[i];
    if (a === '--animations') args.animations = argv[++i].split(',');
    else if (a === '--frames') args.frames = argv[++i].split(',').map(Number);
    else if (a === '--source') args.source = argv[++i];
    else if (a === '--fps') args.fps = Number(argv[++i]);
    else if (a === '--expect-from') args.expectFrom = argv[++i];
    else if (!args.file) args.file = a;
    else return null;
  }
  return args.file ? args : null;
}

function readGlb(file) {
  const bytes = fs.readFileSync(file);
  if (bytes.length < 20 || bytes.toString('latin1', 0, 4) !== 'glTF') throw new Error('not a GLB');
  if (bytes.readUInt32LE(4) !== 2) throw new Error('GLB version is not 2');
  if (bytes.readUInt32LE(8) !== bytes.length) throw new Error('GLB length field differs from the file size');
  const jsonLength = bytes.readUInt32LE(12);
  if (bytes.readUInt32LE(16) !== 0x4e4f534a) throw new Error('first chunk is not JSON');
  const json = JSON.parse(bytes.toString('utf8', 20, 20 + jsonLength));
  const binStart = 20 + jsonLength;
  const binLength = bytes.readUInt32LE(binStart);
  if (bytes.readUInt32LE(binStart + 4) !== 0x004e4942) throw new Error('second chunk is not BIN');
  return { json, bin: bytes.subarray(binStart + 8, binStart + 8 + binLength) };
}

function main() {
  const args = parseArgs(process.argv.slice(2));
  if (!args) {
    console.error('usage: node animate_check.js OUT.glb [--animations a,b] [--frames n,m] [--source NAME] [--fps F]');
    return 2;
  }
  const failures = [];
  const check = (ok, message) => { if (!ok) failures.push(message); };
  const { json, bin } = readGlb(args.file);

  const accessorData = (index) => {
    const a = json.accessors[index];
    const view = json.bufferViews[a.bufferView];
    const components = { SCALAR: 1, VEC3: 3, VEC4: 4, MAT4: 16 }[a.type];
    const offset = bin.byteOffset + (view.byteOffset || 0) + (a.byteOffset || 0);
    if (view.byteStride) throw new Error('strided accessors are not expected');
    if (a.componentType === 5126) return new Float32Array(bin.buffer.slice(offset, offset + 4 * a.count * components));
    if (a.componentType === 5125) return new Uint32Array(bin.buffer.slice(offset, offset + 4 * a.count * components));
    throw new Error(`unexpected componentType ${a.componentType}`);
  };

  const extras = json.asset && json.asset.extras && json.asset.extras.skelform;
  check(extras, 'asset.extras.skelform missing');
  if (!extras) return report(failures);
  check(!json.extensionsUsed && !json.extensionsRequired, 'the file must use no extension');
  check(typeof extras.fps === 'number' && extras.fps > 0, 'extras.fps must be a positive number');
  if (args.fps !== undefined) check(extras.fps === args.fps, `extras.fps ${extras.fps}, expected ${args.fps}`);
  if (args.source !== undefined) check(extras.source === args.source, `extras.source '${extras.source}', expected '${args.source}'`);
  check(Array.isArray(extras.offset) && extras.offset.length === 3 && extras.offset[0] > 0 &&
        extras.offset[1] === 0 && extras.offset[2] === 0, 'extras.offset must be [positive, 0, 0]');
  const ranges = extras.animations || [];
  let targetCount = 0;
  for (const r of ranges) {
    check(r.first_target === targetCount, `animation '${r.name}' starts at target ${r.first_target}, expected ${targetCount}`);
    check(Number.isInteger(r.frame_count) && r.frame_count >= 1, `animation '${r.name}' has no frame`);
    targetCount += r.frame_count;
  }
  check(targetCount > 0, 'no frame at all');
  if (args.expectFrom) {
    const source = readGlb(args.expectFrom).json;
    const fps = args.fps !== undefined ? args.fps : 30;
    const names = [], frames = [];
    (source.animations || []).forEach((animation, a) => {
      let start = Infinity, end = -Infinity;
      for (const sampler of animation.samplers) {
        const input = source.accessors[sampler.input];
        start = Math.min(start, input.min[0]);
        end = Math.max(end, input.max[0]);
      }
      names.push(animation.name ? animation.name : `animation ${a}`);
      frames.push(end > start ? Math.min(300, Math.ceil((end - start) * fps - 1e-6) + 1) : 1);
    });
    if (names.length === 0) { names.push('rest pose'); frames.push(1); }
    args.animations = args.animations || names;
    args.frames = args.frames || frames;
  }
  if (args.animations) check(JSON.stringify(ranges.map((r) => r.name)) === JSON.stringify(args.animations),
                             `animation names ${JSON.stringify(ranges.map((r) => r.name))}, expected ${JSON.stringify(args.animations)}`);
  if (args.frames) check(JSON.stringify(ranges.map((r) => r.frame_count)) === JSON.stringify(args.frames),
                         `frame counts ${JSON.stringify(ranges.map((r) => r.frame_count))}, expected ${JSON.stringify(args.frames)}`);

  // Nodes: three roles per deformable, all scene roots.
  const roots = json.scenes[json.scene || 0].nodes;
  const byDeformable = new Map();
  for (const n of roots) {
    const node = json.nodes[n];
    const info = node.extras && node.extras.skelform;
    check(info && ['skelform', 'lbs', 'skeletal'].includes(info.role), `node ${n} has no skelform role`);
    if (!info) continue;
    check(node.name.startsWith(info.role + ':'), `node ${n} name '${node.name}' does not start with its role`);
    check(!node.rotation && !node.scale && !node.matrix, `node ${n} must have identity rotation and scale`);
    const x = info.role === 'lbs' ? extras.offset[0] : 0;
    check(JSON.stringify(node.translation) === JSON.stringify([x, 0, 0]), `node ${n} translation ${JSON.stringify(node.translation)}`);
    if (!byDeformable.has(info.deformable)) byDeformable.set(info.deformable, {});
    const roles = byDeformable.get(info.deformable);
    check(!roles[info.role], `deformable ${info.deformable} has two '${info.role}' nodes`);
    roles[info.role] = n;
    const mesh = json.meshes[node.mesh];
    check(mesh.weights && mesh.weights.length === targetCount && mesh.weights.every((w) => w === 0),
          `mesh of node ${n}: weights must be ${targetCount} zeros`);
    for (const p of mesh.primitives) {
      check(p.targets && p.targets.length === targetCount, `mesh of node ${n}: ${p.targets ? p.targets.length : 0} targets, expected ${targetCount}`);
      for (const t of p.targets || []) {
        const pos = json.accessors[t.POSITION];
        check(pos && pos.min && pos.max, `mesh of node ${n}: a POSITION target without min/max`);
        check((info.role === 'skeletal') === (t.NORMAL === undefined), `mesh of node ${n}: NORMAL targets expected only on skelform/lbs`);
      }
    }
  }
  check(byDeformable.size > 0, 'no deformable node');
  for (const [d, roles] of byDeformable)
    check(roles.skelform !== undefined && roles.lbs !== undefined && roles.skeletal !== undefined,
          `deformable ${d} lacks a role: ${JSON.stringify(roles)}`);
  const skeletal = [...byDeformable.values()].map((r) => json.meshes[json.nodes[r.skeletal].mesh]);
  for (const m of skeletal) {
    const material = json.materials[m.primitives[0].material];
    check(material.alphaMode === 'BLEND' && material.doubleSided === true, 'the skeletal material must be BLEND and double-sided');
  }

  // Animations: one per range, driving every role node's weights with one-hot keys.
  const animations = json.animations || [];
  check(animations.length === ranges.length, `${animations.length} glTF animations for ${ranges.length} ranges`);
  animations.forEach((animation, a) => {
    const range = ranges[a];
    if (!range) return;
    check(animation.name === range.name, `animation ${a} is named '${animation.name}', extras say '${range.name}'`);
    const driven = new Set(animation.channels.filter((c) => c.target.path === 'weights').map((c) => c.target.node));
    check(driven.size === roots.length && roots.every((n) => driven.has(n)), `animation '${animation.name}' does not drive every node`);
    for (const channel of animation.channels) {
      const sampler = animation.samplers[channel.sampler];
      check(sampler.interpolation === 'LINEAR', `animation '${animation.name}': interpolation ${sampler.interpolation}`);
      const input = accessorData(sampler.input);
      const output = accessorData(sampler.output);
      check(input.length === range.frame_count, `animation '${animation.name}': ${input.length} keys, ${range.frame_count} frames`);
      check(input[0] === 0, `animation '${animation.name}': first key at ${input[0]}, expected 0`);
      for (let k = 1; k < input.length; ++k) check(input[k] > input[k - 1], `animation '${animation.name}': keys not increasing`);
      check(output.length === input.length * targetCount, `animation '${animation.name}': output size`);
      for (let k = 0; k < input.length; ++k)
        for (let t = 0; t < targetCount; ++t) {
          const expected = t === range.first_target + k ? 1 : 0;
          if (output[k * targetCount + t] !== expected) {
            check(false, `animation '${animation.name}': key ${k} weight ${t} is ${output[k * targetCount + t]}, expected ${expected}`);
            k = input.length;
            break;
          }
        }
      // With the fps, keys are k / fps but for the last (the animation's end) when not capped.
      if (input.length >= 3 && Math.abs(input[1] - 1 / extras.fps) < 1e-6)
        check(Math.abs(input[input.length - 2] - (input.length - 2) / extras.fps) < 1e-4, `animation '${animation.name}': keys not at k / fps`);
    }
  });

  // Measured: enclosed volume over the frames, relative to the rest mesh.
  const volume = (positions, indices) => {
    let v = 0;
    for (let i = 0; i < indices.length; i += 3) {
      const a = 3 * indices[i], b = 3 * indices[i + 1], c = 3 * indices[i + 2];
      v += positions[a] * (positions[b + 1] * positions[c + 2] - positions[b + 2] * positions[c + 1]) -
           positions[a + 1] * (positions[b] * positions[c + 2] - positions[b + 2] * positions[c]) +
           positions[a + 2] * (positions[b] * positions[c + 1] - positions[b + 1] * positions[c]);
    }
    return v / 6;
  };
  for (const [d, roles] of byDeformable) {
    const line = [];
    for (const role of ['skelform', 'lbs']) {
      const mesh = json.meshes[json.nodes[roles[role]].mesh];
      let rest = 0;
      const frames = new Float64Array(targetCount);
      for (const p of mesh.primitives) {
        const base = accessorData(p.attributes.POSITION);
        const indices = accessorData(p.indices);
        rest += volume(base, indices);
        p.targets.forEach((t, k) => {
          const delta = accessorData(t.POSITION);
          const posed = new Float32Array(base.length);
          for (let i = 0; i < base.length; ++i) posed[i] = base[i] + delta[i];
          frames[k] += volume(posed, indices);
        });
      }
      let lo = Infinity, hi = -Infinity, worst = 0;
      frames.forEach((v, k) => { const r = v / rest; if (r < lo) { lo = r; worst = k; } hi = Math.max(hi, r); });
      line.push(`${role} volume ${(100 * lo).toFixed(1)}%..${(100 * hi).toFixed(1)}% of rest (lowest at target ${worst})`);
    }
    console.log(`deformable ${d}: ${line.join('; ')}`);
  }
  console.log(`${args.file}: ${ranges.length} animation(s) ${JSON.stringify(ranges.map((r) => [r.name, r.frame_count]))}, ` +
              `${targetCount} targets, ${byDeformable.size} deformable(s)`);
  return report(failures);
}

function report(failures) {
  for (const f of failures.slice(0, 20)) console.log(`FAIL: ${f}`);
  if (failures.length > 20) console.log(`... and ${failures.length - 20} more`);
  return failures.length ? 1 : 0;
}

function strip(what, input, output) {
  const { json, bin } = readGlb(input);
  delete json.animations;
  if (what === 'skins') {
    delete json.skins;
    for (const node of json.nodes || []) delete node.skin;
    for (const mesh of json.meshes || [])
      for (const p of mesh.primitives) for (const a of Object.keys(p.attributes)) if (/^(JOINTS|WEIGHTS)_/.test(a)) delete p.attributes[a];
  } else if (what !== 'animations') {
    throw new Error(`--strip takes animations or skins, not ${what}`);
  }
  const text = Buffer.from(JSON.stringify(json), 'utf8');
  const jsonChunk = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, ' ')]);
  const header = Buffer.alloc(20), binHeader = Buffer.alloc(8);
  header.write('glTF', 0, 'latin1');
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(20 + jsonChunk.length + 8 + bin.length, 8);
  header.writeUInt32LE(jsonChunk.length, 12);
  header.writeUInt32LE(0x4e4f534a, 16);
  binHeader.writeUInt32LE(bin.length, 0);
  binHeader.writeUInt32LE(0x004e4942, 4);
  fs.writeFileSync(output, Buffer.concat([header, jsonChunk, binHeader, bin]));
  return 0;
}

try {
  const argv = process.argv.slice(2);
  process.exitCode = argv[0] === '--strip' && argv.length === 4 ? strip(argv[1], argv[2], argv[3]) : main();
} catch (err) {
  console.log(`FAIL: ${err.message}`);
  process.exitCode = 1;
}
