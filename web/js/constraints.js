// The constraint view of a map version: its observation edges with their source (a hypothesis the robot
// accepted, or a direct edge), their χ² residual after optimisation and the findings that flag them, each
// with the repairs that act on it. Motion (odometry) edges are left out: they cannot be rejected.
import { h, num } from './ui.js';
import { edgeKey, flaggedEdges } from './mapoverlay.js';

const FIRST_ROWS = 100;

/// `runNodes`: the nodes the version's run added (a Set, from /graph's flags); only hypotheses of that run
/// can be rejected as a whole (the server keys hypotheses by run). `repairBlocked`: why repairs are off, or ''.
export function constraintTable(graph, findings, { runNodes, repairBlocked, onRejectEdge, onRejectHypothesis, onHover }) {
  const flagged = flaggedEdges(findings);
  const edges = graph.edges.filter((e) => e.kind === 'observation');
  let descending = true, flaggedOnly = false, showAll = false;

  const body = h('tbody', {});
  const sortButton = h('button', { class: 'link', 'data-testid': 'sort-chi2', onclick: () => { descending = !descending; draw(); } });
  const flaggedToggle = h('input', { type: 'checkbox', 'data-testid': 'flagged-only', onchange: (e) => { flaggedOnly = e.target.checked; draw(); } });
  const more = h('button', { class: 'secondary', 'data-testid': 'show-all-constraints', onclick: () => { showAll = true; draw(); } });
  const count = h('span', { class: 'muted' });

  const sourceOf = (edge) => {
    if (edge.hypothesis === undefined) return { text: 'direct', ofRun: false };
    const ofRun = runNodes.has(edge.from);
    return { text: `hypothesis ${edge.hypothesis}${ofRun ? '' : ' (earlier run)'}`, ofRun };
  };

  function row(edge) {
    const key = edgeKey(edge);
    const flags = flagged.get(key) || [];
    const source = sourceOf(edge);
    const hypothesisTitle = repairBlocked || (source.ofRun ? `remove every edge hypothesis ${edge.hypothesis} of this version's run added`
      : `hypothesis ${edge.hypothesis} belongs to an earlier run: reject its edges one by one, or roll back`);
    return h('tr', { 'data-testid': 'constraint-row', 'data-from': edge.from, 'data-to': edge.to, 'data-view': edge.view ?? '',
      'data-chi2': edge.chi2, 'data-flagged': flags.length > 0 ? 'true' : 'false', class: flags.length ? 'flagged' : undefined,
      onmouseenter: () => onHover(key), onmouseleave: () => onHover(null) },
    h('td', { class: 'num' }, edge.from), h('td', { class: 'num' }, edge.to), h('td', { class: 'num' }, edge.view ?? '—'),
    h('td', {}, source.text), h('td', { class: 'num' }, num(edge.chi2, 2)),
    h('td', {}, flags.length ? flags.map((f) => h('span', { class: 'badge rejected', title: f.summary }, `#${f.finding_id} ${f.kind.replaceAll('_', ' ')}`)) : h('span', { class: 'muted' }, 'no')),
    h('td', { class: 'actions' },
      h('button', { class: 'small danger', 'data-testid': 'reject-edge', 'data-repair': true, disabled: Boolean(repairBlocked), title: repairBlocked || 'remove this edge and re-optimise',
        onclick: () => onRejectEdge(edge) }, 'Reject edge'),
      edge.hypothesis !== undefined ? h('button', { class: 'small secondary', 'data-testid': 'reject-hypothesis', 'data-repair': true, 'data-hypothesis': edge.hypothesis,
        disabled: Boolean(repairBlocked) || !source.ofRun, title: hypothesisTitle, onclick: () => onRejectHypothesis(edge.hypothesis) }, `Reject hypothesis ${edge.hypothesis}`) : null));
  }

  function draw() {
    const shown = edges.filter((e) => !flaggedOnly || flagged.has(edgeKey(e)))
      .sort((a, b) => (descending ? b.chi2 - a.chi2 : a.chi2 - b.chi2));
    const rows = showAll ? shown : shown.slice(0, FIRST_ROWS);
    body.replaceChildren(...rows.map(row));
    sortButton.textContent = `χ² ${descending ? '▼' : '▲'}`;
    count.textContent = `${rows.length} of ${shown.length} shown${flaggedOnly ? ' (flagged only)' : ''} · ${edges.length} observation edges in all`;
    more.hidden = rows.length === shown.length;
    more.textContent = `Show all ${shown.length}`;
  }
  draw();
  return h('div', {},
    h('div', { class: 'filters' }, h('label', { class: 'inline' }, flaggedToggle, ' only edges a finding flags'), count),
    h('div', { class: 'constraints' }, h('table', { 'data-testid': 'constraint-table' },
      h('thead', {}, h('tr', {}, h('th', { class: 'num' }, 'from'), h('th', { class: 'num' }, 'to'), h('th', { class: 'num' }, 'view'),
        h('th', {}, 'source'), h('th', { class: 'num', title: 'residual after optimisation; click to sort' }, sortButton), h('th', {}, 'flagged by'), h('th', {}, 'repair'))),
      body)),
    h('div', { class: 'pager' }, more));
}
