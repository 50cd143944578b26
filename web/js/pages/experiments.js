// Experiments: two parameter sets side by side over the same runs: fleet-wide figures and their deltas,
// by firmware, and the runs whose reports changed most.
import { getJson } from '../api.js';
import * as charts from '../charts.js';
import { card, emptyState, go, h, num, pct, setState } from '../ui.js';
import { apiFilter } from './filters.js';

const figures = [
  ['recovery_per_run', 'recovery hypotheses / run (Fig. 6)', num],
  ['recovery_accepted_share', 'recovery accepted (Fig. 6)', pct],
  ['started_localized_share', 'started localized (Fig. 7)', pct],
  ['merge_conditional_then_rejected_share', 'merge cond. → rejected (Fig. 7)', pct],
  ['ambiguous_view_share', 'ambiguous views (Fig. 8)', pct],
  ['protrusions_per_run', 'protrusions / run (Fig. 12)', num],
];

export async function render(main, { query, isCurrent }) {
  const meta = await getJson('/api/meta');
  const sets = meta.parameter_sets;
  const a = query.get('a') || meta.default_parameter_set;
  const b = query.get('b') || sets.find((s) => s !== a) || a;
  const select = (name, value) => h('label', {}, name === 'a' ? 'Baseline (A)' : 'Candidate (B)',
    h('select', { name, 'data-testid': `set-${name}` }, sets.map((s) => h('option', { value: s, selected: s === value }, s))));
  const form = h('form', { class: 'filters' }, select('a', a), select('b', b),
    h('label', {}, 'Firmware', h('select', { name: 'firmware' }, h('option', { value: '' }, 'all'),
      meta.firmware.map((f) => h('option', { value: f, selected: f === query.get('firmware') }, f)))),
    h('button', { type: 'submit' }, 'Compare'));
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    const values = new URLSearchParams();
    for (const el of form.querySelectorAll('[name]')) if (el.value) values.set(el.name, el.value);
    go(`#/experiments?${values}`);
  });
  main.append(h('h1', {}, 'Experiments'), form);
  if (sets.length < 2 || a === b) {
    main.append(emptyState('Pick two different parameter sets.', sets.length < 2
      ? 'Only one parameter set is stored: store another (Reprocessing.PutParameterSet) and reprocess runs with it (Reprocessing.StartJob).' : ''));
    setState(main, 'empty');
    return;
  }
  const filter = apiFilter(query, meta);
  delete filter.parameter_set;
  const cmp = await getJson('/api/compare', { ...filter, a, b, limit: 15 });
  if (!isCurrent()) return;
  if (cmp.stats_b.reports === 0) {
    main.append(emptyState(`No runs are analysed with "${b}" yet.`, 'Reprocess stored runs with it (Reprocessing.StartJob); progress shows on the Jobs page.'));
    setState(main, 'empty');
    return;
  }
  const delta = (key, fmt) => {
    const x = cmp.stats_a[key], y = cmp.stats_b[key];
    if (x === null || y === null) return h('td', { class: 'num' }, '—');
    const d = y - x;
    return h('td', { class: `num delta ${d > 0 ? 'up' : d < 0 ? 'down' : ''}` }, `${d > 0 ? '+' : ''}${fmt === pct ? `${(100 * d).toFixed(1)} pp` : d.toFixed(2)}`);
  };
  const chart = h('div', { class: 'chart' }, h('canvas', { 'data-testid': 'chart-compare' }));
  main.append(h('div', { class: 'row' },
    card(`Fleet-wide: ${a} vs ${b} (${num(cmp.stats_a.reports)} / ${num(cmp.stats_b.reports)} runs)`,
      h('table', { 'data-testid': 'compare-table' }, h('tr', {}, h('th', {}, 'figure'), h('th', { class: 'num' }, a), h('th', { class: 'num' }, b), h('th', { class: 'num' }, 'Δ (B − A)')),
        figures.map(([key, label, fmt]) => h('tr', {}, h('td', {}, label), h('td', { class: 'num' }, fmt(cmp.stats_a[key])), h('td', { class: 'num' }, fmt(cmp.stats_b[key])), delta(key, fmt))))),
    card('Shares side by side', chart)));
  const shareFigures = figures.filter(([, , fmt]) => fmt === pct);
  charts.bar(chart.firstChild, shareFigures.map(([, label]) => label.replace(/ \(Fig.*/, '')), [
    { label: a, data: shareFigures.map(([key]) => cmp.stats_a[key]) },
    { label: b, data: shareFigures.map(([key]) => cmp.stats_b[key]) }], { percent: true });
  const keys = ['recovery_accepted', 'merge_conditionally_accepted', 'merge_conditional_then_rejected', 'views_ambiguous', 'protrusions_found'];
  main.append(card(`Runs that changed most (${num(cmp.runs_changed)} of ${num(cmp.runs_compared)} compared runs changed${cmp.scan_truncated ? `; first ${num(cmp.runs_scanned)} runs scanned` : ''})`,
    cmp.changed_most.length === 0 ? h('p', { class: 'muted' }, 'No run has reports under both sets.') :
      h('table', { 'data-testid': 'changed-runs' }, h('tr', {}, h('th', {}, 'run'), h('th', {}, 'firmware'), h('th', { class: 'num' }, 'score'),
        keys.map((k) => h('th', { class: 'num' }, `Δ ${k.replace(/_/g, ' ')}`)), h('th', {}, 'localized A → B')),
      cmp.changed_most.map((r) => h('tr', { 'data-testid': 'changed-run' },
        h('td', {}, h('a', { href: `#/runs/${encodeURIComponent(r.run_id)}?parameter_set=${b}&robot=${encodeURIComponent(r.robot_id)}` }, r.run_id)), h('td', {}, r.firmware),
        h('td', { class: 'num' }, num(r.score, 0)), keys.map((k) => h('td', { class: 'num' }, `${r.delta[k] > 0 ? '+' : ''}${r.delta[k]}`)),
        h('td', {}, `${r.a.started_localized ? 'yes' : 'no'} → ${r.b.started_localized ? 'yes' : 'no'}`))))));
  setState(main, 'ready');
}
