// The pose graph of a run's rerun child map as SVG: motion edges coloured by component, observation edges
// in grey, the hypotheses' observations dashed by how they ended (accepted, conditional merge, rejected,
// expired), views as dots, ambiguous views as red rings.
import { color } from './charts.js';
import { h } from './ui.js';

const SVG = 'http://www.w3.org/2000/svg';
const statusStyle = {
  accepted: { stroke: '#2e9d5b', dash: '' },
  conditionally_accepted: { stroke: '#e0a100', dash: '6 3' },
  rejected: { stroke: '#d64541', dash: '2 3' },
  expired: { stroke: '#9aa1ad', dash: '2 3' },
  open: { stroke: '#7b4fd1', dash: '4 4' },
};

function el(tag, attrs) {
  const element = document.createElementNS(SVG, tag);
  for (const [key, value] of Object.entries(attrs)) element.setAttribute(key, value);
  return element;
}

export function poseGraph(graph) {
  const svg = el('svg', { 'data-testid': 'pose-graph', preserveAspectRatio: 'xMidYMid meet' });
  if (graph.nodes.length === 0) return svg;
  const xs = graph.nodes.map((n) => n.x), ys = graph.nodes.map((n) => n.y);
  const minX = Math.min(...xs), maxX = Math.max(...xs), minY = Math.min(...ys), maxY = Math.max(...ys);
  const span = Math.max(maxX - minX, maxY - minY, 1), pad = span * 0.05;
  svg.setAttribute('viewBox', `${minX - pad} ${-(maxY + pad)} ${maxX - minX + 2 * pad} ${maxY - minY + 2 * pad}`);
  const width = span / 400;  // ~1 px at the usual size
  const byId = new Map(graph.nodes.map((n) => [n.id, n]));
  const componentIndex = new Map(graph.components.map((c, i) => [c.id, i]));
  const line = (a, b, attrs) => el('line', { x1: a.x, y1: -a.y, x2: b.x, y2: -b.y, ...attrs });
  const layers = { observation: el('g', {}), motion: el('g', {}), hypotheses: el('g', {}), views: el('g', {}) };
  for (const edge of graph.edges) {
    const a = byId.get(edge.from), b = byId.get(edge.to);
    if (!a || !b) continue;
    if (edge.kind === 'motion') {
      layers.motion.append(line(a, b, { stroke: color(componentIndex.get(a.component) || 0), 'stroke-width': 2 * width }));
    } else {
      layers.observation.append(line(a, b, { stroke: '#b8bec9', 'stroke-width': width, 'data-kind': 'observation' }));
    }
  }
  for (const edge of graph.hypothesis_edges) {
    const a = byId.get(edge.from), b = byId.get(edge.to);
    if (!a || !b) continue;
    const style = edge.conditional_merge && edge.status !== 'accepted' ? statusStyle.conditionally_accepted : (statusStyle[edge.status] || statusStyle.open);
    const dash = style.dash ? style.dash.split(' ').map((v) => v * width * 2).join(' ') : '';
    const item = line(a, b, { stroke: style.stroke, 'stroke-width': 1.5 * width, 'stroke-dasharray': dash, 'data-kind': 'hypothesis', 'data-status': edge.status });
    const title = el('title', {});
    title.textContent = `${edge.kind} hypothesis ${edge.hypothesis}: ${edge.status}${edge.conditional_merge ? ' (was conditionally merged)' : ''}, view ${edge.view} at t=${edge.time.toFixed(1)} s`;
    item.append(title);
    layers.hypotheses.append(item);
  }
  for (const view of graph.views) {
    const n = byId.get(view.node);
    if (!n) continue;
    const dot = el('circle', { cx: n.x, cy: -n.y, r: (view.ambiguous ? 6 : 3) * width,
      fill: view.ambiguous ? 'none' : '#1d2433', stroke: view.ambiguous ? '#d64541' : 'none', 'stroke-width': 2 * width,
      'data-kind': view.ambiguous ? 'ambiguous-view' : 'view' });
    const title = el('title', {});
    title.textContent = `view ${view.id}${view.ambiguous ? ' — ambiguous' : ''}`;
    dot.append(title);
    layers.views.append(dot);
  }
  svg.append(layers.observation, layers.motion, layers.hypotheses, layers.views);
  return svg;
}

export function poseGraphLegend(graph) {
  const swatch = (stroke, dash, label) => h('span', {}, h('i', { style: `background:${stroke};${dash ? 'opacity:.7' : ''}` }), label);
  const counts = {};
  for (const e of graph.hypothesis_edges) counts[e.status] = (counts[e.status] || 0) + 1;
  const conditional = graph.hypothesis_edges.filter((e) => e.conditional_merge).length;
  return h('div', { class: 'legend' },
    ...graph.components.map((c, i) => swatch(color(i), '', `component ${c.id} (${c.nodes} nodes)`)),
    swatch('#b8bec9', '', 'observation edge'),
    swatch('#2e9d5b', '', `hypothesis accepted (${counts.accepted || 0})`),
    swatch('#e0a100', '-', `conditional merge (${conditional})`),
    swatch('#d64541', '-', `rejected (${counts.rejected || 0})`),
    swatch('#9aa1ad', '-', `expired (${counts.expired || 0})`),
    h('span', {}, h('i', { style: 'background:none;border:2px solid #d64541;border-radius:50%;width:10px;height:10px' }),
      `ambiguous view (${graph.views.filter((v) => v.ambiguous).length} of ${graph.views.length})`));
}
