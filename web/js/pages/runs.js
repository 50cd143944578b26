// Runs: keyset-paginated (the cursor is the last run of the page), filtered like the overview.
import { getJson } from '../api.js';
import { go, h, noRuns, num, setState, time } from '../ui.js';
import { apiFilter, filterBar } from './filters.js';

export async function render(main, { query, isCurrent }) {
  const { form, meta } = await filterBar(query, (values) => { go(`#/runs?${values}`); });
  const filter = apiFilter(query, meta);
  const page = await getJson('/api/runs', { ...filter, limit: 25, after_ms: query.get('after_ms'), after_id: query.get('after_id'), after_robot: query.get('after_robot') });
  if (!isCurrent()) return;
  main.append(h('h1', {}, 'Runs'), form);
  if (page.runs.length === 0) {
    main.append(query.get('after_ms') ? h('div', { class: 'empty', 'data-testid': 'empty-state' }, 'No more runs.') : noRuns());
    setState(main, 'empty');
    return;
  }
  const rows = page.runs.map((run) => {
    const r = run.report;
    return h('tr', { class: 'clickable', 'data-testid': 'run-row', onclick: () => { go(`#/runs/${encodeURIComponent(run.run_id)}?parameter_set=${page.parameter_set}&robot=${encodeURIComponent(run.robot_id)}`); } },
      h('td', {}, h('a', { href: `#/runs/${encodeURIComponent(run.run_id)}?parameter_set=${page.parameter_set}&robot=${encodeURIComponent(run.robot_id)}` }, run.run_id)),
      h('td', {}, run.robot_id), h('td', {}, run.firmware), h('td', {}, time(run.started_at_ms)),
      h('td', {}, run.parent_snapshot_id ? 'yes' : 'first run'),
      r ? [h('td', { class: 'num' }, num(r.recovery_created)), h('td', { class: 'num' }, num(r.recovery_accepted)),
        h('td', { class: 'num' }, `${num(r.merge_conditionally_accepted)} / ${num(r.merge_conditional_then_rejected)}`),
        h('td', {}, r.started_localized ? 'yes' : 'no'),
        h('td', { class: 'num' }, `${num(r.views_ambiguous)} / ${num(r.views_total)}`)]
        : h('td', { colspan: 5, class: 'muted' }, 'analysis pending'),
      h('td', { class: 'num' }, `${num(run.regions)}${run.regions_labelled ? ` (${run.regions_labelled} labelled)` : ''}`));
  });
  main.append(h('section', { class: 'card' }, h('table', { 'data-testid': 'runs-table' },
    h('tr', {}, ['run', 'robot', 'firmware', 'started (UTC)', 'parent map', 'recovery hyp.', 'accepted',
      'merges cond. / cond.→rejected', 'started localized', 'ambiguous views', 'regions'].map((t) => h('th', {}, t))),
    rows)));
  const next = new URLSearchParams(query);
  const pager = h('div', { class: 'pager' });
  if (query.get('after_ms')) {
    const first = new URLSearchParams(query); first.delete('after_ms'); first.delete('after_id'); first.delete('after_robot');
    pager.append(h('button', { class: 'secondary', onclick: () => { go(`#/runs?${first}`); } }, '⟨ First page'));
  }
  if (page.next) {
    next.set('after_ms', page.next.after_ms); next.set('after_id', page.next.after_id); next.set('after_robot', page.next.after_robot);
    pager.append(h('button', { 'data-testid': 'next-page', onclick: () => { go(`#/runs?${next}`); } }, 'Next page ⟩'));
  }
  pager.append(h('span', { class: 'muted' }, `${page.runs.length} runs on this page, ordered by start time (keyset pagination)`));
  main.append(pager);
  setState(main, 'ready');
}
