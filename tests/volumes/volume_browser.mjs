// Drives the viewer page in headless Chromium for the light-volume tests (the pattern of
// tests/viewer/browser.mjs):
//   node volume_browser.mjs URL STEPS.json OUT_DIR   test mode, the steps below
//   node volume_browser.mjs URL live OUT_DIR         the page as a person sees it: the objects'
//       places 0.5 s apart, then both volume toggles clicked and a screenshot.png
// Each step {name, objects, probes, time, spec} shows or hides the volume's moving objects and
// probe cubes, sets the objects' time, then renders spec with window.patchlight.renderCase and
// writes OUT_DIR/<name>.rgba (RGBA, top row first). OUT_DIR/log.json holds {ready, errors,
// volume: {baked, objects: {name: positions}}}.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const { chromium } = require(process.env.PLAYWRIGHT_CORE || 'playwright-core');
const ARGS = ['--headless', '--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
  '--disable-background-networking', '--disable-component-update', '--disable-sync', '--no-first-run',
  '--disable-quic'];

const [url, stepsFile, outDir] = process.argv.slice(2);
const steps = stepsFile === 'live' ? [] : JSON.parse(fs.readFileSync(stepsFile, 'utf8'));
const profile = fs.mkdtempSync(path.join(os.tmpdir(), 'patchlight-chromium-'));
const log = { errors: [], volume: { objects: {} } };
const context = await chromium.launchPersistentContext(profile, {
  executablePath: process.env.PATCHLIGHT_CHROMIUM || '/usr/bin/chromium',
  headless: true, args: ARGS, viewport: { width: 640, height: 480 }, deviceScaleFactor: 1,
});
try {
  const page = context.pages()[0] || await context.newPage();
  page.on('console', (msg) => { if (msg.type() === 'error') log.errors.push(msg.text()); });
  page.on('pageerror', (err) => log.errors.push(String(err)));
  page.on('response', (res) => { if (res.status() >= 400) log.errors.push(`HTTP ${res.status()}: ${res.url()}`); });
  const live = stepsFile === 'live';
  await page.goto(live ? url : `${url}?test=1`);
  await page.waitForFunction(() => document.body.dataset.ready, null, { timeout: 60000 });
  log.ready = await page.evaluate(() => document.body.dataset.ready);
  if (log.ready === 'true' && live) {
    const objects = () => page.evaluate(() => window.patchlight.volume.objects());
    log.volume.objects.first = await objects();
    await page.waitForTimeout(500);
    log.volume.objects.later = await objects();
    await page.click('#volume-naive');
    await page.click('#volume-probes');
    await page.waitForTimeout(200);
    log.stats = await page.textContent('#stats');
    await page.screenshot({ path: path.join(outDir, 'screenshot.png') });
  } else if (log.ready === 'true') {
    log.volume.baked = await page.evaluate(() => window.patchlight.volume.baked);
    for (const step of steps) {
      const result = await page.evaluate((s) => {
        const v = window.patchlight.volume;
        v.showObjects(Boolean(s.objects));
        v.showProbes(Boolean(s.probes));
        v.setTime(s.time ?? 0);
        if (s.look_at_sphere) {  // aim the camera at the sphere's centre from that offset
          const c = v.objects().sphere.center;
          s.spec.camera = { eye: c.map((x, i) => x + s.look_at_sphere[i]), target: c, fov: 20 };
        }
        return { pixels: window.patchlight.renderCase(s.spec), objects: v.objects() };
      }, step);
      fs.writeFileSync(path.join(outDir, `${step.name}.rgba`), Buffer.from(result.pixels, 'base64'));
      log.volume.objects[step.name] = result.objects;
    }
  }
} finally {
  fs.writeFileSync(path.join(outDir, 'log.json'), JSON.stringify(log, null, 1));
  await context.close();
  fs.rmSync(profile, { recursive: true, force: true });
}
