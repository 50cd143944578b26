// A map image (parent, child or difference; all three share the child's cells) with the protrusion regions
// drawn over it as SVG rectangles, coloured by label, or by the classifier's class when unlabelled.
import { h } from './ui.js';
import { loadImage } from './api.js';

const SVG = 'http://www.w3.org/2000/svg';

export function regionClass(region) { return region.label || region.predicted_class || 'unclassified'; }
/// What decided the region's class, in words: the run's own views (they show the robot slipped while drawing
/// it) or the map-only classifier; '—' for regions analysed before the server kept it.
export function decidedByText(region) {
  return { views: "the run's views", classifier: 'the classifier', none: 'no classifier' }[region.decided_by] || '—';
}

export function mapView(src, info, regions, { testid, onRegionClick, selected } = {}) {
  const img = loadImage(h('img', { alt: testid || 'map', 'data-testid': testid }), src);
  const svg = document.createElementNS(SVG, 'svg');
  svg.setAttribute('viewBox', `0 0 ${info.width} ${info.height}`);
  svg.setAttribute('preserveAspectRatio', 'none');
  for (const region of regions) {
    const [x, y, width, height] = region.bbox;
    const rect = document.createElementNS(SVG, 'rect');
    const pad = 2;
    rect.setAttribute('x', x - pad); rect.setAttribute('y', y - pad);
    rect.setAttribute('width', width + 2 * pad); rect.setAttribute('height', height + 2 * pad);
    rect.setAttribute('class', `region ${regionClass(region)}${selected === region.region_id ? ' selected' : ''}`);
    rect.dataset.region = region.region_id;
    rect.dataset.testid = 'region';
    const title = document.createElementNS(SVG, 'title');
    title.textContent = `region ${region.region_id}: ${regionClass(region)}${region.label ? ' (labelled)' : ` (decided by ${decidedByText(region)})`}`;
    rect.append(title);
    if (onRegionClick) rect.addEventListener('click', () => onRegionClick(region));
    svg.append(rect);
  }
  return h('div', { class: 'mapview' }, img, svg);
}
