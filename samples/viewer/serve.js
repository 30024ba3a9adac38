#!/usr/bin/env node
// Serves skelform's web viewer on 127.0.0.1 with no dependency but Node itself:
//   node samples/viewer/serve.js [FILE.glb ...] [--port N]
//
// Serves the viewer's own files (index.html, *.js, *.css beside this script), three.js from
// its node_modules (npm ci in samples/viewer/), and each FILE given under /files/NAME. Prints
// one line per file with the URL that opens it: "skelform viewer: http://127.0.0.1:P/?file=...".
// --port 0 picks a free port (the browser test does). Nothing else on the disk is reachable.
// Stops on SIGINT/SIGTERM.
'use strict';

const fs = require('fs');
const http = require('http');
const path = require('path');

const VIEWER_DIR = __dirname;
const THREE_DIR = path.join(VIEWER_DIR, 'node_modules', 'three');
const CONTENT_TYPES = {
  '.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8', '.css': 'text/css; charset=utf-8',
  '.json': 'application/json', '.glb': 'model/gltf-binary', '.gltf': 'model/gltf+json', '.bin': 'application/octet-stream',
  '.png': 'image/png', '.jpg': 'image/jpeg', '.jpeg': 'image/jpeg', '.ktx2': 'image/ktx2', '.wasm': 'application/wasm',
};

function usage(message) {
  if (message) console.error(`serve.js: ${message}`);
  console.error('usage: node serve.js [FILE.glb ...] [--port N]   (N = 0: any free port; default 8765)');
  process.exit(2);
}

function parseArguments(argv) {
  const files = [];
  let port = 8765;
  for (let i = 0; i < argv.length; ++i) {
    if (argv[i] === '--port') {
      if (i + 1 >= argv.length || !/^\d+$/.test(argv[i + 1]) || Number(argv[i + 1]) > 65535) usage('--port needs a number 0..65535');
      port = Number(argv[++i]);
    } else if (argv[i] === '-h' || argv[i] === '--help') {
      usage();
    } else if (argv[i].startsWith('-')) {
      usage(`unknown option ${argv[i]}`);
    } else {
      const file = path.resolve(argv[i]);
      if (!fs.existsSync(file) || !fs.statSync(file).isFile()) usage(`${argv[i]}: no such file`);
      files.push(file);
    }
  }
  return { files, port };
}

// URL path -> file on disk, or null. Served files are named by their base name; when two
// share one, the later ones get their index as a prefix.
function makeResolver(files) {
  const served = new Map();
  files.forEach((file, i) => {
    let name = path.basename(file);
    if (served.has(name)) name = `${i}-${name}`;
    served.set(name, file);
  });
  const inside = (dir, relative) => {
    const resolved = path.resolve(dir, relative);
    return resolved.startsWith(dir + path.sep) ? resolved : null;
  };
  const resolve = (urlPath) => {
    if (urlPath === '/' || urlPath === '/index.html') return path.join(VIEWER_DIR, 'index.html');
    if (urlPath.startsWith('/files/')) return served.get(urlPath.slice('/files/'.length)) || null;
    if (urlPath.startsWith('/node_modules/three/')) return inside(THREE_DIR, urlPath.slice('/node_modules/three/'.length));
    // The viewer's own top-level sources only (not the servers, not the test drivers' folders).
    const name = urlPath.slice(1);
    if (/^[A-Za-z0-9_-]+\.(js|css|html)$/.test(name) && name !== 'serve.js') return path.join(VIEWER_DIR, name);
    return null;
  };
  return { served, resolve };
}

function main() {
  const { files, port } = parseArguments(process.argv.slice(2));
  if (!fs.existsSync(path.join(THREE_DIR, 'build', 'three.module.js'))) {
    console.error(`serve.js: three.js is not installed: run "npm ci" in ${VIEWER_DIR} (or use serve.sh)`);
    process.exit(1);
  }
  const { served, resolve } = makeResolver(files);
  const server = http.createServer((request, response) => {
    let urlPath;
    try {
      urlPath = decodeURIComponent(new URL(request.url, 'http://localhost').pathname);
    } catch (err) {
      response.writeHead(400).end('bad request');
      return;
    }
    if (request.method !== 'GET' && request.method !== 'HEAD') {
      response.writeHead(405, { Allow: 'GET, HEAD' }).end();
      return;
    }
    const file = resolve(urlPath);
    if (urlPath === '/favicon.ico') {
      response.writeHead(204).end();
      return;
    }
    fs.stat(file || '', (err, stat) => {
      if (!file || err || !stat.isFile()) {
        response.writeHead(404, { 'Content-Type': 'text/plain' }).end(`not found: ${urlPath}`);
        return;
      }
      response.writeHead(200, {
        'Content-Type': CONTENT_TYPES[path.extname(file).toLowerCase()] || 'application/octet-stream',
        'Content-Length': stat.size,
        'Cache-Control': 'no-store',
      });
      if (request.method === 'HEAD') response.end();
      else fs.createReadStream(file).pipe(response);
    });
  });
  server.on('error', (err) => {
    console.error(`serve.js: ${err.code === 'EADDRINUSE' ? `port ${port} is in use (try --port 0)` : err.message}`);
    process.exit(1);
  });
  server.listen(port, '127.0.0.1', () => {
    const base = `http://127.0.0.1:${server.address().port}/`;
    if (served.size === 0) console.log(`skelform viewer: ${base}  (no file given: open one from the page)`);
    for (const name of served.keys()) console.log(`skelform viewer: ${base}?file=files/${encodeURIComponent(name)}`);
    console.log('press Ctrl+C to stop');
  });
  const stop = () => server.close(() => process.exit(0));
  process.on('SIGINT', stop);
  process.on('SIGTERM', stop);
}

main();
