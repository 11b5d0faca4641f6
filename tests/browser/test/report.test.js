// report.html in a real browser, on three runs of `lrmcal`:
//
// - the documented workflow (README.md, "Calibrating a real arm", as
//   .ci/readme-steps runs it): plan, select (60 poses to fit, 10 set aside
//   to validate on), simulated measurements of the selected poses only, and
//   identify --poses --option all, which fits the 60 and holds the 10 out;
// - a calibration of 40 poses DETMAX picks among many measured (every
//   option, the others held out);
// - the demo, made small.
//
// A headless Chromium opens each page with JavaScript off and on, and finds
// every section, table and plot, each plot with drawn content, no console
// or page error, and no request leaving the page (only the file itself may
// load). On the workflow's page it checks what a user wants to see: the
// first screen (verdict, headline numbers, the file to push, the advice)
// before any figure; each option's error per measurement with the fitted
// and the held-out poses; the workspace seen from above and from the side;
// one servo-curve figure per joint with a servo; the parameters grouped per
// joint; and that exactly the validation poses were held out.
//
// The binary: $LRMCAL, or the debug build `cargo test` leaves in
// ${CARGO_TARGET_DIR:-target}/debug/lrmcal. With $REPORT_SCREENSHOT set to
// a .png path, the top of the workflow's page (1100 × 1400 pixels) is saved there.

import { test, before, after } from 'node:test';
import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import { existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';
import chromium from '@sparticuz/chromium';
import puppeteer from 'puppeteer-core';

const root = resolve(fileURLToPath(import.meta.url), '../../../..');
const lrmcal =
  process.env.LRMCAL ?? join(resolve(root, process.env.CARGO_TARGET_DIR ?? 'target'), 'debug', 'lrmcal');

// Every page has these sections, in this order.
const SECTIONS = ['next', 'summary', 'errors', 'workspace', 'servo', 'mechanics', 'suspect', 'parameters',
  'selection', 'model', 'knots', 'registration'];

let dir;
let browser;
// The runs: where each wrote its page, and what the test knows of it.
const runs = {};

/** Runs lrmcal with `args`, failing the test with its output if it fails. */
function run(...args) {
  return execFileSync(lrmcal, args, { encoding: 'utf8', stdio: ['ignore', 'pipe', 'pipe'] });
}

/** The rows of a CSV file without comments, as objects by column name. */
function csv(file) {
  const [header, ...rows] = readFileSync(file, 'utf8').split('\n').filter((l) => l && !l.startsWith('#'));
  const names = header.split(',');
  return rows.map((r) => Object.fromEntries(r.split(',').map((v, i) => [names[i], v.trim()])));
}

before(async () => {
  assert.ok(existsSync(lrmcal), `no lrmcal binary at ${lrmcal}: build it (cargo build -p host) or set LRMCAL`);
  dir = mkdtempSync(join(tmpdir(), 'lrmcal-page-'));
  const at = (name) => join(dir, name);

  // The documented workflow, with the README's commands and defaults.
  run('plan', '--out', at('candidates.csv'));
  run('select', '--candidates', at('candidates.csv'), '--out', at('selected.csv'));
  run('simulate', '--poses', at('selected.csv'), '--loads', '0,0.0663', '--out', at('measured.csv'));
  run('identify', '--measurements', at('measured.csv'), '--load-kg', '0.0663', '--poses', at('selected.csv'),
    '--option', 'all', '--out', at('workflow'));
  const selected = csv(at('selected.csv'));
  runs.workflow = {
    page: at('workflow/report.html'),
    report: JSON.parse(readFileSync(at('workflow/report.json'), 'utf8')),
    fit: selected.filter((r) => r.role === 'fit').map((r) => Number(r.pose)),
    validate: selected.filter((r) => r.role === 'validate').map((r) => Number(r.pose)),
    joints: Object.keys(selected[0]).filter((c) => /^q\d+_deg$/.test(c)).length,
  };

  // 40 poses DETMAX picks among every third candidate measured: the others held out.
  const [header, ...rows] = readFileSync(at('candidates.csv'), 'utf8').trim().split('\n');
  writeFileSync(at('poses.csv'), [header, ...rows.filter((_, i) => i % 3 === 0)].join('\n') + '\n');
  run('simulate', '--poses', at('poses.csv'), '--loads', '0,0.0663', '--seed', '5', '--out', at('many.csv'));
  run('identify', '--measurements', at('many.csv'), '--load-kg', '0.0663', '--select', '40',
    '--starts', '2', '--option', 'all', '--out', at('select40'));
  runs.select40 = { page: at('select40/report.html') };

  // The demo, made small: its page is built the same way.
  run('demo', '--out', at('demo'), '--starts', '2', '--compare-random', '0', '--targets', '0', '--no-error-sweep');
  runs.demo = { page: at('demo/report.html') };

  browser = await puppeteer.launch({
    executablePath: await chromium.executablePath(),
    args: chromium.args,
    headless: true,
  });
});

after(async () => {
  await browser?.close();
  if (dir) rmSync(dir, { recursive: true, force: true });
});

/**
 * Opens `file` with JavaScript on or off; every request but the page's own
 * is recorded and refused, and console errors and page errors are recorded.
 */
async function open(file, javascript) {
  const page = await browser.newPage();
  const url = pathToFileURL(file).href;
  const seen = { requests: [], errors: [] };
  await page.setJavaScriptEnabled(javascript);
  await page.setRequestInterception(true);
  page.on('request', (request) => {
    if (request.url() === url) {
      request.continue();
    } else {
      seen.requests.push(request.url());
      request.abort();
    }
  });
  page.on('console', (message) => {
    if (message.type() === 'error') seen.errors.push(`console: ${message.text()}`);
  });
  page.on('pageerror', (error) => seen.errors.push(`page: ${error.message}`));
  await page.goto(url, { waitUntil: 'load' });
  return { page, seen };
}

/** What the page shows: its sections, every table and every figure, and the first screen. */
function inventory(page) {
  return page.evaluate((sections) => {
    const box = (e) => {
      const r = e.getBoundingClientRect();
      return r.width > 0 && r.height > 0;
    };
    const before = (a, b) => !!a && !!b && !!(a.compareDocumentPosition(b) & Node.DOCUMENT_POSITION_FOLLOWING);
    const firstFigure = document.querySelector('figure');
    return {
      sections: sections.map((id) => {
        const s = document.getElementById(id);
        return { id, found: !!s, heading: s?.querySelector('h2')?.textContent ?? '', shown: !!s && box(s) };
      }),
      tables: [...document.querySelectorAll('table')].map((t) => ({
        id: t.id,
        rows: t.querySelectorAll('tbody tr').length,
        groups: [...t.querySelectorAll('tbody > tr > th[scope=rowgroup]')].map((th) => th.textContent),
        bodies: t.querySelectorAll('tbody').length,
        shown: box(t),
      })),
      figures: [...document.querySelectorAll('figure')].map((f) => {
        const svg = f.querySelector('svg');
        const b = svg?.getBBox();
        return {
          id: f.id,
          section: f.closest('section')?.id,
          svg: !!svg,
          shown: !!svg && box(svg),
          drawn: svg?.querySelectorAll('circle, rect, line, polyline, polygon, path, text').length ?? 0,
          circles: svg?.querySelectorAll('circle').length ?? 0,
          polygons: svg?.querySelectorAll('polygon').length ?? 0,
          lines: svg?.querySelectorAll('polyline, path').length ?? 0,
          extent: b ? b.width * b.height : 0,
          caption: f.querySelector('figcaption')?.textContent ?? '',
        };
      }),
      verdict: document.getElementById('verdict')?.textContent ?? '',
      push: document.getElementById('push')?.textContent ?? '',
      firstScreen: ['verdict', 'headline-table', 'push', 'advice'].map((id) => ({
        id,
        beforeFigures: before(document.getElementById(id), firstFigure),
      })),
      advice: [...document.querySelectorAll('#advice li')].map((li) => li.textContent),
      summaryRows: document.querySelectorAll('#summary-table tbody tr').length,
      scripts: document.querySelectorAll('script').length,
      external: [...document.querySelectorAll('[src], link[href], image, use')].length,
    };
  }, SECTIONS);
}

/** The checks every page passes, demo or not. */
function checkEveryPage(found, seen) {
  for (const s of found.sections) {
    assert.ok(s.found && s.shown && s.heading.length > 0, `section ${JSON.stringify(s)}`);
  }
  for (const t of found.tables) {
    // Every table has rows, but the suspect measurements' when none is suspect.
    assert.ok(t.id && t.shown && (t.rows > 0 || t.id === 'suspect-table'), `table ${JSON.stringify(t)}`);
  }
  assert.ok(found.figures.length > 0, 'no figure');
  for (const f of found.figures) {
    // A plot with axes, labels and its data drawn.
    assert.ok(f.svg && f.shown && f.drawn > 30 && f.circles + f.polygons + f.lines > 10 && f.extent > 10000,
      `figure ${JSON.stringify(f)}`);
  }
  // The first screen, before any figure: the verdict, the headline numbers, the file to push, the advice.
  for (const s of found.firstScreen) assert.ok(s.beforeFigures, `first screen ${JSON.stringify(s)}`);
  assert.ok(found.tables.find((t) => t.id === 'headline-table')?.rows >= 2, 'headline-table');
  assert.ok(found.verdict.length > 0 && found.push.length > 0);
  assert.equal(found.scripts, 0);
  assert.equal(found.external, 0);
  assert.deepEqual(seen.requests, []);
  assert.deepEqual(seen.errors, []);
}

/** The figures of `found` whose id starts with `prefix`. */
const figuresOf = (found, prefix) => found.figures.filter((f) => f.id.startsWith(prefix));

for (const javascript of [false, true]) {
  const js = `JavaScript ${javascript ? 'on' : 'off'}`;

  test(`the documented workflow's page shows what a user wants to see (${js})`, async () => {
    const w = runs.workflow;
    // What select wrote: 60 poses to fit, 10 set aside; identify held out exactly those.
    assert.equal(w.fit.length, 60);
    assert.equal(w.validate.length, 10);
    for (const o of w.report.options) {
      assert.deepEqual([...o.selected_poses].sort((a, b) => a - b), [...w.fit].sort((a, b) => a - b), o.option);
      const held = [...new Set(o.validation.per_pose.map((p) => p.pose))].sort((a, b) => a - b);
      assert.deepEqual(held, [...w.validate].sort((a, b) => a - b), o.option);
    }
    const { page, seen } = await open(w.page, javascript);
    const found = await inventory(page);
    if (javascript && process.env.REPORT_SCREENSHOT) {
      // The picture of the page the README shows, as this browser drew it.
      await page.setViewport({ width: 1100, height: 1400 });
      await page.screenshot({ path: process.env.REPORT_SCREENSHOT });
    }
    await page.close();
    checkEveryPage(found, seen);
    const options = w.report.options.length;
    assert.equal(found.summaryRows, options);

    // Is it good: judged on the poses the fit never saw, and the file to push named.
    assert.match(found.verdict, /on the 10 measurements held out of the fit/);
    assert.match(found.push, /^File to push: calibration-[a-z-]+\.json/);
    assert.ok(found.advice.some((a) => a.startsWith('Push calibration-')), found.advice.join('\n'));

    // Each option's error per measurement: the 60 fitted ones before, after and
    // left out (circles), the 10 held out before and after (triangles).
    const perPose = figuresOf(found, 'fig-per-pose-');
    assert.equal(perPose.length, options);
    for (const f of perPose) {
      assert.ok(f.section === 'errors' && f.circles >= 3 * 60 && f.polygons >= 2 * 10, `per pose ${JSON.stringify(f)}`);
    }
    // The validation on the held-out poses, per option and across loads.
    for (const id of ['fig-errors', 'fig-errors-cross-load']) {
      assert.ok(found.figures.some((f) => f.id === id), id);
    }

    // Where the arm was worst: from above and from the side, before and after,
    // every fitted point (circles) and held-out one (triangles) in both panels.
    for (const id of ['fig-workspace-top', 'fig-workspace-side']) {
      const f = found.figures.find((x) => x.id === id);
      assert.ok(f && f.section === 'workspace' && f.circles >= 2 * 60 && f.polygons >= 2 * 10, `${id} ${JSON.stringify(f)}`);
    }

    // One servo-curve figure per joint with a servo, for each option whose fit
    // kept servo curves; ours keeps them here (60 poses carry its knots).
    const ours = w.report.options.findIndex((o) => o.option === 'elasto-kinematic-servo');
    assert.ok(ours >= 0 && w.report.options[ours].model.chosen === 'elasto-kinematic-servo');
    w.report.options.forEach((o, i) => {
      const drawn = figuresOf(found, `fig-servo-${i}-j`).map((f) => f.id).sort();
      const expected = o.servo_curves.map((c) => `fig-servo-${i}-j${c.joint}`).sort();
      assert.deepEqual(drawn, expected, o.option);
    });
    const servo = figuresOf(found, `fig-servo-${ours}-j`);
    assert.equal(servo.length, w.joints, 'a servo-curve figure per joint of the arm');
    for (const f of servo) {
      // The band, the curve, and the knots.
      assert.ok(f.section === 'servo' && f.polygons >= 1 && f.lines >= 1 && f.circles >= 3, `servo ${JSON.stringify(f)}`);
    }

    // Play and spring per joint, and the parameters grouped per joint.
    const mechanics = found.tables.find((t) => t.id === `mechanics-${ours}`);
    assert.ok(mechanics && mechanics.rows >= w.joints, JSON.stringify(mechanics));
    const params = found.tables.find((t) => t.id === `params-${ours}`);
    const joints = Array.from({ length: w.joints }, (_, j) => `joint ${j + 1}`);
    assert.ok(params && params.bodies === params.groups.length, JSON.stringify(params));
    for (const group of ['base', ...joints]) assert.ok(params.groups.includes(group), `${group}: ${params.groups}`);
  });

  for (const name of ['select40', 'demo']) {
    test(`the ${name} page is complete (${js}) and asks the network for nothing`, async () => {
      const { page, seen } = await open(runs[name].page, javascript);
      const found = await inventory(page);
      await page.close();
      checkEveryPage(found, seen);
      // The held-out poses' validation, every option's error per measurement,
      // the workspace and ours' servo curves, whatever made the page.
      for (const prefix of ['fig-errors', 'fig-per-pose-0', 'fig-workspace-top', 'fig-workspace-side', 'fig-servo-']) {
        assert.ok(figuresOf(found, prefix).length > 0, `${name}: ${prefix}`);
      }
      assert.ok(found.tables.some((t) => t.id.startsWith('params-') && t.bodies > 1), `${name}: grouped parameters`);
      assert.ok(found.advice.some((a) => a.startsWith('Push calibration-')), found.advice.join('\n'));
    });
  }
}

// The harness can fail: a page that asks for an image elsewhere is caught.
test('a request leaving the page is seen', async () => {
  const file = join(dir, 'leaky.html');
  writeFileSync(file, '<!DOCTYPE html><title>x</title><img src="https://example.invalid/x.png">');
  const { page, seen } = await open(file, false);
  await page.close();
  assert.deepEqual(seen.requests, ['https://example.invalid/x.png']);
});
