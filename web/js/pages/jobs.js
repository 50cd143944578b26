// Jobs: reprocessing jobs (a parameter set over stored runs) with live progress, polled every second while
// any is queued or running. Jobs are started with `StartJob` on the gRPC API (fleetctl / engineers).
import { getJson } from '../api.js';
import { card, emptyState, h, num, setState, time } from '../ui.js';

let timer = null;
export function stop() { clearTimeout(timer); timer = null; }

export async function render(main, { isCurrent }) {
  main.append(h('h1', {}, 'Jobs'));
  const body = h('div', {});
  main.append(body);
  const refresh = async () => {
    let data;
    try {
      data = await getJson('/api/jobs', { limit: 50 });
    } catch (error) {
      if (!isCurrent()) return;
      body.replaceChildren(h('div', { class: 'error', 'data-testid': 'error-state' }, `Could not load jobs: ${error.message} — retrying`));
      setState(main, 'error');
      timer = setTimeout(refresh, 3000);
      return;
    }
    if (!isCurrent()) return;
    const analyses = Object.entries(data.upload_analyses).map(([state, n]) => `${n} ${state}`).join(', ') || 'none';
    const summary = h('p', { class: 'muted' }, `Upload analyses: ${analyses}. Reprocessing jobs, newest first:`);
    if (data.jobs.length === 0) {
      body.replaceChildren(summary, emptyState('No reprocessing jobs yet.', 'Start one with the gRPC API: Reprocessing.StartJob {parameter_set, filter} (engineer token).'));
      setState(main, 'empty');
    } else {
      body.replaceChildren(summary, card('Reprocessing jobs', h('table', { 'data-testid': 'jobs-table' },
        h('tr', {}, ['job', 'parameter set', 'state', 'progress', '', 'attempts', 'created (UTC)', 'updated', 'error'].map((t) => h('th', {}, t))),
        data.jobs.map((job) => {
          const fraction = job.progress_total > 0 ? job.progress_done / job.progress_total : job.state === 'done' ? 1 : 0;
          return h('tr', { 'data-testid': 'job-row', 'data-job': job.job_id, 'data-state': job.state, 'data-done': job.progress_done, 'data-total': job.progress_total },
            h('td', {}, `#${job.job_id}`), h('td', {}, job.parameter_set || ''), h('td', {}, h('span', { class: `badge ${job.state}` }, job.state)),
            h('td', {}, h('div', { class: 'progress', title: `${Math.round(100 * fraction)} %` }, h('div', { style: `width:${(100 * fraction).toFixed(1)}%` }))),
            h('td', { class: 'num' }, `${num(job.progress_done)} / ${num(job.progress_total)}`), h('td', { class: 'num' }, `${job.attempts}/${job.max_attempts}`),
            h('td', {}, time(job.created_at_ms)), h('td', {}, time(job.updated_at_ms)), h('td', { class: 'muted' }, job.last_error || ''));
        }))));
      setState(main, 'ready');
    }
    const active = data.jobs.some((j) => j.state === 'queued' || j.state === 'leased');
    timer = setTimeout(refresh, active ? 1000 : 5000);
  };
  await refresh();
}
