// A map version's picture (map.png: its home component's occupancy grid) with the pose graph and the
// findings drawn over it, plus the components that are not in the picture, each drawn in its own frame.
//
// The picture's frame is the `grid` of /graph: cell (col, row) covers world x ∈ [origin_x + col·res, …) and
// y likewise with row 0 at the lowest y (ROS), while image rows run downwards, so a world point lands at
// svg x = (x − origin_x)/res, svg y = height − (y − origin_y)/res (continuous pixel coordinates). Only the
// home component — the one with the most nodes, ties to the first — lives in that frame.
import { h } from './ui.js';
import { svg, tip } from './svg.js';
import { loadImage } from './api.js';

/// Graph nodes arrive as [id, x, y, theta, component].
export const nodeId = (node) => node[0];
export const edgeKey = (edge) => `${edge.from}>${edge.to}@${edge.view ?? ''}`;
const FLAGGING_KINDS = new Set(['high_residual_edge', 'unconfirmed_hypothesis']);

export function homeComponent(graph) {
  let home = graph.components[0];
  for (const component of graph.components) if (component.nodes > home.nodes) home = component;
  return home ? home.id : null;
}

/// Edge key → the findings whose evidence names that edge.
export function flaggedEdges(findings) {
  const flagged = new Map();
  for (const finding of findings) {
    if (!FLAGGING_KINDS.has(finding.kind) || !finding.evidence || !Array.isArray(finding.evidence.edges)) continue;
    for (const edge of finding.evidence.edges) {
      const key = edgeKey(edge);
      if (!flagged.has(key)) flagged.set(key, []);
      flagged.get(key).push(finding);
    }
  }
  return flagged;
}

function drawEdges(graph, nodes, project, flagged, { withKeys }) {
  const layers = { motion: svg('g', {}), observation: svg('g', {}), flagged: svg('g', {}) };
  const lines = new Map();
  for (const edge of graph.edges) {
    const a = nodes.get(edge.from), b = nodes.get(edge.to);
    if (!a || !b) continue;
    const [x1, y1] = project(a), [x2, y2] = project(b);
    const isFlagged = edge.kind === 'observation' && flagged.has(edgeKey(edge));
    const kind = edge.kind === 'motion' ? 'motion' : isFlagged ? 'flagged' : 'observation';
    const line = svg('line', { x1, y1, x2, y2, class: `edge-${kind}`, 'data-kind': kind });
    if (edge.kind === 'observation') {
      line.append(tip(`${edge.from}→${edge.to}${edge.view !== undefined ? ` view ${edge.view}` : ''}: χ² ${edge.chi2.toFixed(1)}${edge.hypothesis !== undefined ? `, hypothesis ${edge.hypothesis}` : ''}`));
      if (withKeys) lines.set(edgeKey(edge), line);
    }
    layers[kind].append(line);
  }
  return { groups: [layers.motion, layers.observation, layers.flagged], lines };
}

/// What an imported map said besides its grid (the version's metadata): zones, virtual walls and the robot's
/// path drawn in the picture's frame, the robot and dock as dots, each room's name at its centre.
function drawMetadata(metadata, project, grid) {
  const group = svg('g', { class: 'metadata', 'data-testid': 'metadata-overlay' });
  if (!metadata) return group;
  const pointsOf = (xy) => {
    const out = [];
    for (let i = 0; i + 1 < xy.length; i += 2) out.push(project([0, xy[i], xy[i + 1]]).join(','));
    return out.join(' ');
  };
  for (const zone of metadata.zones) {
    group.append(svg('polygon', { points: pointsOf(zone.xy), class: `zone zone-${zone.type}`, 'data-testid': 'zone', 'data-type': zone.type },
      tip(zone.type.replaceAll('_', ' '))));
  }
  for (const wall of metadata.virtual_walls) {
    group.append(svg('polyline', { points: pointsOf(wall.xy), class: 'virtual-wall', 'data-testid': 'virtual-wall' }, tip('virtual wall')));
  }
  for (const path of metadata.paths) {
    group.append(svg('polyline', { points: pointsOf(path.xy), class: `robot-path ${path.type}`, 'data-testid': 'robot-path' }, tip(path.type.replaceAll('_', ' '))));
  }
  const size = Math.max(grid.width, grid.height) / 60;
  for (const point of metadata.points) {
    const [cx, cy] = project([0, point.x, point.y]);
    group.append(svg('circle', { cx, cy, r: size / 2, class: `map-point ${point.type}`, 'data-testid': 'map-point', 'data-type': point.type },
      tip(point.type.replaceAll('_', ' '))));
  }
  for (const room of metadata.rooms) {
    if (!room.centre) continue;
    const [x, y] = project([0, room.centre[0], room.centre[1]]);
    group.append(svg('text', { x, y, 'font-size': size * 1.6, class: 'room-label', 'data-testid': 'room-label', 'text-anchor': 'middle' },
      roomName(room)));
  }
  return group;
}

export const roomName = (room) => room.name || `room ${room.segment_id}`;

/// The picture with the home component's graph and the findings (and an imported map's metadata). Returns
/// {element, highlight(key)}; the highlight marks one observation edge (the constraint table's row under the
/// pointer).
export function mapOverlay(src, graph, findings, { testid, caption, metadata } = {}) {
  const { grid } = graph;
  const home = homeComponent(graph);
  const project = ([, x, y]) => [(x - grid.origin_x) / grid.resolution, grid.height - (y - grid.origin_y) / grid.resolution];
  const nodes = new Map(graph.nodes.filter((n) => n[4] === home).map((n) => [nodeId(n), n]));
  const flagged = flaggedEdges(findings);
  const { groups, lines } = drawEdges(graph, nodes, project, flagged, { withKeys: true });
  const boxes = svg('g', {});
  for (const finding of findings) {
    if (!Array.isArray(finding.world_bbox)) continue;
    const [minX, minY, maxX, maxY] = finding.world_bbox;
    const [x1, y1] = project([0, minX, maxY]), [x2, y2] = project([0, maxX, minY]);
    boxes.append(svg('rect', { x: x1, y: y1, width: x2 - x1, height: y2 - y1, class: `finding-box ${finding.state}`,
      'data-testid': 'finding-box', 'data-finding': finding.finding_id }, tip(`finding ${finding.finding_id}: ${finding.summary}`)));
  }
  const img = h('img', { alt: `${testid || 'map'} picture`, 'data-testid': testid });
  const unavailable = h('p', { class: 'muted', hidden: true }, 'No picture: this version has no occupancy patches in its home component.');
  img.addEventListener('error', () => { unavailable.hidden = false; });
  loadImage(img, src);
  const overlay = svg('svg', { viewBox: `0 0 ${grid.width} ${grid.height}`, preserveAspectRatio: 'none', class: 'graph-overlay',
    'data-testid': `${testid}-overlay` }, drawMetadata(metadata, project, grid), ...groups, boxes);
  const element = h('figure', {}, h('div', { class: 'mapview' }, img, grid.width > 0 ? overlay : null), unavailable,
    caption ? h('figcaption', { class: 'muted' }, caption) : null);
  let highlighted = null;
  return {
    element,
    highlight(key) {
      if (highlighted) highlighted.classList.remove('selected');
      highlighted = key ? lines.get(key) || null : null;
      if (highlighted) {
        highlighted.classList.add('selected');
        highlighted.parentNode.append(highlighted);  // on top of its layer
      }
    },
  };
}

/// Components other than the home one: not in the picture's frame, so each gets a small drawing of its own.
export function otherComponents(graph, findings) {
  const home = homeComponent(graph);
  const others = graph.components.filter((c) => c.id !== home);
  if (others.length === 0) return null;
  const flagged = flaggedEdges(findings);
  return h('div', { class: 'components-panel', 'data-testid': 'other-components' },
    h('p', { class: 'muted' }, `${others.length} more component(s), not in the picture (each has its own frame; the robot has not linked them to the home component):`),
    h('div', { class: 'row-tight' }, others.map((component) => {
      const members = graph.nodes.filter((n) => n[4] === component.id);
      const xs = members.map((n) => n[1]), ys = members.map((n) => n[2]);
      const minX = Math.min(...xs), maxY = Math.max(...ys);
      const span = Math.max(Math.max(...xs) - minX, maxY - Math.min(...ys), 0.5), pad = span * 0.08;
      const project = ([, x, y]) => [x - minX + pad, maxY - y + pad];
      const { groups } = drawEdges(graph, new Map(members.map((n) => [nodeId(n), n])), project, flagged, { withKeys: false });
      return h('figure', {}, svg('svg', { viewBox: `0 0 ${span + 2 * pad} ${span + 2 * pad}`, class: 'component-sketch' }, ...groups),
        h('figcaption', { class: 'muted' }, `component ${component.id} · ${component.nodes} nodes`));
    })));
}

/// The rooms, zones and walls an imported map carries (its metadata), beside the picture that draws them.
export function metadataPanel(metadata) {
  if (!metadata) return null;
  const count = (list, one) => `${list.length} ${one}${list.length === 1 ? '' : 's'}`;
  return h('div', { class: 'metadata-panel', 'data-testid': 'metadata-panel' },
    h('p', { class: 'muted' }, `From the ${metadata.format || 'imported'} export: ${count(metadata.rooms, 'room')}, `,
      `${count(metadata.zones, 'zone')}, ${count(metadata.virtual_walls, 'virtual wall')}, ${count(metadata.paths, 'path')}; handed back with the map.`),
    metadata.rooms.length ? h('table', { class: 'compact', 'data-testid': 'rooms' },
      h('tr', {}, h('th', {}, 'room'), h('th', {}, 'segment'), h('th', {}, 'area m²')),
      metadata.rooms.map((room) => h('tr', { 'data-testid': 'room' }, h('td', {}, roomName(room)), h('td', {}, room.segment_id),
        h('td', { class: 'num' }, room.area_m2.toFixed(1))))) : null);
}

export function overlayLegend(metadata) {
  const swatch = (cls, label) => h('span', {}, h('i', { class: cls }), label);
  return h('div', { class: 'legend' },
    swatch('swatch-motion', 'odometry (motion edges)'), swatch('swatch-observation', 'observation edges'),
    swatch('swatch-flagged', 'edges a finding flags'), swatch('swatch-box', 'protrusion finding (dashed: cut out)'),
    metadata ? [swatch('swatch-zone', 'no-go zone (dashed blue: active zone)'), swatch('swatch-virtual-wall', 'virtual wall'),
      swatch('swatch-path', "the robot's path"), swatch('swatch-dock', 'dock (blue: robot)')] : null,
    h('span', {}, 'hover a constraint row to find its edge'));
}
