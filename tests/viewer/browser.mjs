// Drives the viewer page in Debian's headless Chromium (playwright-core): the one driver of
// every browser test (tests/viewer/browser_support.py runs it).
//
//   node browser.mjs cases URL CASES.json OUT_DIR   render each case with window.patchlight.renderCase,
//                                                 write OUT_DIR/<name>.rgba (raw RGBA, top row first).
//       A case's `volume` {objects, probes, time, look_at_sphere} first shows or hides the light
//       volume's moving objects and probe cubes and sets their time (look_at_sphere: aim the
//       camera at the sphere's centre from that offset); the objects' places go to the log, and
//       so do the maps of scene.glb's three.js materials (log.engine).
//   node browser.mjs smoke URL OUT_DIR             load the page as a person would, pick every model
//                                                 and option from the controls, save screenshot.png
//   node browser.mjs controls URL SCRIPT.json OUT_DIR  with the page's own controls, run the script's
//                                                 `actions` ({select|fill|click: CSS selector, value}),
//                                                 log the light panel and the lights they made, then
//                                                 render its `case` with those lights to OUT_DIR/<name>.rgba
//   node browser.mjs volume-live URL OUT_DIR       the live page with a light volume: the objects'
//                                                 places 0.5 s apart, both volume toggles clicked,
//                                                 screenshot.png
//   node browser.mjs inspect URL SCRIPT.json OUT_DIR  the inspection tools with the page's own
//                                                 controls and mouse: every step of the script's
//                                                 `steps` ({select|click|slide: selector, value},
//                                                 {sky: false} (hide it), {camera: {eye, target, fov}},
//                                                 {dblclick: [x, y]}, {press: key}, {probe: [x, y] canvas
//                                                 pixels clicked}, {shot: name}) logs the page's state;
//                                                 `shot` writes OUT_DIR/<name>.rgba (the canvas) and
//                                                 <name>.png (a screenshot of the page)
//       (a URL may carry the page's own query, e.g. ?max-texture=N)
// Each writes OUT_DIR/log.json: {ready, stats (the status line), errors: [...console errors and
// page errors...], ...}; cases adds atlas_grid, the page's layout of the lightmap's atlases.
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
    page.on('requestfailed', (req) => log.errors.push(`request failed: ${req.url()} (${req.failure()?.errorText})`));
    page.on('response', (res) => { if (res.status() >= 400) log.errors.push(`HTTP ${res.status()}: ${res.url()}`); });
    await page.goto(url);
    await page.waitForFunction(() => document.body.dataset.ready, null, { timeout: 60000 });
    log.ready = await page.evaluate(() => document.body.dataset.ready);
    log.stats = await page.textContent('#stats');  // the page's one line of what went wrong, if it did
    if (log.ready === 'true') await body(page, log);
  } finally {
    fs.writeFileSync(path.join(outDir, 'log.json'), JSON.stringify(log, null, 1));
    await context.close();
    fs.rmSync(profile, { recursive: true, force: true });
  }
}

async function cases(url, casesFile, outDir) {
  const specs = JSON.parse(fs.readFileSync(casesFile, 'utf8'));
  await withPage(`${url}${url.includes('?') ? '&' : '?'}test=1`, outDir, async (page, log) => {
    log.seconds = {};
    log.atlas_grid = await page.evaluate(() => {  // how the page laid the lightmap's atlases out
      const { atlases, cols, rows, maxSize } = window.patchlight.viewer.atlasGrid;
      return { atlases, cols, rows, max_size: maxSize };
    });
    log.volume = { baked: await page.evaluate(() => window.patchlight.volume.baked), objects: {} };
    log.engine = await page.evaluate(() => {  // scene.glb's three.js materials: which maps they sample
      const materials = {};
      window.patchlight.viewer.engineScene?.traverse((o) => {
        for (const m of o.isMesh ? [o.material].flat() : []) {
          materials[m.name] = { lightMap: Boolean(m.lightMap), aoMap: Boolean(m.aoMap), normalMap: Boolean(m.normalMap) };
        }
      });
      return materials;
    });
    for (const spec of specs) {
      const start = Date.now();
      const result = await page.evaluate((s) => {
        const v = window.patchlight.volume;
        const shown = s.volume || {};
        v.showObjects(Boolean(shown.objects));
        v.showProbes(Boolean(shown.probes));
        v.setTime(shown.time ?? 0);
        if (shown.look_at_sphere) {
          const c = v.objects().sphere.center;
          s.camera = { eye: c.map((x, i) => x + shown.look_at_sphere[i]), target: c, fov: 20 };
        }
        return { pixels: window.patchlight.renderCase(s), objects: v.objects() };
      }, spec);
      log.seconds[spec.name] = (Date.now() - start) / 1000;
      if (result.objects) log.volume.objects[spec.name] = result.objects;
      fs.writeFileSync(path.join(outDir, `${spec.name}.rgba`), Buffer.from(result.pixels, 'base64'));
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
    for (const [x, y] of [[140, 300], [150, 310]]) await page.mouse.move(x, y);  // over the surface
    await page.waitForFunction(() => document.getElementById('hover').textContent !== '');
    log.hover = await page.textContent('#hover');
    await page.selectOption('#model', 'phong');
    for (const toggle of ['#normal-map', '#per-vertex', '#lightmap-specular']) await page.click(toggle);
    await page.selectOption('#light', '1');  // the showcase's point light
    await page.fill('#light-intensity', '20');
    await page.selectOption('#light-falloff', 'range');
    log.surfaces = await page.$$eval('#surface option', (os) => os.map((o) => o.value));
    await page.click('#checker');
    await page.click('#outlines');
    for (const surface of log.surfaces) await page.selectOption('#surface', surface);
    await page.selectOption('#surface', 'adaptive');
    log.legend = await page.$$eval('#legend div', (ds) => ds.map((d) => d.textContent.trim()));
    await page.selectOption('#surface', '');
    await page.$eval('#pass', (el) => { el.value = '1'; el.dispatchEvent(new Event('input')); });
    await page.selectOption('#split', 'lambert');
    await page.click('#frame-all');
    await page.click('#exposure-auto');
    log.lightControls = await lightControls(page);
    await page.selectOption('#light', '0');  // the showcase's sun: aim it
    log.lightControls.sunRows = await rowsShown(page);
    await page.fill('#light-azimuth', '90');
    await page.fill('#light-elevation', '-30');
    await page.selectOption('#light', '2');  // the showcase's spot: aim it, widen its cone
    log.lightControls.spotRows = await rowsShown(page);
    await page.fill('#light-azimuth', '180');
    await page.fill('#light-elevation', '-60');
    await page.fill('#light-outer', '40');
    await page.fill('#light-inner', '10');
    await page.selectOption('#light-kind', 'spot');
    await page.click('#light-add');
    log.lightControls.added = await page.evaluate(() => window.patchlight.viewer.state.lights.length);
    log.lightControls.selected = await page.inputValue('#light');
    await page.click('#light-remove');
    log.lightControls.after = await lightState(page);
    await page.mouse.move(320, 240);
    await page.mouse.down();
    await page.mouse.move(360, 250, { steps: 4 });
    await page.mouse.up();
    await page.waitForTimeout(200);
    log.stats = await page.textContent('#stats');
    await page.screenshot({ path: path.join(outDir, 'screenshot.png') });
  });
}

async function lightControls(page) {
  return page.evaluate(() => {
    const values = (id) => [...document.querySelectorAll(`#${id} option`)].map((o) => o.value);
    const panel = document.getElementById('light-panel');
    return { kinds: values('light-kind'), falloffs: values('light-falloff'), lights: values('light'),
      panelShown: !panel.hidden && panel.getClientRects().length > 0,
      fieldsShown: document.getElementById('light-fields').getClientRects().length > 0 };
  });
}

async function rowsShown(page) {
  return page.evaluate(() => Object.fromEntries(['position', 'aim', 'range', 'falloff', 'cone']
    .map((row) => [row, document.getElementById(`light-${row}-row`).getClientRects().length > 0])));
}

// The lights as the page holds them and as its shader uniforms received them.
async function lightState(page) {
  return page.evaluate(() => {
    const v = window.patchlight.viewer;
    const u = v.uniforms;
    const n = u.light_count.value;
    return { state: v.state.lights, uniforms: {
      count: n, direction: u.light_direction.value.slice(0, n).map((d) => d.toArray()),
      cos_inner: u.light_cos_inner.value.slice(0, n), cos_outer: u.light_cos_outer.value.slice(0, n) } };
  });
}

async function controls(url, scriptFile, outDir) {
  const script = JSON.parse(fs.readFileSync(scriptFile, 'utf8'));
  await withPage(`${url}?test=1`, outDir, async (page, log) => {
    log.before = await lightControls(page);
    for (const action of script.actions) {
      if (action.select) await page.selectOption(action.select, action.value);
      else if (action.fill) await page.fill(action.fill, String(action.value));
      else if (action.click) await page.click(action.click);
    }
    log.after = await lightControls(page);
    log.lights = await lightState(page);
    const spec = { ...script.case, keep_lights: true };
    const pixels = await page.evaluate((s) => window.patchlight.renderCase(s), spec);
    fs.writeFileSync(path.join(outDir, `${spec.name}.rgba`), Buffer.from(pixels, 'base64'));
  });
}

async function volumeLive(url, outDir) {
  await withPage(url, outDir, async (page, log) => {
    const objects = () => page.evaluate(() => window.patchlight.volume.objects());
    log.volume = { objects: { first: await objects() } };
    await page.waitForTimeout(500);
    log.volume.objects.later = await objects();
    await page.click('#volume-naive');
    await page.click('#volume-probes');
    await page.waitForTimeout(200);
    log.stats = await page.textContent('#stats');
    await page.screenshot({ path: path.join(outDir, 'screenshot.png') });
  });
}

async function inspect(url, scriptFile, outDir) {
  const script = JSON.parse(fs.readFileSync(scriptFile, 'utf8'));
  await withPage(url, outDir, async (page, log) => {
    log.steps = [];
    const state = () => page.evaluate(() => {
      const v = window.patchlight.viewer;
      return { model: v.state.model, overlay: v.state.overlay, exposure: v.state.exposure, pass: v.state.pass,
        exposures: v.state.exposures, camera: v.cameraJson(), canvas: [v.renderer.domElement.width, v.renderer.domElement.height] };
    });
    const settle = () => page.waitForTimeout(300);  // the redraw runs on the next animation frame
    for (const step of script.steps) {
      const entry = { step };
      if (step.select) await page.selectOption(step.select, step.value);
      else if (step.click) await page.click(step.click);
      else if (step.slide) {
        await page.$eval(step.slide, (el, value) => { el.value = value; el.dispatchEvent(new Event('input')); }, String(step.value));
      } else if (step.dblclick) await page.mouse.dblclick(...step.dblclick);
      else if (step.press) await page.keyboard.press(step.press);
      else if (step.sky === false) {
        await page.evaluate(() => { window.patchlight.viewer.sky.visible = false; });
      } else if (step.camera) {
        await page.evaluate((c) => window.patchlight.look(c), step.camera);
      } else if (step.probe) {
        await page.mouse.click(step.probe[0], step.probe[1]);
        entry.probe = await page.evaluate(async () => {
          const v = window.patchlight.viewer;
          const patch = v.probed?.texel && v.probed.status !== 'uncovered' ? await v.patch.loading : null;
          return { probe: v.probed, patch, text: document.getElementById('probe').textContent,
            pixels: window.patchlight.patchPixels() };
        });
      }
      await settle();
      entry.state = await state();
      entry.legend = await page.textContent('#legend');
      if (step.shot) {
        const pixels = await page.evaluate(() => {
          const bytes = window.patchlight.viewer.pixels();
          let binary = '';
          for (let i = 0; i < bytes.length; i += 0x8000) binary += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
          return btoa(binary);
        });
        fs.writeFileSync(path.join(outDir, `${step.shot}.rgba`), Buffer.from(pixels, 'base64'));
        await page.screenshot({ path: path.join(outDir, `${step.shot}.png`) });
      }
      log.steps.push(entry);
    }
  });
}

const COMMANDS = { cases, smoke, controls, 'volume-live': volumeLive, inspect };
const [command, ...rest] = process.argv.slice(2);
if (COMMANDS[command]) await COMMANDS[command](...rest);
else {
  console.error('usage: node browser.mjs cases URL CASES.json OUT_DIR | smoke URL OUT_DIR | '
    + 'controls URL SCRIPT.json OUT_DIR | volume-live URL OUT_DIR | inspect URL SCRIPT.json OUT_DIR');
  process.exit(2);
}
