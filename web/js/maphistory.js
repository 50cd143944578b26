// A robot's map history (docs/formats/map-versions.md) for the map pages: a version's review state, its
// badge and label, and the lineage timeline — one node per version, an arrow from each parent to its child,
// coloured by approval.
import { h } from './ui.js';
import { svg, tip } from './svg.js';

export const robotMapsPath = (robotId) => `/api/robots/${encodeURIComponent(robotId)}/maps`;
export const historyHash = (robotId) => `#/robots/${encodeURIComponent(robotId)}/maps`;
export const versionHash = (robotId, version) => `${historyHash(robotId)}/${version}`;

/// "current" (the newest approved version, the one robots get), else the approval: approved, pending,
/// rejected or stale (an upload built on a map that was no longer current).
export const reviewState = (version) => (version.current ? 'current' : version.approval);

export function approvalBadge(version, testid = 'approval-badge') {
  const state = reviewState(version);
  return h('span', { class: `badge ${state}`, 'data-testid': testid, 'data-approval': version.approval },
    state === 'current' ? 'approved · current' : state);
}

/// What made the version, in words: "upload", or the repair's action ("reject edge", "cut region", …).
export function originLabel(version) {
  if (version.origin === 'upload') return 'upload';
  return (version.action || version.origin).replaceAll('_', ' ');
}

/// The earlier version whose map this one holds again (undo, rollback), by content address.
export function sameMapAs(version, versions) {
  if (version.origin === 'upload') return null;
  return versions.find((other) => other.version < version.version && other.snapshot_id === version.snapshot_id) || null;
}

const COLUMN = 112, LANE = 64, RADIUS = 13, PAD_X = 60, PAD_TOP = 24, LABEL_SPACE = 34;

/// Lanes: a child continues its parent's lane while nothing came after the parent there; other children
/// (a repair of an older version, a stale upload) take the lowest lane free from the parent's column on.
function assignLanes(versions) {
  const column = new Map(versions.map((v, i) => [v.version, i]));
  const lane = new Map();
  const laneEnd = [];  // the last column used in each lane
  versions.forEach((v, i) => {
    const parentColumn = column.get(v.parent_version);
    let chosen = parentColumn === undefined ? -1 : lane.get(v.parent_version);
    if (chosen < 0 || laneEnd[chosen] !== parentColumn) {
      const freeAfter = parentColumn === undefined ? i - 1 : parentColumn;
      chosen = laneEnd.findIndex((end) => end <= freeAfter);
      if (chosen < 0) chosen = laneEnd.length;
    }
    lane.set(v.version, chosen);
    laneEnd[chosen] = i;
  });
  return { column, lane, lanes: Math.max(1, laneEnd.length) };
}

/// The timeline as SVG; clicking a version calls onOpen(version).
export function lineageTimeline(versions, { onOpen } = {}) {
  const { column, lane, lanes } = assignLanes(versions);
  const position = (v) => ({ x: PAD_X + column.get(v.version) * COLUMN, y: PAD_TOP + RADIUS + lane.get(v.version) * LANE });
  const width = PAD_X * 2 + Math.max(0, versions.length - 1) * COLUMN;
  const height = PAD_TOP + RADIUS * 2 + (lanes - 1) * LANE + LABEL_SPACE;
  const arrows = svg('g', { class: 'lineage-arrows' });
  const nodes = svg('g', {});
  const byVersion = new Map(versions.map((v) => [v.version, v]));
  for (const v of versions) {
    const parent = byVersion.get(v.parent_version);
    if (!parent) continue;
    const a = position(parent), b = position(v);
    const d = a.y === b.y ? `M ${a.x + RADIUS} ${a.y} L ${b.x - RADIUS - 3} ${b.y}`
      : `M ${a.x} ${a.y + Math.sign(b.y - a.y) * RADIUS} C ${a.x} ${b.y}, ${a.x} ${b.y}, ${b.x - RADIUS - 3} ${b.y}`;
    arrows.append(svg('path', { d, class: `lineage-arrow ${reviewState(v)}`, 'marker-end': 'url(#lineage-head)', 'data-from': parent.version, 'data-to': v.version }));
  }
  for (const v of versions) {
    const { x, y } = position(v);
    const state = reviewState(v);
    const same = sameMapAs(v, versions);
    const group = svg('g', {
      class: `lineage-version ${state}`, 'data-testid': 'timeline-version', 'data-version': v.version, 'data-approval': v.approval,
      transform: `translate(${x} ${y})`, tabindex: 0, role: 'link',
      onclick: () => onOpen && onOpen(v),
      onkeydown: (event) => { if (event.key === 'Enter' && onOpen) onOpen(v); },
    },
    tip(`v${v.version}: ${originLabel(v)}${v.action_detail ? ` — ${v.action_detail}` : ''}\n${state}${v.created_by ? ` · by ${v.created_by}` : ''}${v.reason ? `\nreason: ${v.reason}` : ''}`),
    svg('circle', { r: RADIUS }),
    svg('text', { class: 'lineage-number', 'text-anchor': 'middle', dy: '0.35em' }, v.version),
    svg('text', { class: 'lineage-label', 'text-anchor': 'middle', y: RADIUS + 14 }, originLabel(v)),
    svg('text', { class: 'lineage-sublabel', 'text-anchor': 'middle', y: RADIUS + 27 }, same ? `= v${same.version}'s map` : state));
    nodes.append(group);
  }
  const head = svg('marker', { id: 'lineage-head', viewBox: '0 0 10 10', refX: 8, refY: 5, markerWidth: 7, markerHeight: 7, orient: 'auto-start-reverse' },
    svg('path', { d: 'M 0 0 L 10 5 L 0 10 z', class: 'lineage-head' }));
  return svg('svg', { 'data-testid': 'map-timeline', class: 'lineage', width, height, viewBox: `0 0 ${width} ${height}` },
    svg('defs', {}, head), arrows, nodes);
}

export function lineageLegend() {
  const swatch = (state, label) => h('span', {}, h('i', { class: `dot ${state}` }), label);
  return h('div', { class: 'legend' },
    swatch('current', 'current (approved, robots get it)'), swatch('approved', 'approved earlier'),
    swatch('pending', 'pending review'), swatch('rejected', 'rejected'), swatch('stale', 'stale upload (built on an older map)'),
    h('span', {}, '→ parent to child; "= vN\'s map": holds that version\'s map again (undo, rollback)'));
}
