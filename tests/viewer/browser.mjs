// Drives the viewer page in Debian's headless Chromium (playwright-core), for the pytest suite.
//
//   node browser.mjs cases URL CASES.json OUT_DIR   render each case with window.patchlight.renderCase,
//                                                 write OUT_DIR/<name>.rgba (raw RGBA, top row first)
//   node browser.mjs smoke URL OUT_DIR             load the page as a person would, pick every model
//                                                 and option from the controls, save screenshot.png
// Both write OUT_DIR/log.json: {errors: [...console errors and page errors...], ...}.
// One browser launch per run, a fresh profile each time. $PATCHLIGHT_CHROMIUM overrides /usr/bin/chromium.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const { chromium } = require(process.env.PLAYWRIGHT_CORE || 'playwright-core');

const ARGS = ['--headless', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run',
  '--disable-quic'];

async function withPage(url, outDir, body) {
  const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'patchlight-chromium-'));
  const log = { errors: [] };
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: process.env.PATCHLIGHT_CHROMIUM || '/usr/bin/chromium',
    headless: true, args: ARGS, viewport: { width: 640, height: 480 }, deviceScaleFactor: 1,
  });
  try {
    const page = context.pages()[0] || await context.newPage();
    page.on('console', (msg) => { if (msg.type() === 'error') log.errors.push(msg.text()); });
    page.on('pageerror', (err) => log.errors.push(String(err)));
    page.on('requestfailed', (req) => log.errors.push(`request failed: ${req.url()}`));
    page.on('response', (res) => { if (res.status() >= 400) log.errors.push(`HTTP ${res.status()}: ${res.url()}`); });
    await page.goto(url);
    await page.waitForFunction(() => document.body.dataset.ready, null, { timeout: 60000 });
    log.ready = await page.evaluate(() => document.body.dataset.ready);
    if (log.ready === 'true') await body(page, log);
  } finally {
    fs.writeFileSync(path.join(outDir, 'log.json'), JSON.stringify(log, null, 1));
    await context.close();
    fs.rmSync(profile, { recursive: true, force: true });
  }
}

async function cases(url, casesFile, outDir) {
  const specs = JSON.parse(fs.readFileSync(casesFile, 'utf8'));
  await withPage(`${url}?test=1`, outDir, async (page, log) => {
    log.seconds = {};
    for (const spec of specs) {
      const start = Date.now();
      const b64 = await page.evaluate((s) => window.patchlight.renderCase(s), spec);
      log.seconds[spec.name] = (Date.now() - start) / 1000;
      fs.writeFileSync(path.join(outDir, `${spec.name}.rgba`), Buffer.from(b64, 'base64'));
    }
  });
}

async function smoke(url, outDir) {
  await withPage(url, outDir, async (page, log) => {
    const frame = () => page.waitForFunction(() => /ms\/frame/.test(document.getElementById('stats').textContent));
    await frame();
    log.models = await page.evaluate(() => window.patchlight.models);
    log.frames = {};
    for (const model of log.models) {
      await page.selectOption('#model', model);
      await page.waitForFunction((m) => document.getElementById('stats').textContent.startsWith(m), model);
      log.frames[model] = await page.textContent('#stats');
    }
    await page.selectOption('#model', 'phong');
    for (const toggle of ['#normal-map', '#per-vertex', '#lightmap-specular']) await page.click(toggle);
    await page.selectOption('#light', '1');  // the showcase's point light
    await page.fill('#light-intensity', '20');
    await page.selectOption('#light-falloff', 'range');
    for (const picture of await page.$$eval('#surface option', (os) => os.map((o) => o.value))) {
      await page.selectOption('#surface', picture);
    }
    await page.selectOption('#surface', '');
    await page.mouse.move(320, 240);
    await page.mouse.down();
    await page.mouse.move(360, 250, { steps: 4 });
    await page.mouse.up();
    await page.waitForTimeout(200);
    log.stats = await page.textContent('#stats');
    await page.screenshot({ path: path.join(outDir, 'screenshot.png') });
  });
}

const [command, ...rest] = process.argv.slice(2);
if (command === 'cases') await cases(...rest);
else if (command === 'smoke') await smoke(...rest);
else { console.error('usage: node browser.mjs cases URL CASES.json OUT_DIR | smoke URL OUT_DIR'); process.exit(2); }
