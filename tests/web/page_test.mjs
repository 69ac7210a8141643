// The results page (docs/plots.md) in a real browser: headless Chromium driven by puppeteer-core.
//
//   node tests/web/page_test.mjs --cli MULTIBOND --source SRC_DIR --work WORK_DIR [--screenshot PNG]
//
// For the mass-spring-damper (`multibond plot`), the differential and the bouncing ball
// (`multibond view`), a results folder with hostile names and a 5,001-row x 200-column run, it
// checks: no console error and no page error; no request but file:, data: and blob: (any other
// is aborted and fails the test); every plot's canvas and the 3D view's WebGL canvas drawn (not
// blank); a click on an element of the bond graph adds its plot; the 3D scene's body transforms
// at a chosen time equal the results' values bit for bit; the differential's pinion and crown
// wheel drawn in mesh (their boxes overlap along the contact line); the events marked on every
// plot against time; the exports (CSV, SVG, PNG) give the data; hostile text shown as text only (no
// dialog, no element made from it); the large run ready in under two seconds.
// Exit 77 (CTest: skipped) when Chromium or web/node_modules is missing.

import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';

const args = Object.fromEntries(process.argv.slice(2).reduce((acc, a, i, all) => (a.startsWith('--') ? [...acc, [a.slice(2), all[i + 1]]] : acc), []));
const cli = args.cli, source = path.resolve(args.source), work = path.resolve(args.work);
const chromium = args.chromium || '/usr/bin/chromium';
if (!fs.existsSync(chromium)) {
  console.log(`skipped: no Chromium at ${chromium} (apt-get install chromium; scripts/install-deps installs it)`);
  process.exit(77);
}
if (!fs.existsSync(path.join(source, 'web', 'node_modules', 'puppeteer-core'))) {
  console.log('skipped: web/node_modules is missing (run `npm ci` in web/; scripts/install-deps does)');
  process.exit(77);
}
const puppeteer = createRequire(path.join(source, 'web', 'package.json'))('puppeteer-core');

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures += 1;
}
const run = argv => execFileSync(cli, argv, { stdio: ['ignore', 'pipe', 'pipe'], encoding: 'utf8' });

/** results.csv as columns of numbers (the page's values must equal these bit for bit). */
function readCsv(file) {
  const lines = fs.readFileSync(file, 'utf8').trim().split('\n');
  const header = lines[0].split(',').map(h => h.replace(/ \[[^\]]*\]$/, ''));
  const cols = header.map(() => []);
  for (const line of lines.slice(1)) line.split(',').forEach((v, k) => cols[k].push(Number(v)));
  return { header, cols, col: name => cols[header.indexOf(name)] };
}

fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });
const downloads = path.join(work, 'downloads');
fs.mkdirSync(downloads);

// --- The results folders.
const msd = path.join(work, 'msd');
run(['run', path.join(source, 'examples/mass_spring_damper.yaml'), '-o', msd]);
run(['plot', msd, '--model', path.join(source, 'examples/mass_spring_damper.yaml')]);
const diff = path.join(work, 'differential');
run(['run', path.join(source, 'examples/differential.yaml'), '-o', diff]);
run(['view', diff, '--no-open', '--model', path.join(source, 'examples/differential.yaml')]);

const ball = path.join(work, 'bouncing-ball');
run(['run', path.join(source, 'examples/events/bouncing_ball.yaml'), '-o', ball]);
run(['view', ball, '--no-open']);

// Hostile text in every place a results folder holds text: column names and units, the model's
// name in run.json, an event's element and description.
const hostile = path.join(work, 'hostile');
fs.mkdirSync(hostile);
{
  const names = ['time [s]', '"<img src=x onerror=alert(1)>.x [<b>m</b>]"', '"x&amp;<script>alert(2)</script>.y [</script><script>alert(3)</script>]"',
    'energy.work [J]', 'energy.kinetic [J]', 'energy.potential [J]', 'energy.dissipated [J]', 'energy.residual [-]'];
  const rows = [names.join(',')];
  for (let i = 0; i <= 100; ++i) {
    const t = i / 100;
    rows.push([t, Math.sin(t), Math.cos(t), t, t / 2, t / 4, t / 4, 0].join(','));
  }
  fs.writeFileSync(path.join(hostile, 'results.csv'), `${rows.join('\n')}\n`);
  fs.writeFileSync(path.join(hostile, 'events.csv'),
    'time [s],kind,element,description\n0.5,impact,"<img src=x onerror=alert(4)>","<script>alert(5)</script>"\n');
  fs.writeFileSync(path.join(hostile, 'run.json'), JSON.stringify({ model: { name: '<img src=x onerror=alert(6)>', file: '/etc/passwd' } }));
  run(['view', hostile, '--no-open']);
}

// 5,001 rows x 200 columns.
const large = path.join(work, 'large');
fs.mkdirSync(large);
{
  const header = ['time [s]'];
  for (let k = 1; k < 200; ++k) header.push(`body${Math.floor(k / 10)}.q${k % 10} [m]`);
  const lines = [header.join(',')];
  for (let i = 0; i <= 5000; ++i) {
    const t = i / 1000, row = [t];
    for (let k = 1; k < 200; ++k) row.push(Math.sin(k * t + k) * (1 + k / 7));
    lines.push(row.join(','));
  }
  fs.writeFileSync(path.join(large, 'results.csv'), `${lines.join('\n')}\n`);
  run(['view', large, '--no-open']);
}

// --- The browser.
const profile = fs.mkdtempSync(path.join(work, 'profile-'));
const browser = await puppeteer.launch({
  executablePath: chromium,
  headless: true,
  userDataDir: profile,
  args: ['--no-sandbox', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-background-networking',
    '--disable-component-update', '--disable-sync', '--no-first-run', '--disable-default-apps'],
});

async function open(dir, what) {
  const page = await browser.newPage();
  const problems = [];
  page.on('console', m => { if (m.type() === 'error') problems.push(`console error: ${m.text()}`); });
  page.on('pageerror', e => problems.push(`page error: ${e.message}`));
  page.on('dialog', async d => { problems.push(`dialog: ${d.message()}`); await d.dismiss(); });
  await page.setRequestInterception(true);
  page.on('request', r => {
    const url = r.url();
    if (/^(file|data|blob):/.test(url)) r.continue();
    else { problems.push(`network request: ${url}`); r.abort(); }
  });
  const cdp = await page.createCDPSession();
  await cdp.send('Browser.setDownloadBehavior', { behavior: 'allow', downloadPath: downloads });
  await page.setViewport({ width: 1400, height: 1000 });
  await page.goto(`file://${dir}/index.html`, { waitUntil: 'load' });
  await page.waitForSelector('body[data-ready="1"]', { timeout: 30000 });
  return { page, problems, what };
}

/** Canvases (2D and WebGL) with more than one colour. */
async function blankCanvases(page, selector) {
  return page.$$eval(selector, cs => cs.map(c => {
    const probe = document.createElement('canvas');
    probe.width = Math.min(c.width, 400); probe.height = Math.min(c.height, 300);
    const ctx = probe.getContext('2d');
    ctx.drawImage(c, 0, 0, probe.width, probe.height);
    const d = ctx.getImageData(0, 0, probe.width, probe.height).data;
    const seen = new Set();
    for (let i = 0; i < d.length && seen.size < 3; i += 4) seen.add(`${d[i]},${d[i + 1]},${d[i + 2]},${d[i + 3]}`);
    return seen.size < 2;
  }).filter(Boolean).length);
}

function finish({ page, problems, what }) {
  check(problems.length === 0, `${what}: no console errors, dialogs or network requests${problems.length ? `: ${problems.join('; ')}` : ''}`);
  return page.close();
}

const waitFile = async (name, ms = 10000) => {
  for (let t = 0; t < ms; t += 100) {
    const f = path.join(downloads, name);
    if (fs.existsSync(f) && fs.statSync(f).size > 0) return fs.readFileSync(f);
    await new Promise(r => setTimeout(r, 100));
  }
  return null;
};

// The mass-spring-damper: plots, events-free energy stack, graph click, exports.
{
  const p = await open(msd, 'mass-spring-damper');
  const { page } = p;
  const canvases = await page.$$eval('.mb-plot canvas', cs => cs.length);
  check(canvases >= 2, `mass-spring-damper: ${canvases} plot canvases (energy stack and outputs)`);
  check(await blankCanvases(page, '.mb-plot canvas') === 0, 'mass-spring-damper: every plot canvas is drawn');
  const columns = await page.$$eval('#mb-column-list .mb-col-name', els => els.map(e => e.textContent));
  const csv = readCsv(path.join(msd, 'results.csv'));
  check(columns.length === csv.header.length - 1 && csv.header.slice(1).every(n => columns.includes(n)), `mass-spring-damper: the list has every column (${columns.length})`);
  await page.type('#mb-search', 'energy');
  const energy = await page.$$eval('#mb-column-list .mb-col-name', els => els.map(e => e.textContent));
  check(energy.length === csv.header.filter(n => n.includes('energy')).length, `mass-spring-damper: search 'energy' lists the file's ${energy.length} columns (not the stack's own)`);
  await page.$eval('#mb-search', e => { e.value = ''; });
  await page.type('#mb-search', 'spring');
  const filtered = await page.$$eval('#mb-column-list .mb-col-name', els => els.map(e => e.textContent));
  check(filtered.length > 0 && filtered.every(n => n.includes('spring')), `mass-spring-damper: search 'spring' lists ${filtered.join(', ')}`);
  const before = await page.evaluate(() => window.multibondPage.plotCount());
  await page.click('.mb-node.mb-clickable[data-element="spring"]');
  const after = await page.evaluate(() => window.multibondPage.plotCount());
  const titles = await page.$$eval('.mb-plot .mb-title', els => els.map(e => e.textContent));
  check(after > before && titles.some(t => t.startsWith('spring')), `mass-spring-damper: clicking 'spring' in the bond graph adds its plots (${before} -> ${after})`);
  // Power at the cursor: the damper takes power in (red) whenever it moves; the force gives it
  // out (blue) while the mass moves its way.
  const v = csv.col('velocity'), tt = csv.col('time');
  const moving = v.findIndex(x => x > 0.01);
  await page.evaluate(t => window.multibondPage.setTime(t), tt[moving + 1]);
  const fill = name => page.$eval(`.mb-node[data-element="${name}"] .mb-node-box`, e => e.getAttribute('fill'));
  const [damperFill, forceFill] = [await fill('damper'), await fill('force')];
  check(damperFill.startsWith('rgba(214,39,40') && forceFill.startsWith('rgba(31,119,180'),
    `mass-spring-damper: at t = ${tt[moving + 1]} s the damper takes power in (${damperFill}), the force gives it out (${forceFill})`);
  // Exports of the first plot (spring's): CSV with every row, SVG, PNG.
  const first = await page.$('#mb-plots .mb-plot');
  const [csvButton, svgButton, pngButton] = await Promise.all(['CSV', 'SVG', 'PNG'].map(t => first.$(`xpath/.//button[text()="${t}"]`)));
  await csvButton.click();
  const exported = await waitFile('columns.csv');
  const lines = exported ? exported.toString().trim().split('\n') : [];
  const q = csv.col('spring.q');
  const header = lines.length ? lines[0].split(',') : [];
  const k = header.indexOf('spring.q [m]');
  check(lines.length === q.length + 1 && k > 0 && lines.slice(1).every((l, i) => Number(l.split(',')[k]) === q[i]),
    `mass-spring-damper: CSV export holds every row (${lines.length - 1}) with the values of results.csv`);
  const title = await first.$eval('.mb-title', e => e.textContent);
  await svgButton.click();
  const svg = await waitFile(`${title.replace(/[^A-Za-z0-9_.-]+/g, '_').slice(0, 80)}.svg`);
  check(svg && svg.toString().startsWith('<svg') && svg.toString().includes('<polyline'), 'mass-spring-damper: SVG export is an SVG with the curves');
  await pngButton.click();
  const png = await waitFile(`${title.replace(/[^A-Za-z0-9_.-]+/g, '_').slice(0, 80)}.png`);
  check(png && png.subarray(1, 4).toString() === 'PNG', 'mass-spring-damper: PNG export is a PNG');
  await finish(p);
}

// The differential: the 3D view, its transforms, the scrub bar and the cursor together.
{
  const p = await open(diff, 'differential');
  const { page } = p;
  check(await page.$('#mb-3d canvas') !== null, 'differential: a 3D view');
  check(await blankCanvases(page, '#mb-3d canvas') === 0, 'differential: the WebGL canvas is drawn');
  check(await blankCanvases(page, '.mb-plot canvas') === 0, 'differential: every plot canvas is drawn');
  const csv = readCsv(path.join(diff, 'results.csv'));
  const t = 0.2503;
  const row = await page.evaluate(x => window.multibondPage.setTime(x), t);
  const time = csv.col('time');
  let expectRow = 0;
  while (expectRow + 1 < time.length && time[expectRow + 1] <= t) ++expectRow;
  check(row === expectRow, `differential: time ${t} s is row ${row} (results.csv: ${expectRow})`);
  for (const body of ['H', 'G', 'A', 'P1', 'P2', 'S1', 'S2']) {
    const m = await page.evaluate(b => window.multibondPage.bodyMatrix(b), body);
    // three.js keeps the matrix column by column: [R11 R21 R31 0 R12 R22 R32 0 R13 R23 R33 0 x y z 1].
    const c = n => csv.col(`${body}.${n}`)[expectRow];
    const want = [c('R.11'), c('R.21'), c('R.31'), 0, c('R.12'), c('R.22'), c('R.32'), 0, c('R.13'), c('R.23'), c('R.33'), 0,
      c('r.x'), c('r.y'), c('r.z'), 1];
    check(m && m.every((v, i) => v === want[i]), `differential: body ${body}'s transform at t = ${time[expectRow]} s equals results.csv's r and R`);
  }
  // The bevel pair drawn in mesh: at t = 0 the line where the pinion's and the crown wheel's pitch
  // cones touch, from the heel (the crown's pitch circle, H + (-0.2, 0, -0.1)) a third of the way
  // (the face width) to the common apex H + (0, 0, -0.05), lies inside both bodies' boxes.
  await page.evaluate(() => window.multibondPage.setTime(0));
  const [boxG, boxA] = [await page.evaluate(() => window.multibondPage.bodyBox('G')), await page.evaluate(() => window.multibondPage.bodyBox('A'))];
  const H = ['x', 'y', 'z'].map(a => csv.col(`H.r.${a}`)[0]);
  const heel = [H[0] - 0.2, H[1], H[2] - 0.1], apex = [H[0], H[1], H[2] - 0.05];
  const toe = heel.map((v, i) => apex[i] + (2 / 3) * (v - apex[i]));
  const inside = (b, q) => b && q.every((v, i) => v > b[0][i] && v < b[1][i]);
  const fmt = b => (b ? b.map(c => `[${c.map(v => v.toFixed(4)).join(', ')}]`).join('-') : 'none');
  check([heel, toe].every(q => inside(boxG, q) && inside(boxA, q)),
    `differential: the pinion G (${fmt(boxG)}) and the crown wheel A (${fmt(boxA)}) overlap along their contact line`);
  await page.evaluate(x => window.multibondPage.setTime(x), t);
  const scrub = await page.$eval('#mb-scrub', e => Number(e.value));
  check(scrub === expectRow, 'differential: the scrub bar follows the time');
  const readout = await page.$eval('#mb-readout', e => e.textContent);
  check(readout.includes('drive.torque') && readout.includes('P1_bearing'), 'differential: drive torque and bearing forces under the cursor');
  // A path: the rim point of P1, y against x, drawn whole (not clipped to the first and last x).
  await page.evaluate(() => {
    document.querySelector('[data-column="Q_P1.y"]').click();
    document.getElementById('mb-x').value = String(window.multibondPage.columns().findIndex(c => c.name === 'Q_P1.x'));
    document.getElementById('mb-plot-selected').click();
  });
  const titles = await page.evaluate(() => window.multibondPage.plotTitles());
  const k = titles.indexOf('Q_P1.y against Q_P1.x');
  const [x0, x1] = k >= 0 ? (await page.evaluate(() => window.multibondPage.xRanges()))[k] : [NaN, NaN];
  const qx = csv.col('Q_P1.x');
  check(k >= 0 && x0 <= Math.min(...qx) && x1 >= Math.max(...qx), `differential: Q_P1.y against Q_P1.x spans x ${x0} to ${x1}`);
  check(await blankCanvases(page, '.mb-plot canvas') === 0, 'differential: the path is drawn');
  const trails = await page.evaluate(() => document.querySelectorAll('#mb-3d canvas').length);
  check(trails === 1, 'differential: one WebGL canvas');
  if (args.screenshot) {
    // The README's picture: the drive torque and a planet bearing's force under the cursor, the
    // seven links turning with the planets' rim points traced.
    await page.setViewport({ width: 1400, height: 1150 });
    await page.evaluate(() => window.multibondPage.plotColumns(['P1_bearing.F.x', 'P1_bearing.F.y', 'P1_bearing.F.z']));
    await page.evaluate(() => window.multibondPage.plotColumns(['drive.torque']));
    await page.evaluate(() => { window.multibondPage.setTime(0.6); document.getElementById('mb-scene').scrollIntoView(); window.scrollBy(0, -40); });
    await page.screenshot({ path: args.screenshot });
    console.log(`wrote ${args.screenshot}`);
  }
  await finish(p);
}

// Events: marked on every plot against time; the bar names the last one before the cursor.
{
  const p = await open(ball, 'bouncing ball');
  const { page } = p;
  const lines = await page.evaluate(() => window.multibondPage.eventLines());
  check(lines.length >= 2 && lines.every(n => n > 0), `bouncing ball: every plot against time marks events (${lines.join(', ')} lines)`);
  const first = fs.readFileSync(path.join(ball, 'events.csv'), 'utf8').split('\n')[1].split(',');
  await page.evaluate(t => window.multibondPage.setTime(t), Number(first[0]) + 0.01);
  const said = await page.$eval('#mb-event-at', e => e.textContent);
  check(said.includes(first[1]) && said.includes(first[2]), `bouncing ball: the bar says the last event: ${said}`);
  check(await blankCanvases(page, '.mb-plot canvas') === 0, 'bouncing ball: every plot canvas is drawn');
  await finish(p);
}

// Hostile names: shown as text.
{
  const p = await open(hostile, 'hostile names');
  const { page } = p;
  const names = await page.$$eval('#mb-column-list .mb-col-name', els => els.map(e => e.textContent));
  check(names.includes('<img src=x onerror=alert(1)>.x'), 'hostile names: a column name with markup is listed as text');
  const injected = await page.evaluate(() => document.querySelectorAll('img[src="x"], b, script:not([src]):not([type="application/json"])').length);
  check(injected === 0, 'hostile names: no element made from the names');
  await page.click('.mb-col-name');
  check(await page.evaluate(() => window.multibondPage.plotCount()) >= 2, 'hostile names: their columns plot');
  await new Promise(r => setTimeout(r, 300));
  await finish(p);
}

// A large run opens fluidly.
{
  const p = await open(large, 'large run');
  const ready = await p.page.evaluate(() => Math.max(window.multibondPage.timings().ready, performance.getEntriesByType('navigation')[0].loadEventEnd));
  const rows = await p.page.evaluate(() => window.multibondPage.rows());
  const cols = await p.page.evaluate(() => window.multibondPage.columns().length);
  check(rows === 5001 && cols === 200, `large run: ${rows} rows x ${cols} columns`);
  check(ready < 2000, `large run: ready and loaded ${Math.round(ready)} ms after the page was opened (< 2000)`);
  await finish(p);
}

await browser.close();
console.log(failures ? `${failures} checks failed` : 'all checks passed');
process.exit(failures ? 1 : 0);
