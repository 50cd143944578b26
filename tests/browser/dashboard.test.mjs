// The dashboard in real headless Chromium (Debian's /usr/bin/chromium, driven by playwright-core) against a
// real fleetd with a simulated fleet: every page renders its charts and images, labelling round-trips
// through the API, a reprocessing job shows live progress, a map repair goes through review and undo, empty
// and error states show. Screenshots are written to $ARTIFACTS_DIR. Run by ctest (dashboard_browser), which
// sets the binaries' paths.
import { after, before, test } from 'node:test';
import assert from 'node:assert/strict';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import * as fleet from './fleet.mjs';

const { chromium } = fleet.webRequire('playwright-core');
const FLEET = { robots: 3, runs: 2, minutes: 3, seed: 7 };

let dir, server, grpc, engineerToken, browser, page, uploaded, repairJob;
const consoleErrors = [];

async function screenshot(name) {
  fs.mkdirSync(fleet.env.artifacts, { recursive: true });
  const file = path.join(fleet.env.artifacts, `${name}.png`);
  await page.screenshot({ path: file, fullPage: true });
  return file;
}

/// Navigates to a hash route and waits until the page says it is done (main[data-state] != loading).
async function visit(route) {
  await page.goto(`${server.http}/#${route}`);
  await page.waitForFunction(() => document.querySelector('main')?.dataset.state !== 'loading', null, { timeout: 20000 });
  return page.locator('main').getAttribute('data-state');
}

async function chartPoints(testid) {
  const canvas = page.locator(`canvas[data-testid="${testid}"]`);
  await canvas.waitFor();
  const box = await canvas.boundingBox();
  assert.ok(box && box.width > 50 && box.height > 50, `${testid} has a size`);
  return Number(await canvas.getAttribute('data-points'));
}

async function imageLoaded(testid) {
  const img = page.locator(`img[data-testid="${testid}"]`);
  await img.waitFor();
  await page.waitForFunction((id) => {
    const element = document.querySelector(`img[data-testid="${id}"]`);
    return element && element.complete && element.naturalWidth > 0;
  }, testid, { timeout: 15000 });
  return img.evaluate((element) => element.naturalWidth);
}

before(async () => {
  dir = fs.mkdtempSync(path.join(os.tmpdir(), 'fleetd-dashboard-'));
  // A small lifelong experiment (two regimes, one of them with its own fleetd) for the fleet page's chart.
  const lifelong = fleet.simulateLifelong(dir, { robots: 2, runs: 3, minutes: 2, seed: 7, regimes: 'filter,service' });
  server = await fleet.startFleetd(dir, ['--lifelong-results', lifelong]);
  grpc = fleet.clients(server.grpc);
  engineerToken = await fleet.issueToken(grpc, server.adminToken, 'engineer:browser-test');
  uploaded = await fleet.simulateAndUpload(grpc, server, server.adminToken, dir, FLEET);
  await fleet.waitFor(() => fleet.getJson(server, '/api/jobs?kind=analyze_run&limit=500'),
    (j) => j.jobs.length >= uploaded && j.jobs.every((job) => ['done', 'failed', 'cancelled'].includes(job.state)), 120000, 'upload analyses');
  const analysed = await fleet.getJson(server, '/api/stats');
  if (analysed.total.reports < uploaded) {
    // fleetd's ingest enqueues the analysis before it stores the run, and a worker that leases the job in
    // between drops it as "no_run" (fleetd_jobs_total{outcome="no_run"}): reprocess with the default set
    // so every run has its report, as an engineer would.
    console.warn(`only ${analysed.total.reports} of ${uploaded} uploads were analysed: reprocessing with "default"`);
    repairJob = await fleet.startReprocessing(grpc, engineerToken, 'default');
    await fleet.waitFor(() => fleet.getJson(server, '/api/stats'), (s) => s.total.reports >= uploaded, 120000, 'analysis of every upload');
  }
  // A fresh profile per run (a --user-data-dir of its own, passed the way playwright wants it).
  browser = await chromium.launchPersistentContext(path.join(dir, 'chromium-profile'), {
    executablePath: '/usr/bin/chromium',
    args: ['--no-sandbox', '--disable-gpu', '--disable-background-networking', '--disable-component-update',
      '--no-first-run', '--disable-quic', '--disable-sync'],
    viewport: { width: 1280, height: 860 },
  });
  page = browser.pages()[0] || await browser.newPage();
  page.on('console', (message) => { if (message.type() === 'error') consoleErrors.push(message.text()); });
  page.on('pageerror', (error) => consoleErrors.push(String(error)));
});

after(async () => {
  if (browser) await browser.close();
  if (grpc) grpc.close();
  if (server) {
    const stopped = await server.stop();
    assert.equal(stopped.code, 0, 'fleetd exits cleanly on SIGTERM');
  }
  if (dir && !process.env.KEEP_TMP) fs.rmSync(dir, { recursive: true, force: true });
});

test('sign-in: no data without a token; the token is entered once and kept for the tab; a 401 asks again', async () => {
  for (const route of ['/api/robots', '/api/runs', '/api/labels', '/api/jobs', '/api/lifelong', '/metrics']) {
    const response = await fetch(`${server.http}${route}`);
    assert.equal(response.status, 401, route);
    assert.equal(response.headers.get('cache-control'), 'no-store', route);
  }
  assert.equal(await visit('/overview'), 'signin');
  const shell = await fetch(`${server.http}/`);
  assert.equal(shell.status, 200, 'the shell itself is open');
  assert.match(shell.headers.get('content-security-policy'), /frame-ancestors 'none'/);
  assert.equal(shell.headers.get('x-content-type-options'), 'nosniff');
  // A wrong token is refused and the form comes back.
  await page.getByTestId('signin-token').fill('engineer:browser-test.0000');
  await page.getByTestId('signin-submit').click();
  await page.waitForFunction(() => document.querySelector('main')?.dataset.state === 'signin'
    && !sessionStorage.getItem('fleetd.token'), null, { timeout: 20000 });
  await page.getByTestId('signin-token').fill(engineerToken);
  await page.getByTestId('signin-submit').click();
  await page.waitForFunction(() => !['loading', 'signin'].includes(document.querySelector('main')?.dataset.state), null, { timeout: 20000 });
  assert.equal(await page.locator('main').getAttribute('data-state'), 'ready');
  assert.equal(await page.evaluate(() => sessionStorage.getItem('fleetd.token')), engineerToken);
  assert.match(await page.locator('#token-status').innerText(), /signed in as engineer:browser-test/);
});

test('fleet overview renders the paper figures and trends', async () => {
  assert.equal(await visit('/overview'), 'ready');
  assert.match(await page.getByTestId('kpi-runs').innerText(), new RegExp(`^${uploaded}\\b`));
  for (const chart of ['chart-fig6', 'chart-fig7', 'chart-fig8', 'chart-fig12', 'chart-trend-day', 'chart-runs-day', 'chart-trend-firmware']) {
    assert.ok(await chartPoints(chart) > 0, `${chart} draws data`);
  }
  await page.getByTestId('confusion-matrix').waitFor();
  // The lifelong experiment: corrupted share by run for each regime, and its table.
  assert.equal(await chartPoints('chart-lifelong'), 2 * 3, 'two regimes × three runs');
  for (const regime of ['filter', 'service']) await page.getByTestId(`lifelong-row-${regime}`).waitFor();
  const life = await fleet.getJson(server, '/api/lifelong');
  assert.deepEqual(Object.keys(life.regimes).sort(), ['filter', 'service']);
  assert.equal(life.regimes.filter.corrupted_by_run.length, 3);
  assert.equal(life.regimes.filter.per_robot, undefined, 'the page gets the summary only');
  const robotToken = await fleet.issueToken(grpc, server.adminToken, 'robot:lifelong-reader');
  const refused = await fetch(`${server.http}/api/lifelong`, { headers: { Authorization: `Bearer ${robotToken}` } });
  assert.equal(refused.status, 403, 'robots do not read the fleet\'s lifelong results');
  // Filters: a firmware filter narrows the figures (server-side aggregation).
  const meta = await fleet.getJson(server, '/api/meta');
  assert.ok(meta.firmware.length >= 1);
  await page.selectOption('select[name=firmware]', meta.firmware[0]);
  await page.click('form[data-testid=filters] button[type=submit]');
  await page.waitForFunction((fw) => location.hash.includes(`firmware=${fw}`) && document.querySelector('main').dataset.state === 'ready', meta.firmware[0]);
  const filtered = await fleet.getJson(server, `/api/stats?firmware=${encodeURIComponent(meta.firmware[0])}`);
  assert.match(await page.getByTestId('kpi-runs').innerText(), new RegExp(`^${filtered.total.reports}\\b`));
  await visit('/overview');
  await screenshot('overview');
});

test('runs list paginates with a keyset cursor', async () => {
  assert.equal(await visit('/runs'), 'ready');
  assert.equal(await page.getByTestId('run-row').count(), uploaded);
  const first = await fleet.getJson(server, '/api/runs?limit=4');
  assert.equal(first.runs.length, 4);
  const second = await fleet.getJson(server, `/api/runs?limit=4&after_ms=${first.next.after_ms}&after_id=${first.next.after_id}`);
  assert.equal(second.runs.length, uploaded - 4);
  assert.ok(!first.runs.some((r) => second.runs.some((s) => s.run_id === r.run_id)), 'pages do not overlap');
  await screenshot('runs');
});

let regionRun;
test('run page shows parent, child and difference maps, the pose graph and the decision timeline', async () => {
  const withRegions = await fleet.getJson(server, '/api/runs?with_regions=1');
  assert.ok(withRegions.runs.length > 0, 'the simulated fleet produced protrusion regions');
  regionRun = withRegions.runs[0];
  await visit('/runs');
  await page.click(`a[href^="#/runs/${regionRun.run_id}"]`);
  await page.waitForFunction(() => document.querySelector('main').dataset.state === 'ready', null, { timeout: 20000 });
  for (const image of ['map-parent', 'map-child', 'map-difference']) assert.ok(await imageLoaded(image) > 0, `${image} loads`);
  assert.equal(await page.locator('[data-testid=map-difference] + svg rect.region').count(), regionRun.regions);
  // Each region says what called it: the run's own views (they show the robot slipped) or the classifier.
  const detail = await fleet.getJson(server, `/api/runs/${regionRun.run_id}`);
  const decidedBy = { views: "the run's views", classifier: 'the classifier', none: 'no classifier' };
  assert.ok(detail.regions.every((g) => g.decided_by in decidedBy), 'every stored region names what decided its class');
  assert.deepEqual(await page.getByTestId('decided-by').allTextContents(), detail.regions.map((g) => decidedBy[g.decided_by]));
  const graph = page.getByTestId('pose-graph');
  await graph.waitFor();
  assert.ok(await graph.locator('line').count() > 10, 'the pose graph has edges');
  const api = await fleet.getJson(server, `/api/runs/${regionRun.run_id}/graph`);
  assert.equal(await graph.locator('[data-kind=hypothesis]').count(), api.hypothesis_edges.filter((e) => api.nodes.length).length);
  assert.equal(await graph.locator('[data-kind=ambiguous-view]').count(), api.views.filter((v) => v.ambiguous).length);
  assert.ok(await page.getByTestId('decision').count() > 0, 'the timeline lists decisions');
  await page.getByTestId('ambiguous-views').waitFor();
  await screenshot('run');
});

test('labelling: click a region, label it, and the label round-trips through the API', async () => {
  assert.equal(await visit(`/labelling?run=${encodeURIComponent(regionRun.run_id)}`), 'ready');
  assert.ok(await imageLoaded('label-map') > 0);
  await page.getByTestId('no-labels').waitFor();
  const rect = page.locator('[data-testid=label-map] + svg rect.region').first();
  const regionId = Number(await rect.getAttribute('data-region'));
  await rect.click({ force: true });
  await page.waitForSelector(`[data-testid=label-map] + svg rect.region.selected[data-region="${regionId}"]`);
  // The engineer signed in once (the first subtest): labelling asks for no token again.
  let prompts = 0;
  page.on('dialog', (dialog) => { prompts += 1; dialog.accept(engineerToken); });
  await page.getByTestId('label-protrusion').click();
  await page.waitForSelector('[data-testid=label-status][data-saved=protrusion]');
  assert.equal(prompts, 0);
  const detail = await fleet.getJson(server, `/api/runs/${regionRun.run_id}`);
  const stored = detail.regions.find((g) => g.region_id === regionId);
  assert.equal(stored.label, 'protrusion');
  assert.equal(stored.labelled_by, 'engineer:browser-test');
  const labels = await fleet.getJson(server, '/api/labels');
  assert.ok(labels.regions.some((g) => g.run_id === regionRun.run_id && g.region_id === regionId && g.label === 'protrusion'));
  await page.getByTestId('labelled-region').first().waitFor();
  // Relabel: no second prompt, and the newest label wins.
  await page.getByTestId('label-new-space').click();
  await page.waitForSelector('[data-testid=label-status][data-saved=new_space]');
  assert.equal(prompts, 0, 'the token is not asked for again');
  const relabelled = await fleet.getJson(server, `/api/runs/${regionRun.run_id}`);
  assert.equal(relabelled.regions.find((g) => g.region_id === regionId).label, 'new_space');
  // Without a token the API refuses.
  const refused = await fetch(`${server.http}/api/runs/${regionRun.run_id}/regions/${regionId}/label`, { method: 'POST', body: '{"label":"protrusion"}' });
  assert.equal(refused.status, 401);
  await page.getByTestId('label-protrusion').click();
  await page.waitForSelector('[data-testid=label-status][data-saved=protrusion]');
  await screenshot('labelling');
  // The confusion matrix now counts the label.
  const stats = await fleet.getJson(server, '/api/stats');
  assert.equal(stats.confusion.labelled, 1);
});

test('experiments: empty until a second parameter set is analysed', async () => {
  assert.equal(await visit('/experiments'), 'empty');
  await page.getByTestId('empty-state').waitFor();
});

test('jobs: a reprocessing job shows live progress until done', async () => {
  assert.equal(await visit('/jobs'), repairJob ? 'ready' : 'empty');
  await fleet.putParameterSet(grpc, engineerToken, {
    name: 'strict-recovery', description: 'stricter recovery acceptance and gate',
    mapper: { gate_chi2: 5.0, recovery: { min_observations: 5, min_views: 3 } },
  });
  const job = await fleet.startReprocessing(grpc, engineerToken, 'strict-recovery');
  const row = page.locator(`[data-testid=job-row][data-job="${job.job_id}"]`);
  await row.waitFor({ timeout: 10000 });  // the page polls: no reload
  const seen = new Set();
  const deadline = Date.now() + 90000;
  while (Date.now() < deadline) {
    const state = await row.getAttribute('data-state');
    seen.add(`${state}:${await row.getAttribute('data-done')}/${await row.getAttribute('data-total')}`);
    if (state === 'done' || state === 'failed') break;
    await page.waitForTimeout(100);
  }
  assert.equal(await row.getAttribute('data-state'), 'done', `job states seen: ${[...seen].join(' ')}`);
  assert.equal(await row.getAttribute('data-done'), String(uploaded));
  assert.equal(await row.getAttribute('data-total'), String(uploaded));
  await screenshot('jobs');
});

test('experiments: two parameter sets side by side with deltas and the runs that changed most', async () => {
  assert.equal(await visit('/experiments?a=default&b=strict-recovery'), 'ready');
  assert.ok(await chartPoints('chart-compare') > 0);
  await page.getByTestId('compare-table').waitFor();
  const cmp = await fleet.getJson(server, '/api/compare?a=default&b=strict-recovery');
  assert.equal(cmp.runs_compared, uploaded);
  assert.equal(await page.getByTestId('changed-run').count(), Math.min(15, cmp.changed_most.length));
  await screenshot('experiments');
});

// ---- Map review (issue #10): history timeline, findings and constraints, repair → review → undo, export ----
let mapRobot, reviewedVersion, repairedVersion, undoVersion;
const mapsApi = (robot) => `/api/robots/${encodeURIComponent(robot)}/maps`;

/// Waits for the review page of a version other than `previous` (a repair opens the version it made).
async function waitForNewVersionPage(previous) {
  await page.waitForFunction((old) => {
    const match = location.hash.match(/\/maps\/(\d+)/);
    return match && Number(match[1]) !== old && document.querySelector(`[data-testid=version-title][data-version="${match[1]}"]`) &&
      document.querySelector('main').dataset.state === 'ready';
  }, previous, { timeout: 20000 });
  return Number(await page.getByTestId('version-title').getAttribute('data-version'));
}

/// Repairs and reviews ask for the engineer token once (like labelling); when no earlier subtest stored it
/// in this tab, answer the prompt.
async function expectTokenPrompt() {
  const stored = await page.evaluate(() => Boolean(sessionStorage.getItem('fleetd.token')));
  if (!stored && page.listenerCount('dialog') === 0) page.once('dialog', (dialog) => dialog.accept(engineerToken));
}

test('maps: robots with their map history in brief', async () => {
  assert.equal(await visit('/maps'), 'ready');
  const { robots } = await fleet.getJson(server, '/api/robots');
  assert.equal(robots.length, FLEET.robots);
  assert.equal(await page.getByTestId('robot-row').count(), robots.length);
  // The robot whose current map has the most observation edges (and is its newest version): something to repair.
  let best = -1;
  for (const robot of robots) {
    const history = await fleet.getJson(server, mapsApi(robot.robot_id));
    const current = history.versions.find((v) => v.current);
    if (current && robot.head_version === current.version && current.observation_edges > best) {
      best = current.observation_edges;
      mapRobot = robot;
    }
  }
  assert.ok(mapRobot && best >= 1, 'a robot has a current map with observation edges');
  const row = page.locator(`[data-testid=robot-row][data-robot="${mapRobot.robot_id}"]`);
  assert.match(await row.innerText(), new RegExp(`v${mapRobot.current_version}\\b`));
  await screenshot('maps');
});

test('maps: a robot\'s map history as a timeline', async () => {
  await page.click(`[data-testid=robot-row][data-robot="${mapRobot.robot_id}"] a`);
  await page.waitForFunction(() => document.querySelector('[data-testid=map-timeline]') && document.querySelector('main').dataset.state === 'ready');
  const history = await fleet.getJson(server, mapsApi(mapRobot.robot_id));
  const nodes = page.locator('[data-testid=map-timeline] [data-testid=timeline-version]');
  assert.ok(history.versions.length >= 1);
  assert.equal(await nodes.count(), history.versions.length, 'one timeline node per version');
  const withParent = history.versions.filter((v) => history.versions.some((p) => p.version === v.parent_version)).length;
  assert.equal(await page.locator('[data-testid=map-timeline] path.lineage-arrow').count(), withParent, 'one arrow per parent → child');
  assert.match(await page.locator(`[data-testid=timeline-version][data-version="${history.current_version}"]`).getAttribute('class'), /\bcurrent\b/);
  assert.equal(await page.getByTestId('version-row').count(), history.versions.length);
});

test('maps: the current version with its picture, pose graph overlay, findings and constraints', async () => {
  reviewedVersion = mapRobot.current_version;
  await page.locator(`[data-testid=timeline-version][data-version="${reviewedVersion}"] circle`).click();
  assert.equal(await waitForNewVersionPage(-1), reviewedVersion);
  assert.ok(await imageLoaded('version-map') > 0, 'the map picture loads');
  const api = `${mapsApi(mapRobot.robot_id)}/${reviewedVersion}`;
  const [graph, detail] = await Promise.all([fleet.getJson(server, `${api}/graph`), fleet.getJson(server, api)]);
  // Every edge of the home component (the one with the most nodes) is drawn, inside the picture.
  const home = graph.components.reduce((a, b) => (b.nodes > a.nodes ? b : a));
  const homeNodes = new Set(graph.nodes.filter((n) => n[4] === home.id).map((n) => n[0]));
  const homeEdges = graph.edges.filter((e) => homeNodes.has(e.from) && homeNodes.has(e.to)).length;
  const lines = page.locator('[data-testid=version-map-overlay] line');
  assert.equal(await lines.count(), homeEdges, 'the overlay draws the home component\'s edges');
  const outside = await lines.evaluateAll((all, grid) => all.filter((l) => ['x1', 'x2'].some((a) => l[a].baseVal.value < -1 || l[a].baseVal.value > grid.width + 1) ||
    ['y1', 'y2'].some((a) => l[a].baseVal.value < -1 || l[a].baseVal.value > grid.height + 1)).length, graph.grid);
  assert.equal(outside, 0, 'the graph lies on the picture (grid frame)');
  const observations = graph.edges.filter((e) => e.kind === 'observation').length;
  assert.equal(await page.getByTestId('constraint-row').count(), Math.min(100, observations));
  assert.ok(await page.getByTestId('constraint-row').count() >= 1);
  assert.equal(await page.getByTestId('finding').count(), detail.findings.length);
  if (detail.findings.some((f) => f.kind === 'high_residual_edge')) {
    assert.ok(await page.locator('[data-testid=version-map-overlay] line[data-kind=flagged]').count() > 0, 'flagged edges are drawn in red');
    assert.equal(await page.getByTestId('constraint-row').first().getAttribute('data-flagged'), 'true', 'the worst edge is flagged');
  }
  // Sorted by χ², highest first; the header flips it.
  const chi2 = await page.getByTestId('constraint-row').evaluateAll((rows) => rows.map((r) => Number(r.dataset.chi2)));
  assert.deepEqual(chi2, [...chi2].sort((a, b) => b - a));
  await page.getByTestId('sort-chi2').click();
  const ascending = await page.getByTestId('constraint-row').evaluateAll((rows) => rows.map((r) => Number(r.dataset.chi2)));
  assert.ok(ascending[0] <= ascending[ascending.length - 1]);
  await page.getByTestId('sort-chi2').click();
});

test('maps: rejecting an observation edge makes a pending, re-optimised version with one edge fewer', async () => {
  const base = (await fleet.getJson(server, `${mapsApi(mapRobot.robot_id)}/${reviewedVersion}`)).version;
  const row = page.getByTestId('constraint-row').first();
  const edge = { from: Number(await row.getAttribute('data-from')), to: Number(await row.getAttribute('data-to')), view: await row.getAttribute('data-view') };
  // No reason, no repair: the page says so and makes nothing.
  await row.getByTestId('reject-edge').click();
  await page.waitForSelector('[data-testid=repair-status][data-kind=error]');
  assert.equal((await fleet.getJson(server, mapsApi(mapRobot.robot_id))).versions.at(-1).version, reviewedVersion);
  await page.getByTestId('repair-reason').fill('browser test: the edge with the highest residual');
  await expectTokenPrompt();
  await row.getByTestId('reject-edge').click();
  repairedVersion = await waitForNewVersionPage(reviewedVersion);
  const history = await fleet.getJson(server, mapsApi(mapRobot.robot_id));
  const repaired = history.versions.at(-1);
  assert.equal(repaired.version, repairedVersion);
  assert.equal(repaired.approval, 'pending');
  assert.equal(repaired.parent_version, reviewedVersion);
  assert.equal(repaired.action, 'reject_edge');
  assert.equal(repaired.created_by, 'engineer:browser-test');
  assert.equal(repaired.edges, base.edges - 1);
  assert.equal(repaired.observation_edges, base.observation_edges - 1);
  assert.equal(history.current_version, reviewedVersion, 'robots keep the current map until review');
  const graph = await fleet.getJson(server, `${mapsApi(mapRobot.robot_id)}/${repairedVersion}/graph`);
  assert.ok(!graph.edges.some((e) => e.kind === 'observation' && e.from === edge.from && e.to === edge.to && String(e.view ?? '') === edge.view), 'the edge is gone');
  // The page: pending, one edge fewer, the new picture beside its parent's.
  assert.equal(await page.getByTestId('approval-badge').getAttribute('data-approval'), 'pending');
  assert.equal(Number(await page.locator('[data-testid=kpi-edges] [data-value]').getAttribute('data-value')), base.edges - 1);
  assert.ok(await imageLoaded('version-map') > 0, 'the re-optimised map loads');
  assert.ok(await imageLoaded('parent-map') > 0, 'the parent map loads beside it');
  await page.waitForSelector('[data-testid=repair-status][data-kind=ok]');
  await screenshot('map-version');
});

test('maps: approving the repair makes it the robot\'s current map', async () => {
  await page.getByTestId('review-approve').click();
  await page.waitForSelector('[data-testid=approval-badge][data-approval=approved]');
  await page.waitForFunction(() => document.querySelector('main').dataset.state === 'ready');
  const history = await fleet.getJson(server, mapsApi(mapRobot.robot_id));
  assert.equal(history.current_version, repairedVersion);
  assert.equal(history.versions.at(-1).approved_by, 'engineer:browser-test');
  assert.equal(await page.getByTestId('review-card').count(), 0);
});

test('maps: undoing the repair makes a pending version holding the map from before it', async () => {
  await page.getByTestId('repair-reason').fill('browser test: undo the edge rejection');
  await page.getByTestId('undo-repair').click();
  undoVersion = await waitForNewVersionPage(repairedVersion);
  const history = await fleet.getJson(server, mapsApi(mapRobot.robot_id));
  const undo = history.versions.find((v) => v.version === undoVersion);
  const before = history.versions.find((v) => v.version === reviewedVersion);
  assert.equal(undo.origin, 'undo');
  assert.equal(undo.approval, 'pending');
  assert.equal(undo.parent_version, repairedVersion);
  assert.equal(undo.snapshot_id, before.snapshot_id, 'the very map of the version before the repair');
  assert.equal(undo.edges, before.edges);
  assert.ok(await imageLoaded('version-map') > 0);
});

test('maps: export links download the version as ROS map_server PGM + YAML and as g2o', async () => {
  const [download] = await Promise.all([page.waitForEvent('download'), page.getByTestId('export-g2o').click()]);
  assert.equal(download.suggestedFilename(), `${mapRobot.robot_id}-v${undoVersion}.g2o`);
  const downloaded = fs.readFileSync(await download.path(), 'utf8');
  const version = (await fleet.getJson(server, `${mapsApi(mapRobot.robot_id)}/${undoVersion}`)).version;
  assert.equal(downloaded.split('\n').filter((l) => l.startsWith('EDGE_SE2')).length, version.edges);
  assert.equal(downloaded.split('\n').filter((l) => l.startsWith('VERTEX_SE2')).length, version.nodes);
  const fetched = async (testid) => {
    const url = new URL(await page.getByTestId(testid).getAttribute('href'), server.http);
    assert.equal((await fetch(url)).status, 401, `${testid} without a token`);
    const response = await fetch(url, { headers: { Authorization: `Bearer ${engineerToken}` } });
    assert.equal(response.status, 200, testid);
    return Buffer.from(await response.arrayBuffer());
  };
  assert.equal((await fetched('export-g2o')).toString(), downloaded);
  assert.match((await fetched('export-yaml')).toString(), new RegExp(`^image: ${mapRobot.robot_id}-v${undoVersion}\\.pgm`, 'm'));
  assert.equal((await fetched('export-pgm')).subarray(0, 2).toString(), 'P5');
});

test('maps: a repair of a version that is no longer the newest says so in the page', async () => {
  // Another engineer rolls the map back meanwhile; this page still shows the undo version.
  const meanwhile = await fetch(`${server.http}${mapsApi(mapRobot.robot_id)}/${undoVersion}/repair`, {
    method: 'POST', headers: { Authorization: `Bearer ${engineerToken}` }, body: JSON.stringify({ action: 'undo', reason: 'another engineer' }) });
  assert.equal(meanwhile.status, 200);
  const newest = (await meanwhile.json()).version.version;
  await page.getByTestId('repair-reason').fill('browser test: stale page');
  await page.getByTestId('constraint-row').first().getByTestId('reject-edge').click();
  const status = page.locator('[data-testid=repair-status][data-kind=error]');
  await status.waitFor();
  assert.match(await status.innerText(), new RegExp(`v${newest} .*is the newest version now`));
  assert.equal(await page.getByTestId('open-newest').getAttribute('href'), `#/robots/${mapRobot.robot_id}/maps/${newest}`);
  assert.equal((await fleet.getJson(server, mapsApi(mapRobot.robot_id))).versions.at(-1).version, newest, 'nothing was made');
});

test('maps: the timeline shows the repair loop', async () => {
  assert.equal(await visit(`/robots/${encodeURIComponent(mapRobot.robot_id)}/maps`), 'ready');
  const history = await fleet.getJson(server, mapsApi(mapRobot.robot_id));
  const node = (version) => page.locator(`[data-testid=timeline-version][data-version="${version}"]`);
  assert.equal(await page.getByTestId('timeline-version').count(), history.versions.length);
  assert.match(await node(repairedVersion).getAttribute('class'), /\bcurrent\b/);
  assert.equal(await node(undoVersion).getAttribute('data-approval'), 'pending');
  assert.equal(await page.locator(`path.lineage-arrow[data-from="${reviewedVersion}"][data-to="${repairedVersion}"]`).count(), 1);
  assert.equal(await page.locator(`path.lineage-arrow[data-from="${repairedVersion}"][data-to="${undoVersion}"]`).count(), 1);
  await screenshot('map-history');
});

test('maps: two Valetudo exports of one real home uploaded on its map page become versions, the second compared with the first', async () => {
  const home = 'valetudo-d9-1058';
  let previous = -1;
  for (const [index, file] of ['dreame_d9_1058_no_segments.json', 'dreame_d9_1058_with_segments.json'].entries()) {
    await visit(`/robots/${home}/maps`);
    await page.getByTestId('import-file').setInputFiles(path.join(fleet.env.valetudo, file));
    await page.getByTestId('import-button').click();
    previous = await waitForNewVersionPage(previous);
    assert.equal(previous, index + 1, `${file} is version ${index + 1}`);
  }
  // The second version lists what changed against the first: the alignment and the new room among the regions.
  const detail = await fleet.getJson(server, `${mapsApi(home)}/2`);
  assert.equal(detail.version.approval, 'pending', 'an upload waits for review');
  const kinds = detail.findings.map((f) => f.kind);
  assert.ok(kinds.includes('alignment'), `the alignment is reported (${kinds})`);
  assert.ok(kinds.filter((k) => k === 'new_region').length >= 1, 'new regions are listed');
  assert.equal(await page.getByTestId('finding').count(), detail.findings.length, 'every finding is on the page');
  assert.ok(await imageLoaded('version-map') > 0, 'the imported map is drawn');
  await screenshot('map-import');
  // A file that is no ValetudoMap export is refused with the reason, and nothing is added.
  await visit(`/robots/${home}/maps`);
  await page.getByTestId('import-file').setInputFiles({ name: 'notes.json', mimeType: 'application/json', buffer: Buffer.from('{"hello": 1}') });
  await page.getByTestId('import-button').click();
  await page.waitForFunction(() => /not imported/.test(document.querySelector('[data-testid=import-status]').textContent));
  assert.equal((await fleet.getJson(server, mapsApi(home))).versions.length, 2);
});

test('maps: a Valetudo export\'s rooms, zones, virtual walls and path are kept with its version, drawn and handed back', async () => {
  const home = 'valetudo-viomi';
  await visit(`/robots/${home}/maps`);
  await page.getByTestId('import-file').setInputFiles(path.join(fleet.env.valetudo, '3irobotix_viomi_v6_41_virtual_restrictions_and_active_zones.json'));
  await page.getByTestId('import-button').click();
  assert.equal(await waitForNewVersionPage(-1), 1);
  const detail = await fleet.getJson(server, `${mapsApi(home)}/1`);
  assert.deepEqual(detail.metadata.rooms.map((r) => r.name), ['room1', 'room2']);
  assert.equal(detail.metadata.zones.length, 4);
  assert.equal(detail.metadata.virtual_walls.length, 2);
  await page.waitForFunction(() => document.querySelectorAll('[data-testid=room-label]').length === 2);
  assert.deepEqual(await page.getByTestId('room-label').allTextContents(), ['room1', 'room2']);
  assert.equal(await page.getByTestId('zone').count(), 4);
  assert.equal(await page.getByTestId('virtual-wall').count(), 2);
  assert.equal(await page.getByTestId('robot-path').count(), 1);
  assert.equal(await page.locator('[data-testid=map-point][data-type=charger_location]').count(), 1);
  assert.equal(await page.getByTestId('room').count(), 2, 'the rooms are listed beside the picture');
  assert.ok(await imageLoaded('version-map') > 0, 'the imported map is drawn');
  await page.getByTestId('version-map-overlay').scrollIntoViewIfNeeded();
  await screenshot('map-metadata');
  // The hand-back gives the Valetudo user the rooms and zones back.
  const handBack = await fetch(`${server.http}${mapsApi(home)}/1/export/map.json`, { headers: { Authorization: `Bearer ${engineerToken}` } });
  assert.equal(handBack.status, 200);
  const json = await handBack.json();
  assert.deepEqual(json.layers.filter((l) => l.type === 'segment').map((l) => l.metaData.name), ['room1', 'room2']);
  assert.equal(json.entities.filter((e) => e.type === 'no_go_area').length, 2);
  assert.equal(json.entities.filter((e) => e.type === 'virtual_wall').length, 2);
  // Absurd metadata is refused naming the field, and nothing is stored.
  const viomi = JSON.parse(fs.readFileSync(path.join(fleet.env.valetudo, '3irobotix_viomi_v6_41_virtual_restrictions_and_active_zones.json'), 'utf8'));
  const zone = viomi.entities.find((e) => e.type === 'no_go_area');
  const post = (body) => fetch(`${server.http}${mapsApi(home)}/import`, { method: 'POST', body: JSON.stringify(body),
    headers: { Authorization: `Bearer ${engineerToken}`, 'Content-Type': 'application/json' } });
  let refused = await post({ ...viomi, entities: [...viomi.entities, ...Array(1500).fill(zone)] });
  assert.equal(refused.status, 400);
  assert.match((await refused.json()).error, /metadata\.zones: 1504 shapes, more than the limit 1000/);
  const named = structuredClone(viomi);
  named.layers.find((l) => l.type === 'segment').metaData.name = 'x'.repeat(5000);
  refused = await post(named);
  assert.equal(refused.status, 400);
  assert.match((await refused.json()).error, /metadata\.rooms\[0\]\.name: 5000 bytes/);
  assert.equal((await fleet.getJson(server, mapsApi(home))).versions.length, 1);
});

test('maps: two map_server saves of one home uploaded on its map page (YAML + image) become versions, the second compared with the first', async () => {
  const home = 'ros-home';
  let previous = -1;
  for (const [index, stem] of ['valetudo_dreame_d9_1058_no_segments', 'valetudo_dreame_d9_1058_with_segments'].entries()) {
    await visit(`/robots/${home}/maps`);
    await page.getByTestId('import-file').setInputFiles([path.join(fleet.env.maps, `${stem}.yaml`), path.join(fleet.env.maps, `${stem}.pgm`)]);
    await page.getByTestId('import-button').click();
    previous = await waitForNewVersionPage(previous);
    assert.equal(previous, index + 1, `${stem} is version ${index + 1}`);
  }
  const detail = await fleet.getJson(server, `${mapsApi(home)}/2`);
  assert.equal(detail.version.approval, 'pending');
  assert.match(detail.version.action_detail, /valetudo_dreame_d9_1058_with_segments\.yaml \+ valetudo_dreame_d9_1058_with_segments\.pgm/);
  const kinds = detail.findings.map((f) => f.kind);
  assert.ok(kinds.includes('alignment') || kinds.includes('misaligned'), `compared with version 1 (${kinds})`);
  assert.ok(kinds.includes('new_region'), `the new room is a new region (${kinds})`);
  assert.equal(await page.getByTestId('finding').count(), detail.findings.length, 'every finding is on the page');
  assert.ok(await imageLoaded('version-map') > 0, 'the uploaded map is drawn');
  await screenshot('map-server-import');
  // A YAML naming a file outside the upload, and a PGM that is not one, are refused naming why; nothing is added.
  const yaml = fs.readFileSync(path.join(fleet.env.maps, 'valetudo_dreame_d9_1058_no_segments.yaml'), 'utf8');
  const pgm = fs.readFileSync(path.join(fleet.env.maps, 'valetudo_dreame_d9_1058_no_segments.pgm'));
  for (const [files, why] of [
    [[{ name: 'map.yaml', mimeType: 'text/yaml', buffer: Buffer.from(yaml.replace(/^image: .*$/m, 'image: ../../../etc/passwd')) },
      { name: 'valetudo_dreame_d9_1058_no_segments.pgm', mimeType: 'image/x-portable-graymap', buffer: pgm }], /outside the upload/],
    [[{ name: 'map.yaml', mimeType: 'text/yaml', buffer: Buffer.from(yaml.replace(/^image: .*$/m, 'image: broken.pgm')) },
      { name: 'broken.pgm', mimeType: 'image/x-portable-graymap', buffer: Buffer.from('P5\n4000 4000\n255\n\x00\x01') }], /truncated/]]) {
    await visit(`/robots/${home}/maps`);
    await page.getByTestId('import-file').setInputFiles(files);
    await page.getByTestId('import-button').click();
    await page.waitForFunction(() => /not imported/.test(document.querySelector('[data-testid=import-status]').textContent));
    assert.match(await page.getByTestId('import-status').innerText(), why);
  }
  assert.equal((await fleet.getJson(server, mapsApi(home))).versions.length, 2);
});

test('maps: the robots page lists only the robots waiting for review when asked, a page at a time', async () => {
  const { robots, total } = await fleet.getJson(server, '/api/robots');
  assert.equal(total, robots.length);
  const waiting = robots.filter((r) => r.pending > 0).map((r) => r.robot_id);
  assert.ok(waiting.length >= 1, 'the repairs above left a version waiting for review');
  assert.equal(await visit('/maps?pending=1'), 'ready');
  assert.ok(await page.getByTestId('pending-only').isChecked());
  const rows = await page.getByTestId('robot-row').evaluateAll((all) => all.map((r) => r.dataset.robot));
  assert.deepEqual(rows, waiting);
  await page.getByTestId('pending-only').uncheck();
  await page.waitForFunction((n) => document.querySelector('main').dataset.state === 'ready' &&
    document.querySelectorAll('[data-testid=robot-row]').length === n, robots.length);
  // One robot per page: the pager walks the fleet in robot-id order.
  const first = await fleet.getJson(server, '/api/robots?limit=1');
  assert.equal(first.robots.length, 1);
  assert.equal(first.next.after, robots[0].robot_id);
});

test('error states: a missing run and an unknown endpoint', async () => {
  assert.equal(await visit('/runs/no-such-run'), 'error');
  assert.match(await page.getByTestId('error-state').innerText(), /HTTP 404/);
  const unknown = await fetch(`${server.http}/api/nope`, { headers: { Authorization: `Bearer ${engineerToken}` } });
  assert.equal(unknown.status, 404);
  const traversal = await fetch(`${server.http}/static/%2e%2e/%2e%2e/CMakeLists.txt`, { headers: { Authorization: `Bearer ${engineerToken}` } });
  assert.equal(traversal.status, 404);
});

test('no browser console errors', () => {
  // 404s come from the error-state subtest, the 409 from the stale-repair one: both on purpose.
  // The 401s come from the sign-in subtests, the 400 from the refused upload, on purpose too.
  assert.deepEqual(consoleErrors.filter((e) => !/404|Not Found|409 \(Conflict\)|401 \(Unauthorized\)|400 \(Bad Request\)/.test(e)), []);
});
