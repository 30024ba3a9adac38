// Drives the web viewer in headless Chromium (Debian's /usr/bin/chromium through
// playwright-core, pinned in ../package-lock.json; WebGL on SwiftShader, no GPU needed).
// Shared by the browser test (tests/samples/viewer_browser_test.js) and the README
// screenshots (screenshots.js), so the pictures come from the code path the test checks.
'use strict';

const { spawn } = require('child_process');
const fs = require('fs');
const path = require('path');
const zlib = require('zlib');
const { chromium } = require('playwright-core');

const VIEWER_DIR = path.resolve(__dirname, '..');

function chromiumPath() {
  const candidates = [process.env.CHROMIUM, '/usr/bin/chromium', '/usr/bin/chromium-browser'].filter(Boolean);
  return candidates.find((p) => fs.existsSync(p)) || null;
}

// Starts serve.js on a free port with the given files; resolves to { process, urls } once it
// has printed one URL per file.
function startServer(files) {
  return new Promise((resolve, reject) => {
    const child = spawn(process.execPath, [path.join(VIEWER_DIR, 'serve.js'), ...files, '--port', '0'],
                        { stdio: ['ignore', 'pipe', 'pipe'] });
    let out = '', err = '';
    const urls = [];
    const timer = setTimeout(() => { child.kill(); reject(new Error(`serve.js did not start: ${err}`)); }, 15000);
    child.stdout.on('data', (chunk) => {
      out += chunk;
      const lines = out.split('\n');
      out = lines.pop();
      for (const line of lines) {
        const m = /^skelform viewer: (http:\/\/\S+)/.exec(line);
        if (m) urls.push(m[1]);
        if (line.startsWith('press Ctrl+C')) {
          clearTimeout(timer);
          resolve({ process: child, urls });
        }
      }
    });
    child.stderr.on('data', (chunk) => { err += chunk; });
    child.on('exit', (code) => { clearTimeout(timer); reject(new Error(`serve.js exited with ${code}: ${err}`)); });
  });
}

// A browser, a page and the server for `files`; problems (console errors, page errors, failed
// requests) are collected in session.problems.
async function openSession(files, { width = 1280, height = 640 } = {}) {
  const executablePath = chromiumPath();
  if (!executablePath) throw new Error('chromium not found (apt-get install chromium, or set CHROMIUM)');
  const server = await startServer(files);
  let browser;
  try {
    browser = await chromium.launch({
      executablePath,
      headless: true,
      // WebGL without a GPU: ANGLE on SwiftShader. --no-sandbox: CI runs as root.
      args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
             '--disable-dev-shm-usage'],
    });
  } catch (err) {
    server.process.kill();
    throw err;
  }
  const page = await browser.newPage({ viewport: { width, height }, deviceScaleFactor: 1 });
  const problems = [];
  page.on('console', (message) => { if (message.type() === 'error') problems.push(`console.error: ${message.text()}`); });
  page.on('pageerror', (error) => problems.push(`page error: ${error.message}`));
  // net::ERR_ABORTED is left out: Chromium sometimes reports it for a fetch whose body the page
  // has already read completely (the viewer then loads normally); a real failure to load shows
  // as an HTTP status, another network error or the viewer's own console.error.
  page.on('requestfailed', (request) => {
    if (request.failure().errorText !== 'net::ERR_ABORTED') problems.push(`request failed: ${request.url()} (${request.failure().errorText})`);
  });
  page.on('response', (response) => { if (response.status() >= 400) problems.push(`HTTP ${response.status()}: ${response.url()}`); });
  return {
    page,
    problems,
    urls: server.urls,
    // Opens file i and waits until the viewer has loaded and rendered it.
    async open(i) {
      await page.goto(server.urls[i]);
      await page.waitForFunction(() => window.skelformViewer !== undefined);
      await page.evaluate(() => window.skelformViewer.ready);
    },
    async close() {
      await browser.close();
      server.process.kill();
    },
  };
}

// Waits until the page has painted the viewer's latest state (two animation frames).
function settle(page) {
  return page.evaluate(() => new Promise((resolve) => requestAnimationFrame(() => requestAnimationFrame(resolve))));
}

// Screenshot of the viewer's canvas alone; bare hides the DOM overlays (labels, legend) so the
// pixels are the WebGL views only.
async function canvasShot(page, { bare = false, file = null } = {}) {
  await settle(page);
  if (bare) {
    await page.addStyleTag({ content: 'body.headless-bare .label, body.headless-bare #legend, body.headless-bare #message, ' +
                                      'body.headless-bare #divider { visibility: hidden !important; }' });
    await page.evaluate(() => document.body.classList.add('headless-bare'));
  }
  const png = await page.locator('#canvas').screenshot({ path: file || undefined });
  if (bare) await page.evaluate(() => document.body.classList.remove('headless-bare'));
  return png;
}

// --- PNG decoding (Chromium's screenshots: 8-bit RGB or RGBA, not interlaced) ---

function decodePng(buffer) {
  if (buffer.readUInt32BE(0) !== 0x89504e47) throw new Error('not a PNG');
  let offset = 8, width = 0, height = 0, colourType = 0;
  const idat = [];
  while (offset < buffer.length) {
    const length = buffer.readUInt32BE(offset);
    const type = buffer.toString('ascii', offset + 4, offset + 8);
    const data = buffer.subarray(offset + 8, offset + 8 + length);
    if (type === 'IHDR') {
      width = data.readUInt32BE(0);
      height = data.readUInt32BE(4);
      if (data[8] !== 8 || data[12] !== 0) throw new Error('only 8-bit non-interlaced PNGs');
      colourType = data[9];
    } else if (type === 'IDAT') {
      idat.push(data);
    }
    offset += 12 + length;
  }
  const channels = { 2: 3, 6: 4 }[colourType];
  if (!channels) throw new Error(`PNG colour type ${colourType} not handled`);
  const raw = zlib.inflateSync(Buffer.concat(idat));
  const stride = width * channels;
  const pixels = Buffer.alloc(width * height * 4);
  const previous = Buffer.alloc(stride), current = Buffer.alloc(stride);
  for (let y = 0; y < height; ++y) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    for (let x = 0; x < stride; ++x) {
      const a = x >= channels ? current[x - channels] : 0, b = previous[x], c = x >= channels ? previous[x - channels] : 0;
      let predictor = 0;
      if (filter === 1) predictor = a;
      else if (filter === 2) predictor = b;
      else if (filter === 3) predictor = (a + b) >> 1;
      else if (filter === 4) {
        const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
        predictor = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
      }
      current[x] = (line[x] + predictor) & 0xff;
    }
    for (let x = 0; x < width; ++x) {
      for (let ch = 0; ch < 3; ++ch) pixels[4 * (y * width + x) + ch] = current[x * channels + ch];
      pixels[4 * (y * width + x) + 3] = channels === 4 ? current[x * channels + 3] : 255;
    }
    current.copy(previous);
  }
  return { width, height, pixels };
}

// Statistics of a rectangle of a decoded image: how many distinct colours, the most frequent
// one (the background) and the fraction of pixels that differ from it by more than 12 levels.
function regionStats(image, x0, y0, w, h) {
  const counts = new Map();
  for (let y = y0; y < y0 + h; ++y) {
    for (let x = x0; x < x0 + w; ++x) {
      const i = 4 * (y * image.width + x);
      const key = (image.pixels[i] << 16) | (image.pixels[i + 1] << 8) | image.pixels[i + 2];
      counts.set(key, (counts.get(key) || 0) + 1);
    }
  }
  let background = 0, most = -1;
  for (const [key, n] of counts) if (n > most) { most = n; background = key; }
  const bg = [(background >> 16) & 255, (background >> 8) & 255, background & 255];
  let foreground = 0;
  for (let y = y0; y < y0 + h; ++y) {
    for (let x = x0; x < x0 + w; ++x) {
      const i = 4 * (y * image.width + x);
      const d = Math.max(Math.abs(image.pixels[i] - bg[0]), Math.abs(image.pixels[i + 1] - bg[1]), Math.abs(image.pixels[i + 2] - bg[2]));
      if (d > 12) ++foreground;
    }
  }
  return { colours: counts.size, background: bg, foregroundFraction: foreground / (w * h) };
}

// Fraction of the rectangle's pixels that differ by more than 12 levels between two images.
function regionDifference(a, b, x0, y0, w, h) {
  let changed = 0;
  for (let y = y0; y < y0 + h; ++y) {
    for (let x = x0; x < x0 + w; ++x) {
      const i = 4 * (y * a.width + x);
      const d = Math.max(Math.abs(a.pixels[i] - b.pixels[i]), Math.abs(a.pixels[i + 1] - b.pixels[i + 1]),
                         Math.abs(a.pixels[i + 2] - b.pixels[i + 2]));
      if (d > 12) ++changed;
    }
  }
  return changed / (w * h);
}

// The two views' rectangles (left: skelform, right: LBS) in image pixels.
function halves(image) {
  const half = Math.floor(image.width / 2);
  return [{ x: 0, y: 0, w: half, h: image.height }, { x: image.width - half, y: 0, w: half, h: image.height }];
}

module.exports = { openSession, settle, canvasShot, decodePng, regionStats, regionDifference, halves, chromiumPath, VIEWER_DIR };
