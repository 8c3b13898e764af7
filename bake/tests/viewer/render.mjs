// Renders one glTF file in headless Chromium with three.js's GLTFLoader and
// prints a JSON line: the fraction of pixels that differ from the clear
// colour and the mean colour of those pixels.
//
// Usage: node render.mjs NODE_MODULES_DIR MODEL_FILE [SCREENSHOT_PNG]
// NODE_MODULES_DIR holds puppeteer-core, three and @sparticuz/chromium (a
// Chromium shipped inside the npm package, so nothing else is downloaded).
// Exit code 3 means the browser or WebGL is unavailable (the caller skips);
// any other failure is the model's or the page's.
import { createRequire } from 'node:module';
import http from 'node:http';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const [modules, model, screenshot] = process.argv.slice(2);
const require = createRequire(path.join(path.resolve(modules), 'noop.js'));
const here = path.dirname(fileURLToPath(import.meta.url));
const CLEAR = [255, 0, 255];

function unavailable(why) {
  console.error('unavailable: ' + why);
  process.exit(3);
}

const types = {
  '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript',
  '.json': 'application/json', '.gltf': 'model/gltf+json', '.glb': 'model/gltf-binary',
  '.bin': 'application/octet-stream', '.png': 'image/png', '.jpg': 'image/jpeg',
};
const roots = {
  '/three/': path.join(path.resolve(modules), 'three'),
  '/model/': path.dirname(path.resolve(model)),
};
const server = http.createServer((req, res) => {
  const url = decodeURIComponent(new URL(req.url, 'http://x').pathname);
  let file = null;
  if (url === '/') file = path.join(here, 'page.html');
  for (const [prefix, root] of Object.entries(roots)) {
    if (url.startsWith(prefix)) {
      const f = path.resolve(root, url.slice(prefix.length));
      if (f.startsWith(root + path.sep)) file = f;
    }
  }
  fs.readFile(file ?? '', (err, data) => {
    if (err) {
      console.error('404 ' + url);
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, { 'Content-Type': types[path.extname(file)] ?? 'application/octet-stream' });
    res.end(data);
  });
});
await new Promise((ok) => server.listen(0, '127.0.0.1', ok));
const port = server.address().port;

let browser;
try {
  const puppeteer = require('puppeteer-core');
  const chromiumModule = require('@sparticuz/chromium');
  const chromium = chromiumModule.default ?? chromiumModule;
  browser = await puppeteer.launch({
    executablePath: await chromium.executablePath(),
    headless: true,
    args: [
      ...chromium.args,
      '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist',
    ],
  });
} catch (e) {
  server.close();
  unavailable('cannot launch Chromium: ' + e.message);
}

let code = 0;
try {
  const page = await browser.newPage();
  page.on('console', (m) => console.error('page: ' + m.text()));
  page.on('pageerror', (e) => console.error('page error: ' + e.message));
  const clear = '#' + CLEAR.map((c) => c.toString(16).padStart(2, '0')).join('');
  await page.goto(
    `http://127.0.0.1:${port}/?model=${encodeURIComponent(path.basename(model))}` +
      `&clear=${encodeURIComponent(clear)}`,
  );
  await page.waitForFunction(() => window.result, { timeout: 45000 });
  const result = await page.evaluate(() => window.result);
  if (result.noWebgl) unavailable(result.error);
  if (result.error) throw new Error('page: ' + result.error);
  const canvas = await page.$('canvas');
  if (screenshot) await canvas.screenshot({ path: screenshot });
  // Read the rendered pixels back through a 2D canvas.
  const stats = await page.evaluate((clearRgb) => {
    const gl = document.querySelector('canvas');
    const c = document.createElement('canvas');
    c.width = gl.width;
    c.height = gl.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(gl, 0, 0);
    const px = ctx.getImageData(0, 0, c.width, c.height).data;
    let covered = 0;
    const sum = [0, 0, 0];
    for (let i = 0; i < px.length; i += 4) {
      const d = Math.abs(px[i] - clearRgb[0]) + Math.abs(px[i + 1] - clearRgb[1]) +
        Math.abs(px[i + 2] - clearRgb[2]);
      if (d > 6) {
        covered++;
        for (let k = 0; k < 3; k++) sum[k] += px[i + k];
      }
    }
    const n = px.length / 4;
    return {
      fraction: covered / n,
      mean: sum.map((s) => (covered ? s / covered / 255 : 0)),
    };
  }, CLEAR);
  console.log(JSON.stringify({ ...result, ...stats, clear: CLEAR.map((c) => c / 255) }));
} catch (e) {
  console.error(String(e && e.stack || e));
  code = 1;
} finally {
  await browser.close();
  server.close();
}
process.exit(code);
