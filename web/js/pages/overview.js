// Fleet overview: the paper's figures (Fig. 6, 7, 8, 12) for the chosen time range, firmware and parameter
// set, with trends by day and by firmware. Everything is aggregated by the database (/api/stats).
import { ApiError, getJson } from '../api.js';
import * as charts from '../charts.js';
import { card, go, h, kpi, noRuns, num, pct, setState } from '../ui.js';
import { apiFilter, filterBar } from './filters.js';

export async function render(main, { query, isCurrent }) {
  const { form, meta } = await filterBar(query, (values) => { go(`#/overview?${values}`); });
  const stats = await getJson('/api/stats', apiFilter(query, meta));
  if (!isCurrent()) return;
  const t = stats.total;
  main.append(h('h1', {}, 'Fleet overview'), form);
  if (t.reports === 0) {
    main.append(noRuns());
    setState(main, 'empty');
    return;
  }
  main.append(h('div', { class: 'kpis' },
    kpi('runs analysed', num(t.reports), 'kpi-runs'),
    kpi('robots', num(t.robots), 'kpi-robots'),
    kpi('recovery hypotheses / run (Fig. 6)', num(t.recovery_per_run), 'kpi-recovery'),
    kpi('recovery hypotheses accepted (Fig. 6)', pct(t.recovery_accepted_share), 'kpi-recovery-accepted'),
    kpi('accepted recoveries later retracted', `${num(t.recovery_retracted)} (${pct(t.recovery_retracted_share)})`, 'kpi-retracted'),
    kpi('runs started localized (Fig. 7)', pct(t.started_localized_share), 'kpi-localized'),
    kpi('merges conditional → rejected (Fig. 7)', pct(t.merge_conditional_then_rejected_share), 'kpi-merge'),
    kpi('maps with ambiguous views (Fig. 8)', pct(stats.maps.share_with_ambiguous_views), 'kpi-ambiguous-maps'),
    kpi('ambiguous share of views (Fig. 8)', pct(t.ambiguous_view_share), 'kpi-ambiguous-views'),
    kpi('protrusions found (Fig. 12)', num(t.protrusions_found), 'kpi-protrusions')));

  const canvas = (id) => h('div', { class: 'chart' }, h('canvas', { 'data-testid': id }));
  const fig6 = canvas('chart-fig6'), fig7 = canvas('chart-fig7'), fig8 = canvas('chart-fig8'), fig12 = canvas('chart-fig12');
  const dayRates = canvas('chart-trend-day'), dayRuns = canvas('chart-runs-day'), fwRates = canvas('chart-trend-firmware');
  const c = stats.confusion;
  const cell = (value, good) => h('td', { style: `background:${good ? '#def3e6' : '#fbe3e2'}` }, num(value));
  const confusion = h('table', { class: 'confusion', 'data-testid': 'confusion-matrix' },
    h('tr', {}, h('th', {}, 'label ↓ / predicted →'), h('th', {}, 'protrusion'), h('th', {}, 'new space')),
    h('tr', {}, h('th', {}, 'protrusion'), cell(c.true_positive, true), cell(c.false_negative, false)),
    h('tr', {}, h('th', {}, 'new space'), cell(c.false_positive, false), cell(c.true_negative, true)));
  main.append(h('div', { class: 'grid' },
    card('Fig. 6 — recovery hypotheses: created vs accepted, by firmware', fig6),
    card('Fig. 7 — relocalization: started localized; merges conditionally accepted then rejected', fig7),
    card('Fig. 8 — maps by share of ambiguous views', fig8,
      h('p', { class: 'muted' }, `${num(stats.maps.maps_with_ambiguous_views)} of ${num(stats.maps.maps)} robot maps hold ambiguous views (${pct(stats.maps.share_with_ambiguous_views)}).`)),
    card('Fig. 12 — protrusions found per run by firmware; the classifier against labels', fig12, confusion,
      h('p', { class: 'muted' }, `${num(c.labelled)} labelled regions (${num(c.unclassified)} unclassified): recall ${pct(c.recall)}, precision ${pct(c.precision)}, false-positive rate ${pct(c.false_positive_rate)}.`)),
    card('Trends by day', dayRates),
    card('Runs and protrusions by day', dayRuns),
    card('By firmware', fwRates)));
  await lifelongCard(main, canvas);

  const fw = stats.by_firmware, days = stats.by_day;
  charts.bar(fig6.firstChild, fw.map((g) => g.key), [
    { label: 'recovery hypotheses / run', data: fw.map((g) => g.recovery_per_run) },
    { label: 'accepted / run', data: fw.map((g) => (g.reports ? g.recovery_accepted / g.reports : null)) }]);
  charts.bar(fig7.firstChild, ['started localized', 'merge: conditional → rejected', 'merge conditionally accepted'], [
    { label: stats.parameter_set, data: [t.started_localized_share, t.merge_conditional_then_rejected_share,
      t.merge_created ? t.merge_conditionally_accepted / t.merge_created : null] }], { percent: true });
  charts.bar(fig8.firstChild, stats.maps.ambiguous_share_histogram.map((_, i) => `${i * 10}–${i * 10 + 10} %`),
    [{ label: 'maps', data: stats.maps.ambiguous_share_histogram }]);
  charts.bar(fig12.firstChild, fw.map((g) => g.key), [
    { label: 'protrusions found / run', data: fw.map((g) => g.protrusions_per_run) }]);
  charts.line(dayRates.firstChild, days.map((g) => g.key), [
    { label: 'recovery accepted', data: days.map((g) => g.recovery_accepted_share) },
    { label: 'started localized', data: days.map((g) => g.started_localized_share) },
    { label: 'merge cond. → rejected', data: days.map((g) => g.merge_conditional_then_rejected_share) },
    { label: 'ambiguous views', data: days.map((g) => g.ambiguous_view_share) }], { percent: true });
  charts.bar(dayRuns.firstChild, days.map((g) => g.key), [
    { label: 'runs', data: days.map((g) => g.reports) },
    { label: 'protrusions', data: days.map((g) => g.protrusions_found) }]);
  charts.bar(fwRates.firstChild, fw.map((g) => g.key), [
    { label: 'recovery accepted', data: fw.map((g) => g.recovery_accepted_share) },
    { label: 'started localized', data: fw.map((g) => g.started_localized_share) },
    { label: 'merge cond. → rejected', data: fw.map((g) => g.merge_conditional_then_rejected_share) },
    { label: 'ambiguous views', data: fw.map((g) => g.ambiguous_view_share) }], { percent: true });
  setState(main, 'ready');
}

/// The lifelong experiment (fleetsim --lifelong, served by fleetd --lifelong-results): the share of robots
/// whose map is corrupted after each run, per regime. Nothing is drawn when fleetd has no results.
async function lifelongCard(main, canvas) {
  let life;
  try {
    life = await getJson('/api/lifelong');
  } catch (e) {
    if (e instanceof ApiError && e.status === 404) return;
    throw e;
  }
  const names = Object.keys(life.regimes);
  const chart = canvas('chart-lifelong');
  const rows = names.map((name) => {
    const r = life.regimes[name];
    return h('tr', { 'data-testid': `lifelong-row-${name}` }, h('td', {}, name), h('td', {}, pct(r.corrupted_share)),
      h('td', {}, num(r.robots_ever_corrupted)), h('td', {}, num(r.mean_runs_to_corruption)), h('td', {}, num(r.runs_lost)),
      h('td', {}, num(r.repairs_taken)));
  });
  const table = h('table', { class: 'lifelong', 'data-testid': 'lifelong-table' },
    h('tr', {}, ...['regime', 'corrupted after the last run', 'ever corrupted', 'mean runs to corruption', 'runs lost', 'repairs taken'].map((t) => h('th', {}, t))),
    ...rows);
  main.append(h('div', { class: 'grid' }, card(`Lifelong maps — share of robots whose map is corrupted, by run (${life.robots} robots × ${life.runs} runs, seed ${life.seed})`,
    chart, table, h('p', { class: 'muted' }, `Corrupted: trajectory RMSE over ${life.threshold.trajectory_rmse_m} m or false free area over ${life.threshold.false_free_m2} m² against the simulator's ground truth (docs/fleetsim.md).`))));
  const runs = life.regimes[names[0]].corrupted_by_run.map((_, k) => String(k + 1));
  charts.line(chart.firstChild, runs, names.map((name) => ({ label: name, data: life.regimes[name].corrupted_by_run })), { percent: true });
}
