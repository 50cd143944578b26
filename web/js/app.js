// The dashboard: one page, hash routes, one module per page (pages/). Every page renders into <main> and
// sets main[data-state] to "ready", "empty" or "error" when it is done (the browser tests wait on it).
import { destroyAll } from './charts.js';
import { errorState, h, setState } from './ui.js';
import { getToken, onSignInNeeded, setToken, updateTokenStatus } from './api.js';
import * as overview from './pages/overview.js';
import * as runs from './pages/runs.js';
import * as run from './pages/run.js';
import * as experiments from './pages/experiments.js';
import * as labelling from './pages/labelling.js';
import * as jobs from './pages/jobs.js';
import * as maps from './pages/maps.js';
import * as mapHistory from './pages/maphistory.js';
import * as mapVersion from './pages/mapversion.js';

const routes = [
  { pattern: /^\/overview$/, page: overview, nav: 'overview' },
  { pattern: /^\/runs$/, page: runs, nav: 'runs' },
  { pattern: /^\/runs\/([^/]+)$/, page: run, nav: 'runs' },
  { pattern: /^\/experiments$/, page: experiments, nav: 'experiments' },
  { pattern: /^\/labelling$/, page: labelling, nav: 'labelling' },
  { pattern: /^\/jobs$/, page: jobs, nav: 'jobs' },
  { pattern: /^\/maps$/, page: maps, nav: 'maps' },
  { pattern: /^\/robots\/([^/]+)\/maps$/, page: mapHistory, nav: 'maps' },
  { pattern: /^\/robots\/([^/]+)\/maps\/([^/]+)$/, page: mapVersion, nav: 'maps' },
];

let current = null;   // the page module rendered now (its stop() ends timers)
let generation = 0;   // a newer navigation wins over a slow older one

async function navigate() {
  const [path, queryString] = (location.hash.slice(1) || '/overview').split('?');
  const route = routes.find((r) => r.pattern.test(path));
  if (!route) { location.hash = '#/overview'; return; }
  if (current && current.stop) current.stop();
  destroyAll();
  const main = document.getElementById('main');
  main.replaceChildren();
  setState(main, 'loading');
  for (const link of document.querySelectorAll('[data-nav]')) link.classList.toggle('active', link.dataset.nav === route.nav);
  document.body.dataset.page = route.nav;
  current = route.page;
  const mine = ++generation;
  const args = path.match(route.pattern).slice(1).map(decodeURIComponent);
  try {
    await route.page.render(main, { args, query: new URLSearchParams(queryString || ''), isCurrent: () => mine === generation });
  } catch (error) {
    if (mine !== generation || main.dataset.state === 'signin') return;
    if (error && error.status) console.warn(error.message); else console.error(error);
    destroyAll();
    main.replaceChildren(errorState(error));
    setState(main, 'error');
  }
}

/// fleetd serves no data without a token: the form asks for one (any role's; labelling and repairs need an
/// engineer's), keeps it in sessionStorage for this tab, and renders the page again. A 401 brings it back.
function signIn() {
  if (current && current.stop) current.stop();
  destroyAll();
  ++generation;
  const main = document.getElementById('main');
  const input = h('input', { type: 'password', autocomplete: 'off', placeholder: 'engineer:<name>.<secret>', 'data-testid': 'signin-token', size: 60 });
  const form = h('form', { class: 'signin', 'data-testid': 'signin' },
    h('h1', {}, 'Sign in'),
    h('p', { class: 'muted' }, 'Paste a fleetd token (fleetctl credentials set, or the one the main job printed). It is kept for this tab only.'),
    input, ' ', h('button', { type: 'submit', 'data-testid': 'signin-submit' }, 'Sign in'));
  form.addEventListener('submit', (event) => {
    event.preventDefault();
    if (!input.value.trim()) return;
    setToken(input.value.trim());
    navigate();
  });
  main.replaceChildren(form);
  setState(main, 'signin');
  input.focus();
}

onSignInNeeded(signIn);
window.addEventListener('hashchange', () => (getToken() ? navigate() : signIn()));
updateTokenStatus();
if (getToken()) navigate(); else signIn();
