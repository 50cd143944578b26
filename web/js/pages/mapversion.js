// One map version for review (issue #10, the repair loop): figures and review state, the picture with the
// pose graph and findings drawn over it, the findings with their evidence, and the constraint view. Every
// repair makes a new pending version from this one (POST …/repair, engineer token) and opens it, so the
// engineer sees the re-optimised map beside its parent before approving or rejecting it (POST …/review).
import { ApiError, downloadLink, getJson, postAsEngineer } from '../api.js';
import { card, go, h, kpi, num, setState, time } from '../ui.js';
import { approvalBadge, historyHash, originLabel, reviewState, robotMapsPath, sameMapAs, versionHash } from '../maphistory.js';
import { mapOverlay, metadataPanel, nodeId, otherComponents, overlayLegend } from '../mapoverlay.js';
import { constraintTable } from '../constraints.js';

const TOKEN_WHY = 'Repairing and reviewing maps needs an engineer token.';

export async function render(main, { args, query, isCurrent }) {
  const [robotId, requested] = args;
  const base = robotMapsPath(robotId);
  const [detail, history] = await Promise.all([getJson(`${base}/${encodeURIComponent(requested)}`), getJson(base)]);
  const version = detail.version, v = version.version, versionBase = `${base}/${v}`;
  const byVersion = new Map(history.versions.map((x) => [x.version, x]));
  const head = byVersion.get(history.head_version) || null;  // what repairs start from
  const parent = byVersion.get(version.parent_version) || null;
  const compare = version.approval === 'pending' && parent;

  const graphs = new Map();
  const graphOf = (n) => { if (!graphs.has(n)) graphs.set(n, getJson(`${base}/${n}/graph`)); return graphs.get(n); };
  const [graph, parentGraph, parentDetail] = await Promise.all([
    graphOf(v),
    compare ? graphOf(parent.version) : null,
    compare ? getJson(`${base}/${parent.version}`) : null,
  ]);
  if (!isCurrent()) return;
  // The nodes the version's run added (the server flags them): only that run's hypotheses can be rejected.
  const runNodes = new Set(graph.nodes.filter((n) => n[5] === 1).map(nodeId));

  // ---- Actions: each posts, then opens the version it made (or this one again, reviewed). ----
  const status = h('div', { class: 'status', 'data-testid': 'repair-status', role: 'status', hidden: true });
  const show = (kind, ...content) => {
    status.className = `status ${kind}`;
    status.dataset.kind = kind;
    status.replaceChildren(...content);
    status.hidden = false;
  };
  const reason = h('input', { type: 'text', 'data-testid': 'repair-reason', placeholder: 'why — stored with the new version', size: 44 });
  let busy = false;
  const setBusy = (value) => {
    busy = value;
    for (const button of main.querySelectorAll('button[data-repair]')) button.classList.toggle('busy', value);
  };
  const repairBlocked = head && v === head.version ? ''
    : head ? `Repairs start from v${head.version}, the newest approved or pending version; v${v} is ${['rejected', 'stale'].includes(version.approval) ? version.approval : 'older'}.`
      : 'This robot has no approved or pending version to repair.';

  async function repair(body, what) {
    if (busy) return;
    if (!reason.value.trim()) {
      show('error', `${what}: write a reason first (it is stored with the new version).`);
      reason.focus();
      return;
    }
    setBusy(true);
    show('busy', `${what}: making a new version from v${v} and re-optimising…`);
    try {
      const made = await postAsEngineer(`${versionBase}/repair`, { ...body, reason: reason.value.trim() }, TOKEN_WHY);
      go(`${versionHash(robotId, made.version.version)}?from=${v}`);
    } catch (error) {
      await explain(error, what);
      setBusy(false);
    }
  }

  async function review(approve) {
    if (busy) return;
    setBusy(true);
    show('busy', `${approve ? 'Approving' : 'Rejecting'} v${v}…`);
    try {
      await postAsEngineer(`${versionBase}/review`, { approve }, TOKEN_WHY);
      go(`${versionHash(robotId, v)}?reviewed=${approve ? 'approved' : 'rejected'}`);
    } catch (error) {
      await explain(error, approve ? 'Approve' : 'Reject');
      setBusy(false);
    }
  }

  /// 409 ABORTED: the map moved on (another repair or upload made a newer head); 409 FAILED_PRECONDITION:
  /// the version is no longer pending, or the repair does not apply. Say which and offer a reload.
  async function explain(error, what) {
    const reload = h('button', { class: 'secondary', 'data-testid': 'reload', onclick: () => go(location.hash) }, 'Reload');
    if (error instanceof ApiError && error.status === 409) {
      const latest = error.code === 'ABORTED' ? await getJson(base).catch(() => null) : null;
      const moved = latest && latest.versions.find((x) => x.version === latest.head_version);
      if (moved && moved.version !== v) {
        show('error', `${what} not done: the map changed meanwhile — v${moved.version} (${originLabel(moved)}, by ${moved.created_by}) is the newest version now, so v${v} can no longer be repaired. Reload and look again: `,
          h('a', { href: versionHash(robotId, moved.version), 'data-testid': 'open-newest' }, `open v${moved.version}`), ' ', reload);
        return;
      }
      show('error', `${what} not done: ${error.message} (HTTP 409). This page may be out of date: `, reload);
      return;
    }
    const forgotten = error instanceof ApiError && (error.status === 401 || error.status === 403) ? ' The token was forgotten; the next attempt asks for one again.' : '';
    show('error', `${what} not done: ${error.message}${error.status ? ` (HTTP ${error.status})` : ''}.${forgotten}`);
  }

  const rejectEdge = (edge) => repair({ action: 'reject_edge', from: edge.from, to: edge.to, view: edge.view ?? null },
    `Reject edge ${edge.from}→${edge.to}${edge.view !== undefined ? ` (view ${edge.view})` : ''}`);
  const rejectHypothesis = (hypothesis) => repair({ action: 'reject_hypothesis', hypothesis }, `Reject hypothesis ${hypothesis}`);

  // ---- Header, review, figures, exports ----
  main.append(h('p', { class: 'muted' }, h('a', { href: historyHash(robotId) }, `← ${robotId}'s map history`)),
    h('h1', { 'data-testid': 'version-title', 'data-version': v }, `${robotId} · map v${v} `, approvalBadge(version)),
    h('p', { class: 'muted', 'data-testid': 'version-summary' }, ...describe(version, parent, history.versions, robotId)),
    status);
  arrivalNote(query, version, parent, show);
  if (version.approval === 'pending') {
    main.append(h('section', { class: 'card review', 'data-testid': 'review-card' }, h('h2', {}, 'Review'),
      h('p', {}, `Pending: robots keep the current map (${history.current_version ? `v${history.current_version}` : 'none'}) until an engineer approves this version.`,
        compare ? ' Compare it with its parent below.' : ''),
      h('div', { class: 'pager' },
        h('button', { class: 'approve', 'data-testid': 'review-approve', 'data-repair': true, onclick: () => review(true) }, 'Approve'),
        h('button', { class: 'danger', 'data-testid': 'review-reject', 'data-repair': true, onclick: () => review(false) }, 'Reject'))));
  }
  const delta = (key, digits = 0) => {
    if (!compare) return null;
    const change = version[key] - parent[key];
    return Math.abs(change) < 10 ** -digits / 2 ? null : h('span', { class: 'delta muted' }, ` ${change > 0 ? '+' : '−'}${num(Math.abs(change), digits)}`);
  };
  main.append(h('div', { class: 'kpis' },
    kpi('nodes', h('span', { 'data-value': version.nodes }, num(version.nodes), delta('nodes')), 'kpi-nodes'),
    kpi('edges (observation)', h('span', { 'data-value': version.edges }, `${num(version.edges)} (${num(version.observation_edges)})`, delta('edges')), 'kpi-edges'),
    kpi('components', h('span', {}, num(version.components), delta('components')), 'kpi-components'),
    kpi('known area', h('span', {}, `${num(version.known_area_m2, 1)} m²`, delta('known_area_m2', 1)), 'kpi-area'),
    kpi('χ² after optimisation', h('span', {}, num(version.chi2, 1), delta('chi2', 1)), 'kpi-chi2'),
    kpi('open findings', num(version.open_findings), 'kpi-findings')));
  const exportLink = (file) => downloadLink(h('a', { href: `${versionBase}/export/${file}`, 'data-testid': `export-${file.slice(4)}` }, file),
    `${versionBase}/export/${file}`, `${robotId}-v${v}${file.slice(3)}`);
  main.append(h('p', { class: 'exports', 'data-testid': 'exports' }, h('strong', {}, `Export v${v}: `),
    exportLink('map.pgm'), ' + ', exportLink('map.yaml'), ' (ROS map_server) · ', exportLink('map.g2o'), ' (pose graph, g2o) · ',
    exportLink('map.json'), ' (ValetudoMap, with its rooms and zones)'));

  // ---- Picture(s), findings, repairs, constraints ----
  const after = mapOverlay(`${versionBase}/map.png`, graph, detail.findings,
    { testid: 'version-map', caption: compare ? `after: v${v} — ${originLabel(version)} (pending)` : `v${v}: home component`, metadata: detail.metadata });
  const before = compare ? mapOverlay(`${base}/${parent.version}/map.png`, parentGraph, parentDetail.findings,
    { testid: 'parent-map', caption: `before: v${parent.version} — ${originLabel(parent)} (${reviewState(parent)})`, metadata: parentDetail.metadata }) : null;
  const mapCard = card(compare ? `Before and after (v${parent.version} → v${v})` : 'Map with its pose graph and findings',
    before ? h('div', { class: 'compare' }, before.element, after.element) : after.element,
    overlayLegend(detail.metadata), metadataPanel(detail.metadata), otherComponents(graph, detail.findings));

  const rollbackTitle = version.origin === 'upload' && !version.parent_version
    ? 'the robot\'s first map: there is no parent map' : `a new version holding the map from before run ${version.run_id}`;
  const repairCard = card('Repair',
    h('p', { class: 'muted' }, repairBlocked ? [repairBlocked, ...(head ? [' ', h('a', { href: versionHash(robotId, head.version) }, `Open v${head.version}`), '.'] : [])]
      : 'Each repair makes a new pending version from this one, re-optimised; review it before robots get it.'),
    h('label', { class: 'field' }, 'Reason ', reason),
    h('div', { class: 'pager' },
      h('button', { class: 'secondary', 'data-testid': 'rollback', 'data-repair': true, title: repairBlocked || rollbackTitle,
        disabled: Boolean(repairBlocked) || (version.origin === 'upload' && !version.parent_version),
        onclick: () => repair({ action: 'rollback' }, 'Roll back') }, 'Roll back to parent map'),
      version.origin !== 'upload' ? h('button', { class: 'secondary', 'data-testid': 'undo-repair', 'data-repair': true,
        title: repairBlocked || `a new version holding v${version.parent_version}'s map again`, disabled: Boolean(repairBlocked),
        onclick: () => repair({ action: 'undo' }, 'Undo') }, 'Undo this repair') : null));
  const findingsCard = card(`Findings (${detail.findings.filter((f) => f.state === 'open').length} open of ${detail.findings.length})`,
    findingsList(detail.findings, { runNodes, repairBlocked, rejectEdge, rejectHypothesis,
      cut: (f) => repair({ action: 'cut_finding', finding_id: f.finding_id }, `Cut region (finding #${f.finding_id})`) }));
  main.append(compare ? h('div', {}, mapCard, h('div', { class: 'row' }, findingsCard, repairCard))
    : h('div', { class: 'row' }, mapCard, h('div', { class: 'stack' }, repairCard, findingsCard)));
  main.append(card('Constraints: observation edges, their source and residual',
    constraintTable(graph, detail.findings, { runNodes, repairBlocked, onRejectEdge: rejectEdge, onRejectHypothesis: rejectHypothesis,
      onHover: (key) => { after.highlight(key); if (before) before.highlight(key); } })));
  setState(main, 'ready');
}

function describe(version, parent, versions, robotId) {
  const same = sameMapAs(version, versions);
  const parts = [h('strong', {}, originLabel(version))];
  if (version.action_detail) parts.push(`: ${version.action_detail}`);
  parts.push(` · by ${version.created_by}`);
  if (version.reason) parts.push(` · reason: “${version.reason}”`);
  parts.push(` · ${time(version.created_at * 1000)} UTC`);
  if (parent) parts.push(' · parent ', h('a', { href: versionHash(robotId, parent.version) }, `v${parent.version}`));
  if (same && version.origin !== 'undo') parts.push(` · holds the map of v${same.version} again`);  // undo's detail says so
  if (version.run_id) parts.push(' · run ', h('a', { href: `#/runs/${encodeURIComponent(version.run_id)}?robot=${encodeURIComponent(robotId)}` }, version.run_id));
  if (version.approval !== 'pending' && version.approved_by) parts.push(` · ${version.approval} by ${version.approved_by}`);
  return parts;
}

/// What the last action did, when the page was opened by it (…?from=<base> after a repair, ?reviewed=…).
function arrivalNote(query, version, parent, show) {
  if (query.get('reviewed') === 'approved') {
    show('ok', version.current ? `Approved: v${version.version} is now the robot's current map; robots get it on their next map fetch.`
      : `Approved, but v${version.version} is not the current map: a newer approved version exists.`);
  } else if (query.get('reviewed') === 'rejected') {
    show('ok', `Rejected: robots keep their current map; v${version.version} stays in the history.`);
  } else if (query.has('from') && version.approval === 'pending') {
    show('ok', `New pending version v${version.version} from v${query.get('from')}: ${version.action_detail || originLabel(version)}.`,
      parent ? ' Compare before and after, then approve or reject it.' : '');
  }
}

function findingsList(findings, { runNodes, repairBlocked, rejectEdge, rejectHypothesis, cut }) {
  if (findings.length === 0) return h('p', { class: 'muted', 'data-testid': 'no-findings' }, 'No findings on this version.');
  return h('div', { class: 'findings' }, findings.map((finding) => {
    const evidence = finding.evidence || {};
    const edges = Array.isArray(evidence.edges) ? evidence.edges : [];
    const actions = [];
    const action = (label, testid, onclick, title) => h('button', { class: 'small danger', 'data-testid': testid, 'data-repair': true,
      disabled: Boolean(repairBlocked), title: repairBlocked || title, onclick }, label);
    if (finding.state === 'open') {
      const hypothesis = edges.length > 0 && edges[0].hypothesis !== undefined ? edges[0].hypothesis : null;
      const ofRun = hypothesis !== null && runNodes.has(edges[0].from);
      if (finding.kind === 'protrusion') {
        actions.push(action('Cut region', 'cut-region', () => cut(finding), 'make the run\'s cells inside the box unknown again'));
      } else if (ofRun && (finding.kind === 'unconfirmed_hypothesis' || edges.length > 1)) {
        actions.push(action(`Reject ${evidence.joins_components ? 'merge' : 'hypothesis'} ${hypothesis}`, 'finding-reject-hypothesis',
          () => rejectHypothesis(hypothesis), `remove the ${edges.length} edge(s) of hypothesis ${hypothesis}`));
      } else if (edges.length === 1) {
        actions.push(action(`Reject edge ${edges[0].from}→${edges[0].to}`, 'finding-reject-edge', () => rejectEdge(edges[0]), 'remove this edge and re-optimise'));
      }
    }
    // The repair buttons stay outside <details>: visible without opening the evidence.
    return h('div', { class: 'finding', 'data-testid': 'finding', 'data-kind': finding.kind, 'data-state': finding.state, 'data-finding': finding.finding_id },
      h('details', {},
        h('summary', {}, h('span', { class: 'severity', title: 'severity (0–1)' }, finding.severity.toFixed(2)), ' ',
          h('span', { class: `badge ${finding.kind}` }, finding.kind.replaceAll('_', ' ')), ' ',
          h('span', { class: `badge ${finding.state}` }, finding.state), ' ', finding.summary),
        evidenceView(evidence)),
      actions.length ? h('div', { class: 'finding-actions' }, actions) : null);
  }));
}

function evidenceView(evidence) {
  const parts = [];
  const rest = Object.entries(evidence).filter(([key]) => key !== 'edges' && key !== 'rerun_decisions');
  if (rest.length) {
    parts.push(h('dl', { class: 'evidence' }, rest.flatMap(([key, value]) => [h('dt', {}, key.replaceAll('_', ' ')),
      h('dd', {}, typeof value === 'number' ? num(value) : typeof value === 'object' ? JSON.stringify(value) : String(value))])));
  }
  if (Array.isArray(evidence.edges) && evidence.edges.length) {
    parts.push(h('table', { class: 'compact' }, h('tr', {}, ['from', 'to', 'view', 'hypothesis', 'χ²'].map((t) => h('th', {}, t))),
      evidence.edges.map((e) => h('tr', {}, h('td', {}, e.from), h('td', {}, e.to), h('td', {}, e.view ?? '—'), h('td', {}, e.hypothesis ?? 'direct'),
        h('td', { class: 'num' }, num(e.chi2, 1))))));
  }
  if (Array.isArray(evidence.rerun_decisions) && evidence.rerun_decisions.length) {
    parts.push(h('p', { class: 'muted' }, 'The server\'s rerun decided:'),
      h('table', { class: 'compact', 'data-testid': 'rerun-decisions' }, h('tr', {}, ['t (s)', 'decision', 'hypothesis', 'node', 'view', 'reason'].map((t) => h('th', {}, t))),
        evidence.rerun_decisions.map((d) => h('tr', {}, h('td', { class: 'num' }, num(d.time, 1)), h('td', {}, h('span', { class: `badge ${d.kind}` }, d.kind)),
          h('td', {}, `${d.hypothesis_kind || ''} ${d.hypothesis}`), h('td', {}, d.node), h('td', {}, d.view), h('td', { class: 'wrap muted' }, d.reason)))));
  }
  return h('div', { class: 'evidence-body' }, parts.length ? parts : h('p', { class: 'muted' }, 'No further evidence.'));
}
