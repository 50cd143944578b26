// Labelling: click a region on the map, label it protrusion or new space; labels are stored with the
// region (POST /api/runs/<id>/regions/<region>/label, engineer token) and feed classifier training.
import { ApiError, askToken, getJson, getToken, postJson, setToken } from '../api.js';
import { card, emptyState, go, h, num, setState, time } from '../ui.js';
import { decidedByText, mapView, regionClass } from '../mapview.js';

export async function render(main, { query, isCurrent }) {
  const meta = await getJson('/api/meta');
  const set = query.get('parameter_set') || meta.default_parameter_set;
  const queue = await getJson('/api/runs', { parameter_set: set, with_regions: 1, limit: 20, after_ms: query.get('after_ms'), after_id: query.get('after_id'), after_robot: query.get('after_robot') });
  const labelled = await getJson('/api/labels', { parameter_set: set, limit: 100 });
  if (!isCurrent()) return;
  main.append(h('h1', {}, 'Labelling'),
    h('p', { class: 'muted' }, `Regions the detector found between parent and child maps (parameter set ${set}). Click a region, then label it. Labels train the protrusion classifier.`));
  const runId = query.get('run') || (queue.runs[0] && queue.runs[0].run_id);
  // Run ids are per robot: the robot picks the run when robots share an id.
  const robot = query.get('robot') || (!query.get('run') && queue.runs[0] ? queue.runs[0].robot_id : '');
  if (!runId) {
    main.append(emptyState('No regions to label yet.', 'Regions appear when a run adds space to its parent map; upload more runs with fleetsim --upload …'));
    main.append(labelledList(labelled));
    setState(main, 'empty');
    return;
  }
  const layout = h('div', { class: 'row' });
  const left = card(`Run ${runId}`), right = h('div', {});
  layout.append(left, right);
  main.append(layout);

  const detail = await getJson(`/api/runs/${encodeURIComponent(runId)}`, { parameter_set: set, robot });
  const runRobot = encodeURIComponent(detail.run.robot_id);
  const info = await getJson(`/api/runs/${encodeURIComponent(runId)}/map/info.json`, { parameter_set: set, robot: detail.run.robot_id });
  if (!isCurrent()) return;
  let selected = query.has('region') ? Number(query.get('region')) : (detail.regions.find((g) => !g.label) || detail.regions[0] || {}).region_id;
  const mapHolder = h('div', {});
  const panel = card('Region');
  const status = h('p', { 'data-testid': 'label-status', class: 'muted' });

  const draw = () => {
    mapHolder.replaceChildren(mapView(`/api/runs/${encodeURIComponent(runId)}/map/difference.png?parameter_set=${encodeURIComponent(set)}&robot=${runRobot}`, info, detail.regions,
      { testid: 'label-map', selected, onRegionClick: (region) => { selected = region.region_id; draw(); } }));
    const region = detail.regions.find((g) => g.region_id === selected);
    panel.replaceChildren(h('h2', {}, region ? `Region ${region.region_id}` : 'Click a region'));
    if (region) {
      panel.append(h('p', {}, 'class: ', h('span', { class: `badge ${region.predicted_class}` }, region.predicted_class),
        region.probability >= 0 ? ` (p = ${num(region.probability)})` : '', ` · decided by ${decidedByText(region)} · label: `,
        h('span', { class: `badge ${region.label || ''}`, 'data-testid': 'current-label' }, region.label || 'none')),
        h('div', { class: 'pager' },
          h('button', { 'data-testid': 'label-protrusion', style: 'background:#d64541;border-color:#d64541', onclick: () => label(region, 'protrusion') }, 'Protrusion'),
          h('button', { 'data-testid': 'label-new-space', style: 'background:#2e9d5b;border-color:#2e9d5b', onclick: () => label(region, 'new_space') }, 'New space')),
        status,
        h('table', {}, Object.entries(region.features).map(([k, v]) => h('tr', {}, h('td', {}, k), h('td', { class: 'num' }, num(v))))));
    }
  };

  async function label(region, value) {
    let token = getToken() || askToken('Labelling needs an engineer token.');
    if (!token) { status.textContent = 'Not labelled: no token given.'; return; }
    status.textContent = 'Saving…';
    try {
      const updated = await postJson(`/api/runs/${encodeURIComponent(runId)}/regions/${region.region_id}/label?robot=${runRobot}`, { label: value, parameter_set: set }, token);
      Object.assign(region, updated);
      status.textContent = `Saved: region ${region.region_id} is ${updated.label} (by ${updated.labelled_by}).`;
      status.dataset.saved = updated.label;
      const next = detail.regions.find((g) => !g.label);
      draw();
      if (next) status.append(' Next unlabelled: region ', String(next.region_id), '.');
      const list = await getJson('/api/labels', { parameter_set: set, limit: 100 });
      right.replaceChildren(panel, labelledList(list));
    } catch (error) {
      if (error instanceof ApiError && (error.status === 401 || error.status === 403)) setToken('');
      status.textContent = `Not saved: ${error.message}`;
      status.className = 'error';
    }
  }

  draw();
  const picker = h('select', { 'data-testid': 'label-run', onchange: (e) => { const picked = e.target.selectedOptions[0].dataset.robot || ''; go(`#/labelling?run=${encodeURIComponent(e.target.value)}&robot=${encodeURIComponent(picked)}&parameter_set=${set}`); } },
    queue.runs.map((r) => h('option', { value: r.run_id, 'data-robot': r.robot_id, selected: r.run_id === runId && r.robot_id === detail.run.robot_id }, `${r.run_id} — ${r.regions} regions, ${r.regions_labelled} labelled`)));
  if (!queue.runs.some((r) => r.run_id === runId && r.robot_id === detail.run.robot_id)) picker.prepend(h('option', { value: runId, 'data-robot': detail.run.robot_id, selected: true }, runId));
  left.append(h('p', {}, 'Run: ', picker, ' ', h('a', { href: `#/runs/${encodeURIComponent(runId)}?parameter_set=${set}&robot=${runRobot}` }, 'run page')), mapHolder,
    h('p', { class: 'muted' }, `${detail.regions.length} regions · started ${time(detail.run.started_at_ms)} UTC`));
  right.append(panel, labelledList(labelled));
  setState(main, 'ready');
}

function labelledList(list) {
  return card(`Labelled regions (${list.regions.length})`, list.regions.length === 0 ? h('p', { class: 'muted', 'data-testid': 'no-labels' }, 'No labels yet.') :
    h('table', { 'data-testid': 'labelled-regions' }, h('tr', {}, ['run', 'region', 'label', 'classifier', 'by'].map((t) => h('th', {}, t))),
      list.regions.map((g) => h('tr', { 'data-testid': 'labelled-region' },
        h('td', {}, h('a', { href: `#/labelling?run=${encodeURIComponent(g.run_id)}&parameter_set=${g.parameter_set}&region=${g.region_id}` }, g.run_id)),
        h('td', {}, g.region_id), h('td', {}, h('span', { class: `badge ${g.label}` }, g.label)),
        h('td', {}, h('span', { class: `badge ${g.predicted_class}` }, g.predicted_class)), h('td', { class: 'muted' }, g.labelled_by || '')))));
}
export { regionClass };
