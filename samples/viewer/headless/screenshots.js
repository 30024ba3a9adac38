#!/usr/bin/env node
// The README's pictures, taken from the web viewer in headless Chromium (./run.sh screenshots
// makes the animation files and calls this):
//   node screenshots.js OUT_DIR --cesium CesiumMan.anim.glb --fox Fox.anim.glb [--closeup FILE.anim.glb]
//                       [--gallop QUADRUPED.anim.glb]
// writes OUT_DIR/cesiumman.png (mid-animation, skelform beside LBS), OUT_DIR/fox.png (the
// walk, mid-animation), OUT_DIR/bent-joint-curvature.png: a close-up, coloured by mean
// curvature, of the joint where skelform and LBS differ most over the whole file (default:
// the --cesium file), and with --gallop OUT_DIR/gallop.png: the quadruped's 'Gallop'
// animation half-way, from its side.
'use strict';

const fs = require('fs');
const path = require('path');
const { openSession, settle } = require('./session.js');

function parse(argv) {
  const options = { out: null, cesium: null, fox: null, closeup: null, gallop: null };
  for (let i = 0; i < argv.length; ++i) {
    const flag = argv[i].replace(/^--/, '');
    if (argv[i].startsWith('--') && flag in options && i + 1 < argv.length) options[flag] = argv[++i];
    else if (!argv[i].startsWith('--') && !options.out) options.out = argv[i];
    else throw new Error(`unexpected argument ${argv[i]}`);
  }
  if (!options.out || !options.cesium || !options.fox) {
    throw new Error('usage: node screenshots.js OUT_DIR --cesium FILE --fox FILE [--closeup FILE]');
  }
  options.closeup = options.closeup || options.cesium;
  return options;
}

async function shoot(page, file) {
  await settle(page);
  await page.locator('#views').screenshot({ path: file });
  console.log(`wrote ${file}`);
}

async function main() {
  const options = parse(process.argv.slice(2));
  fs.mkdirSync(options.out, { recursive: true });
  const files = [options.cesium, options.fox, options.closeup];
  if (options.gallop) files.push(options.gallop);
  const session = await openSession(files, { width: 1200, height: 560 });
  const { page } = session;
  try {
    // CesiumMan: its walk, half-way.
    await session.open(0);
    await page.evaluate(() => {
      const v = window.skelformViewer;
      v.setFrame(Math.floor(v.frameCount / 2));
      v.setView({ ...v.home, azimuth: 20, elevation: 5, zoom: 1.25 });
    });
    await shoot(page, path.join(options.out, 'cesiumman.png'));

    // Fox: the walk when there is one, half-way.
    await session.open(1);
    await page.evaluate(() => {
      const v = window.skelformViewer;
      const walk = v.animations.findIndex((a) => /walk/i.test(a.name));
      v.setAnimation(walk >= 0 ? walk : 0);
      v.setFrame(Math.floor(v.frameCount / 2));
      v.setView({ ...v.home, azimuth: 60, elevation: 10, zoom: 1.2 });  // the fox walks along z: see it from its side
    });
    await shoot(page, path.join(options.out, 'fox.png'));

    // Close-up: the frame and point where skelform and LBS differ most (a bent joint).
    await session.open(2);
    const joint = await page.evaluate(() => {
      const v = window.skelformViewer;
      const d = v.largestDifference();
      v.setAnimation(d.animation);
      v.setFrame(d.frame);
      v.setCurvature(true);
      v.setView({ target: d.point, distance: 0.8 * v.radius, azimuth: 90, elevation: 10 });  // from the side
      return d;
    });
    console.log(`close-up: animation ${joint.animation}, frame ${joint.frame}, point ${joint.point.map((x) => x.toFixed(3)).join(' ')}, ` +
                `skelform-LBS distance ${joint.distance.toFixed(4)}`);
    await shoot(page, path.join(options.out, 'bent-joint-curvature.png'));

    if (options.gallop) {
      // A quadruped mid-gallop, from its side.
      await session.open(3);
      await page.evaluate(() => {
        const v = window.skelformViewer;
        const gallop = v.animations.findIndex((a) => /(^|\|)gallop$/i.test(a.name));
        v.setAnimation(gallop >= 0 ? gallop : 0);
        v.setFrame(Math.floor(v.frameCount / 2));
        v.setView({ ...v.home, azimuth: 90, elevation: 5, zoom: 2.0 });
      });
      await shoot(page, path.join(options.out, 'gallop.png'));
    }
  } finally {
    await session.close();
  }
  if (session.problems.length) throw new Error(`the viewer reported problems:\n  ${session.problems.join('\n  ')}`);
}

main().catch((err) => {
  console.error(`screenshots.js: ${err.message}`);
  process.exitCode = 1;
});
