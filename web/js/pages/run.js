// One run (paper Fig. 5 style): parent, child and difference maps with the classified regions, the rerun's
// pose graph with components, hypothesis edges and conditional merges, the decision timeline and the
// ambiguous views.
import { getJson } from '../api.js';
import { card, emptyState, go, h, kpi, num, setState, time } from '../ui.js';
import { decidedByText, mapView, regionClass } from '../mapview.js';
import { poseGraph, poseGraphLegend } from '../posegraph.js';

export async function render(main, { args, query, isCurrent }) {
  const runId = args[0];
  const set = query.get('parameter_set') || '';
  // Run ids are per robot: the robot picks the run when robots share an id.
  const robot = query.get('robot') || '';
  const detail = await getJson(`/api/runs/${encodeURIComponent(runId)}`, { parameter_set: set, robot });
  if (!isCurrent()) return;
  const run = detail.run;
  const setPicker = h('select', { 'data-testid': 'run-parameter-set', onchange: (e) => { go(`#/runs/${encodeURIComponent(runId)}?parameter_set=${e.target.value}&robot=${encodeURIComponent(run.robot_id)}`); } },
    (detail.report_parameter_sets.length ? detail.report_parameter_sets : [detail.parameter_set]).map((s) => h('option', { value: s, selected: s === detail.parameter_set }, s)));
  main.append(h('h1', {}, `Run ${run.run_id}`),
    h('p', { class: 'muted' }, `robot ${run.robot_id} · firmware ${run.firmware} · ${run.robot_model} · started ${time(run.started_at_ms)} UTC · `,
      run.parent_snapshot_id ? 'continues the robot\'s map' : 'first run (no parent map)',
      detail.analysis && detail.analysis.map_version ? h('span', { 'data-testid': 'run-map-version' }, ` (ran on map version ${detail.analysis.map_version})`) : '',
      ' · parameter set ', setPicker));
  if (!detail.report) {
    main.append(emptyState(`No report with parameter set "${detail.parameter_set}" yet.`, 'Analysis runs after the upload; reprocessing jobs add other parameter sets (Jobs page).'));
    setState(main, 'empty');
    return;
  }
  const r = detail.report, a = detail.analysis || {};
  main.append(h('div', { class: 'kpis' },
    kpi('recovery hypotheses (accepted / later retracted)', `${num(r.recovery_created)} (${num(r.recovery_accepted)} / ${num(r.recovery_retracted)})`),
    kpi('merge hypotheses: conditional / then rejected', `${num(r.merge_conditionally_accepted)} / ${num(r.merge_conditional_then_rejected)}`),
    kpi('started localized', r.started_localized ? 'yes' : 'no'),
    kpi('to conditional / full relocalization', `${fmtSeconds(a.seconds_to_conditional_relocalization)} / ${fmtSeconds(a.seconds_to_full_relocalization)}`),
    kpi('ambiguous views', `${num(r.views_ambiguous)} of ${num(r.views_total)}`),
    kpi('regions (protrusions found)', `${num(detail.regions.length)} (${num(r.protrusions_found)})`),
    a.ground_truth ? kpi('trajectory RMSE (truth)', `${num(a.ground_truth.trajectory_rmse)} m`) : null));

  const base = `/api/runs/${encodeURIComponent(runId)}/map`;
  const q = `?parameter_set=${encodeURIComponent(detail.parameter_set)}&robot=${encodeURIComponent(run.robot_id)}`;
  const mapsCard = card('Maps — (a) parent, (b) child (rerun), (c) difference with classified regions');
  main.append(mapsCard);
  let info = null;
  try {
    info = await getJson(`${base}/info.json`, { parameter_set: detail.parameter_set, robot: run.robot_id });
  } catch (error) {
    mapsCard.append(h('div', { class: 'error', 'data-testid': 'maps-error' }, `Maps unavailable: ${error.message}`));
  }
  if (info) {
    const regions = detail.regions;
    mapsCard.append(h('div', { class: 'maps' },
      h('figure', {}, mapView(`${base}/parent.png${q}`, info, [], { testid: 'map-parent' }), h('figcaption', { class: 'muted' }, '(a) parent')),
      h('figure', {}, mapView(`${base}/child.png${q}`, info, regions, { testid: 'map-child' }), h('figcaption', { class: 'muted' }, '(b) child')),
      h('figure', {}, mapView(`${base}/difference.png${q}`, info, regions, { testid: 'map-difference', onRegionClick: (region) => { go(`#/labelling?run=${encodeURIComponent(runId)}&robot=${encodeURIComponent(run.robot_id)}&parameter_set=${detail.parameter_set}&region=${region.region_id}`); } }),
        h('figcaption', { class: 'muted' }, '(c) difference: black = new in the child; boxes: red protrusion, green new space, amber unclassified'))),
      regions.length ? h('table', { 'data-testid': 'regions-table' },
        h('tr', {}, ['region', 'class', 'decided by', 'probability', 'label', 'area m²', 'minor axis m', 'mean distance m'].map((t) => h('th', {}, t))),
        regions.map((g) => h('tr', {}, h('td', {}, g.region_id), h('td', {}, h('span', { class: `badge ${g.predicted_class}` }, g.predicted_class)),
          h('td', { 'data-testid': 'decided-by' }, decidedByText(g)),
          h('td', { class: 'num' }, g.probability >= 0 ? num(g.probability) : '—'),
          h('td', {}, g.label ? h('span', { class: `badge ${g.label}` }, g.label) : h('a', { href: `#/labelling?run=${encodeURIComponent(runId)}&robot=${encodeURIComponent(run.robot_id)}&parameter_set=${detail.parameter_set}&region=${g.region_id}` }, 'label…')),
          h('td', { class: 'num' }, num(g.features.area_m2)), h('td', { class: 'num' }, num(g.features.minor_axis_m)),
          h('td', { class: 'num' }, num(g.features.mean_distance_m)))))
        : h('p', { class: 'muted' }, 'No new regions between parent and child.'));
  }

  const graphCard = card('Pose graph (rerun child): components, hypothesis edges, conditional merges, ambiguous views');
  const timelineCard = card(`Decision timeline (${detail.decisions.length})`);
  main.append(h('div', { class: 'row' }, graphCard, timelineCard));
  const graph = await getJson(`/api/runs/${encodeURIComponent(runId)}/graph`, { parameter_set: detail.parameter_set, robot: run.robot_id });
  if (!isCurrent()) return;
  graphCard.append(h('div', { id: 'posegraph' }, poseGraph(graph)), poseGraphLegend(graph));
  const ambiguous = new Set(detail.ambiguous_views.map((v) => v.view_id));
  timelineCard.append(h('div', { class: 'timeline' }, h('table', { 'data-testid': 'decision-timeline' },
    h('tr', {}, ['t (s)', 'kind', 'decision', 'subject', 'detail'].map((t) => h('th', {}, t))),
    detail.decisions.map((d) => h('tr', { 'data-testid': 'decision' }, h('td', { class: 'num' }, d.time_s.toFixed(1)), h('td', {}, d.kind),
      h('td', {}, h('span', { class: `badge ${d.outcome}` }, d.outcome)),
      h('td', {}, d.outcome === 'view_marked_ambiguous' || ambiguous.has(d.subject_id) && d.kind === 'map' ? `view ${d.subject_id}` : d.subject_id >= 0 ? `#${d.subject_id}` : ''),
      h('td', { class: 'muted' }, d.detail))))),
    h('p', { 'data-testid': 'ambiguous-views' }, h('strong', {}, 'Ambiguous views: '),
      detail.ambiguous_views.length ? detail.ambiguous_views.map((v) => `view ${v.view_id}`).join(', ') : 'none'));
  setState(main, 'ready');
}

function fmtSeconds(value) { return value === undefined || value < 0 ? 'never' : `${value.toFixed(1)} s`; }
export { regionClass };
