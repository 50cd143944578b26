// Small DOM helpers shared by the pages.
export function h(tag, attrs = {}, ...children) {
  const element = document.createElement(tag);
  for (const [key, value] of Object.entries(attrs || {})) {
    if (value === undefined || value === null || value === false) continue;
    if (key === 'class') element.className = value;
    else if (key === 'dataset') Object.assign(element.dataset, value);
    else if (key.startsWith('on')) element.addEventListener(key.slice(2), value);
    else element.setAttribute(key, value === true ? '' : value);
  }
  for (const child of children.flat()) {
    if (child === null || child === undefined || child === false) continue;
    element.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return element;
}

export const pct = (value, digits = 1) => (value === null || value === undefined ? '—' : `${(100 * value).toFixed(digits)} %`);
export const num = (value, digits = 2) =>
  value === null || value === undefined ? '—' : Number.isInteger(value) ? value.toLocaleString('en') : value.toFixed(digits);
export const time = (ms) => (ms ? new Date(ms).toISOString().replace('T', ' ').slice(0, 16) : '—');

export function kpi(label, value, testid) {
  return h('div', { class: 'kpi', 'data-testid': testid }, h('div', { class: 'value' }, value), h('div', { class: 'label' }, label));
}

export function card(title, ...body) {
  return h('section', { class: 'card' }, h('h2', {}, title), ...body);
}

/// The page's state for people (an empty or error panel) and for tests (main[data-state]).
export function setState(main, state) { main.dataset.state = state; }

/// Navigates to a hash route. The page says "loading" at once: the browser fires hashchange later, and until
/// then the old page would still claim to be ready for the new address. The same address renders again.
export function go(hash) {
  const target = new URL(hash.startsWith('#') ? hash : `#${hash}`, location.href).hash;
  setState(document.getElementById('main'), 'loading');
  if (location.hash === target) window.dispatchEvent(new HashChangeEvent('hashchange'));
  else location.hash = target;
}

export function emptyState(message, hint) {
  return h('div', { class: 'empty', 'data-testid': 'empty-state' }, h('p', {}, message), hint ? h('p', { class: 'muted' }, hint) : null);
}

export function errorState(error) {
  const status = error && error.status ? ` (HTTP ${error.status})` : '';
  return h('div', { class: 'error', 'data-testid': 'error-state', role: 'alert' },
    h('strong', {}, 'Could not load this page'), h('p', {}, `${error.message || error}${status}`),
    h('button', { class: 'secondary', onclick: () => go(location.hash) }, 'Retry'));
}

export const NO_RUNS_HINT = h('span', {}, 'No runs yet — upload with ',
  h('code', {}, 'fleetsim --world DIR --robots 3 --runs 2 --upload HOST:PORT --token TOKEN'));

export function noRuns() {
  return emptyState('No runs yet — upload with fleetsim --upload …',
    'e.g. fleetsim --world data/floorplans --robots 3 --runs 2 --upload 127.0.0.1:50051 --token "$TOKEN"; analysis then runs in fleetd.');
}

export function filterValues(form) {
  const values = {};
  for (const element of form.querySelectorAll('[name]')) values[element.name] = element.value;
  return values;
}

/// yyyy-mm-dd (UTC) → milliseconds; the "to" date is inclusive, so it ends at the next midnight.
export function dateToMs(value, inclusiveEnd = false) {
  if (!value) return '';
  const ms = Date.parse(`${value}T00:00:00Z`);
  return Number.isNaN(ms) ? '' : String(ms + (inclusiveEnd ? 86400000 : 0));
}
