#!/usr/bin/env node
// The web viewer in headless Chromium, on animation files of the skelform-animate contract:
//   node viewer_browser_test.js OUT_DIR [--tube] FILE.glb [[--tube] FILE.glb ...]
// For each file: it loads without console errors, page errors or failed requests; both views
// (skelform left, LBS right) draw triangles and their pixels are not blank and not one colour;
// playing advances the frame; scrubbing changes both views; skelform and LBS differ; the
// skeletal overlay changes the skelform view only; wireframe and mean-curvature colouring
// change both views and the curvature is finite. --tube marks the test fixture (a cylinder of
// radius 0.25 at frame 0), whose mean curvature must be 1/(2r) = 2. Screenshots go to OUT_DIR.
// Exit 0 when every check passes, 1 otherwise.
'use strict';

const fs = require('fs');
const path = require('path');
const viewer = require('../../samples/viewer/headless/session.js');

const args = process.argv.slice(2);
if (args.length < 2) {
  console.error('usage: node viewer_browser_test.js OUT_DIR [--tube] FILE.glb ...');
  process.exit(2);
}
const outDir = args.shift();
const files = [];
for (let i = 0; i < args.length; ++i) {
  if (args[i] === '--tube') files.push({ file: args[++i], tube: true });
  else files.push({ file: args[i], tube: false });
}
fs.mkdirSync(outDir, { recursive: true });

let failures = 0;
function check(condition, what) {
  console.log(`${condition ? 'ok  ' : 'FAIL'}: ${what}`);
  if (!condition) ++failures;
}

const pct = (x) => `${(100 * x).toFixed(2)}%`;
const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

// The image with its right half copied onto its left half, to compare the views pixel by pixel.
function shiftedRight(image, left, right) {
  const out = { width: image.width, height: image.height, pixels: Buffer.alloc(image.pixels.length) };
  for (let y = 0; y < image.height; ++y) {
    image.pixels.copy(out.pixels, 4 * (y * image.width + left.x), 4 * (y * image.width + right.x), 4 * (y * image.width + right.x + right.w));
  }
  return out;
}

async function testFile(session, index, { file, tube }) {
  const page = session.page;
  const name = path.basename(file).replace(/\.glb$/, '');
  const api = (fn, arg) => page.evaluate(fn, arg);
  console.log(`--- ${file}`);
  await session.open(index);

  const animations = await api(() => window.skelformViewer.animations);
  const frameCount = await api(() => window.skelformViewer.frameCount);
  check(animations.length >= 1 && frameCount >= 2, `${animations.length} animation(s), the first with ${frameCount} frames`);

  const views = await api(() => window.skelformViewer.renderedViews());
  check(views.length === 2 && views[0].role === 'skelform' && views[1].role === 'lbs', 'two views: skelform, then LBS');
  for (const v of views) check(v.meshes >= 1 && v.triangles > 0, `${v.role} view draws ${v.meshes} mesh(es), ${v.triangles} triangles`);

  // Playing advances the frame with the clock.
  await api(() => window.skelformViewer.play());
  const before = await api(() => window.skelformViewer.frame);
  await sleep(800);
  const after = await api(() => window.skelformViewer.frame);
  check(await api(() => window.skelformViewer.playing) && after !== before, `playing moves the frame (${before.toFixed(2)} -> ${after.toFixed(2)})`);
  await api(() => window.skelformViewer.pause());

  const mid = Math.floor(frameCount / 2);
  await api(() => window.skelformViewer.setFrame(0));
  const first = viewer.decodePng(await viewer.canvasShot(page, { bare: true }));
  await api((k) => window.skelformViewer.setFrame(k), mid);
  const middle = viewer.decodePng(await viewer.canvasShot(page, { bare: true }));
  await viewer.canvasShot(page, { file: path.join(outDir, `${name}-mid.png`) });
  const [left, right] = viewer.halves(middle);
  for (const [label, r] of [['skelform', left], ['LBS', right]]) {
    const stats = viewer.regionStats(middle, r.x, r.y, r.w, r.h);
    check(stats.colours >= 16 && stats.foregroundFraction > 0.005 && stats.foregroundFraction < 0.95,
          `${label} view at frame ${mid}: ${stats.colours} colours, mesh covers ${pct(stats.foregroundFraction)} (0.5%..95%)`);
    const scrubbed = viewer.regionDifference(first, middle, r.x, r.y, r.w, r.h);
    check(scrubbed > 0.002, `${label} view: scrubbing frame 0 -> ${mid} changes ${pct(scrubbed)} of the pixels (> 0.2%)`);
  }
  // Skeletal overlay: inside the skelform view only.
  const meshesBefore = views[0].meshes;
  await api(() => window.skelformViewer.setSkeletal(true));
  const skeletalViews = await api(() => window.skelformViewer.renderedViews());
  const overlay = viewer.decodePng(await viewer.canvasShot(page, { bare: true }));
  await viewer.canvasShot(page, { file: path.join(outDir, `${name}-skeletal.png`) });
  const overlayLeft = viewer.regionDifference(middle, overlay, left.x, left.y, left.w, left.h);
  const overlayRight = viewer.regionDifference(middle, overlay, right.x, right.y, right.w, right.h);
  check(skeletalViews[0].meshes > meshesBefore && skeletalViews[1].meshes === views[1].meshes,
        `skeletal overlay adds ${skeletalViews[0].meshes - meshesBefore} mesh(es) to the skelform view, none to LBS`);
  check(overlayLeft > 0.001 && overlayRight === 0,
        `skeletal overlay changes the skelform view (${pct(overlayLeft)}) and not the LBS view (${pct(overlayRight)})`);
  await api(() => window.skelformViewer.setSkeletal(false));

  await api(() => window.skelformViewer.setWireframe(true));
  const wire = viewer.decodePng(await viewer.canvasShot(page, { bare: true }));
  await viewer.canvasShot(page, { file: path.join(outDir, `${name}-wireframe.png`) });
  await api(() => window.skelformViewer.setWireframe(false));
  for (const [label, r] of [['skelform', left], ['LBS', right]]) {
    const d = viewer.regionDifference(middle, wire, r.x, r.y, r.w, r.h);
    check(d > 0.002, `wireframe changes the ${label} view (${pct(d)})`);
  }

  await api(() => window.skelformViewer.setCurvature(true));
  const coloured = viewer.decodePng(await viewer.canvasShot(page, { bare: true }));
  await viewer.canvasShot(page, { file: path.join(outDir, `${name}-curvature.png`) });
  for (const [label, r] of [['skelform', left], ['LBS', right]]) {
    const d = viewer.regionDifference(middle, coloured, r.x, r.y, r.w, r.h);
    check(d > 0.002, `curvature colouring changes the ${label} view (${pct(d)})`);
  }
  // Both views now have the same material: what differs between the halves (same camera) is
  // the deformation.
  const methodDifference = viewer.regionDifference(coloured, shiftedRight(coloured, left, right), left.x, left.y, left.w, left.h);
  check(methodDifference > 0.0005, `skelform and LBS (coloured by curvature) differ at frame ${mid} on ${pct(methodDifference)} of the pixels (> 0.05%)`);
  const curvature = await api(() => window.skelformViewer.curvature());
  check(curvature.length >= 2 && curvature.every((c) => c.h.length > 0 && c.h.every(Number.isFinite)),
        `mean curvature finite on every vertex of ${curvature.length} surfaces`);
  const scale = await api(() => window.skelformViewer.curvatureScale);
  check(Number.isFinite(scale) && scale > 0, `curvature scale (95th percentile of |H| at rest) ${scale.toPrecision(4)} > 0`);
  if (tube) {
    await api(() => window.skelformViewer.setFrame(0));
    const rest = await api(() => window.skelformViewer.curvature());
    for (const c of rest) {
      const sorted = c.h.slice().sort((a, b) => a - b);
      const median = sorted[sorted.length >> 1];
      check(Math.abs(median - 2) < 0.02 * 2, `${c.role}: median mean curvature of the r = 0.25 cylinder at rest ${median.toFixed(4)} (1/(2r) = 2 within 2%)`);
    }
  }
  await api(() => window.skelformViewer.setCurvature(false));
}

(async () => {
  const t0 = Date.now();
  const session = await viewer.openSession(files.map((f) => f.file));
  try {
    for (let i = 0; i < files.length; ++i) await testFile(session, i, files[i]);
  } catch (err) {
    check(false, `no exception (${err.stack || err})`);
  } finally {
    await session.close();
  }
  check(session.problems.length === 0, `no console errors, page errors or failed requests${session.problems.length ? `:\n  ${session.problems.join('\n  ')}` : ''}`);
  console.log(`${failures} failure(s); ${((Date.now() - t0) / 1000).toFixed(1)} s; screenshots in ${outDir}`);
  process.exitCode = failures ? 1 : 0;
})();
